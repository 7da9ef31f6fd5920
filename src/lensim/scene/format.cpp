#include "lensim/scene/format.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "lensim/scene/description.h"

namespace lensim::scene {

namespace {

std::string inputStr(const Scene& scene, const Input& in, bool is_float) {
  if (in.texture >= 0)
    return fmt::format("texture \"{}\"", scene.textures[static_cast<size_t>(in.texture)].name);
  return is_float ? fmt::format("{}", in.value) : in.spectrum.str();
}

std::string plural(size_t n, std::string_view word) {
  return fmt::format("{} {}{}", n, word, n == 1 ? "" : (word.ends_with("sh") ? "es" : "s"));
}

// "a ×2, b ×1" from ordered counts.
std::string countList(const std::vector<std::pair<std::string, int>>& counts) {
  std::string s;
  for (const auto& [k, n] : counts) s += fmt::format("{}{} ×{}", s.empty() ? "" : ", ", k, n);
  return s;
}

void addCount(std::vector<std::pair<std::string, int>>& counts, const std::string& key) {
  for (auto& [k, n] : counts)
    if (k == key) {
      ++n;
      return;
    }
  counts.push_back({key, 1});
}

std::string renamed(const std::string& written, const std::string& used) {
  if (written == "(default)") return used + " (default)";
  if (written.empty() || written == used) return used;
  return fmt::format("{} (as {})", written, used);
}

/// The summary's text, one line at a time.
struct Lines {
  std::string text;
  void operator()(const std::string& s) { text += s + "\n"; }
};

/// The camera, its shutter and motion, and the scene's motion blur.
void cameraSummary(const Scene& scene, Lines& line) {
  const Camera& c = scene.camera;
  if (c.defaulted) {
    line("camera: perspective, fov 90° (default: no Camera directive)");
  } else if (c.legacy_realistic) {
    const LegacyRealistic& r = *c.legacy_realistic;
    line(fmt::format("camera: realistic, pbrt-v1/v2 parameters ({})", c.loc.str()));
    line(fmt::format("  lens: {} ({})", r.lens_file_as_written, r.lens_file));
    line(fmt::format("  focus: film distance {} mm (set by the scene{})", r.film_distance_mm,
                     r.af_zones_file.empty() ? "" : "; autofocus zones " + r.af_zones_file));
    line(fmt::format("  aperture diameter {} mm, film diagonal {} mm", r.aperture_diameter_mm,
                     r.film_diagonal_mm));
    double units = length(c.camera_from_world.applyVector({1, 0, 0}));
    line(fmt::format("  camera space: millimetres, {} mm per world unit; hither {} mm, yon {} mm",
                     units, c.hither, c.yon));
  } else if (c.realistic) {
    const Realistic& r = *c.realistic;
    line(fmt::format("camera: realistic, pbrt-v3/v4 parameters ({})", c.loc.str()));
    line(fmt::format("  lens: {} ({}), lens millimetres → scene metres", r.lens_file_as_written,
                     r.lens_file));
    line(fmt::format("  focus: focus distance {} m (film distance solved from the lens)",
                     r.focus_distance_m));
    line(fmt::format("  aperture diameter {} mm{}; film diagonal {} mm", r.aperture_diameter_mm,
                     r.aperture.empty() ? "" : fmt::format(", aperture \"{}\"", r.aperture),
                     scene.film.diagonal_mm));
  } else if (c.type == "perspective" && c.type_as_written == "perspective") {
    line(fmt::format("camera: perspective, fov {}°{} ({})", c.fov_deg,
                     c.lens_radius > 0 ? fmt::format(", lens radius {}, focal distance {}",
                                                     c.lens_radius, c.focal_distance)
                                       : "",
                     c.loc.str()));
  } else {
    line(fmt::format("camera: {} ({})", renamed(c.type_as_written, c.type), c.loc.str()));
  }
  if (!c.defaulted) line(fmt::format("  shutter {} to {}", c.shutter_open, c.shutter_close));
  if (c.camera_from_world != c.camera_from_world_end)
    line(fmt::format("  the camera moves (animated transform, times {} to {})",
                     c.transform_start_time, c.transform_end_time));
  if (!scene.motions.empty()) {
    size_t moving_shapes = 0, moving_instances = 0;
    for (const Shape& sh : scene.shapes) moving_shapes += sh.motion >= 0;
    for (const Instance& i : scene.instances) moving_instances += i.motion >= 0;
    line(fmt::format("motion blur: {} shape{} and {} instance{} move (animated transforms)",
                     moving_shapes, moving_shapes == 1 ? "" : "s", moving_instances,
                     moving_instances == 1 ? "" : "s"));
  }
}

/// Shapes by type, triangles (stored and with instances expanded), objects and instances.
void geometrySummary(const Scene& scene, Lines& line) {
  std::vector<std::pair<std::string, int>> world, inObjects;
  size_t nWorld = 0, nObj = 0;
  for (const Shape& sh : scene.shapes) {
    std::string t(shapeTypeName(sh.type));
    if (sh.type_as_written != t) t = fmt::format("{} (as {})", sh.type_as_written, t);
    addCount(sh.object < 0 ? world : inObjects, t);
    ++(sh.object < 0 ? nWorld : nObj);
  }
  line(fmt::format("shapes: {} in the world{}, {} in object definitions{}", nWorld,
                   world.empty() ? "" : " (" + countList(world) + ")", nObj,
                   inObjects.empty() ? "" : " (" + countList(inObjects) + ")"));
  // Triangles stored, and as rendered with every instance expanded.
  auto meshTriangles = [&](const Shape& sh) -> size_t {
    if (sh.mesh < 0) return 0;
    const Mesh& m = scene.meshes[static_cast<size_t>(sh.mesh)];
    return m.faceCount() * (m.vertices_per_face == 4 ? 2 : 1);
  };
  size_t expanded = 0;
  for (const Shape& sh : scene.shapes)
    if (sh.object < 0) expanded += meshTriangles(sh);
  for (const Instance& i : scene.instances)
    for (int si : scene.objects[static_cast<size_t>(i.object)].shapes)
      expanded += meshTriangles(scene.shapes[static_cast<size_t>(si)]);
  line(fmt::format(
      "triangles: {} in {}{}", scene.triangleCount(), plural(scene.meshes.size(), "mesh"),
      expanded != scene.triangleCount() ? fmt::format(" ({} with instances expanded)", expanded)
                                        : ""));
  std::string objs;
  for (const ObjectDef& o : scene.objects) {
    std::vector<std::pair<std::string, int>> k;
    for (int si : o.shapes)
      addCount(k, std::string(shapeTypeName(scene.shapes[static_cast<size_t>(si)].type)));
    objs += fmt::format("{}\"{}\" ({})", objs.empty() ? ": " : ", ", o.name,
                        k.empty() ? "empty" : countList(k));
  }
  line(fmt::format("objects: {}{}", scene.objects.size(), objs));
  std::vector<std::pair<std::string, int>> inst;
  for (const Instance& i : scene.instances)
    addCount(inst, fmt::format("\"{}\"", scene.objects[static_cast<size_t>(i.object)].name));
  line(fmt::format("instances: {}{}", scene.instances.size(),
                   inst.empty() ? "" : ": " + countList(inst)));
}

/// Materials by type, and each texture with its inputs.
void materialsSummary(const Scene& scene, Lines& line) {
  std::vector<std::pair<std::string, int>> mats;
  for (const Material& m : scene.materials) {
    std::string key = m.fallback
                          ? fmt::format("{} (not rendered: as diffuse grey)", m.type_as_written)
                          : renamed(m.type_as_written, m.type);
    addCount(mats, key);
  }
  line(fmt::format("materials: {}{}", scene.materials.size(),
                   mats.empty() ? "" : ": " + countList(mats)));
  line(fmt::format("textures: {}", scene.textures.size()));
  for (const Texture& t : scene.textures) {
    bool fl_kind = t.kind == TextureKind::Float;
    std::string what = fmt::format("  \"{}\": {} {}", t.name, fl_kind ? "float" : "spectrum",
                                   renamed(t.type_as_written, t.type));
    if (t.type == "imagemap") {
      what += fmt::format(" \"{}\"", t.filename_as_written);
      if (t.uscale != 1 || t.vscale != 1)
        what += fmt::format(", uv scale {} × {}", t.uscale, t.vscale);
    } else if (t.type == "scale") {
      what += fmt::format(": {} × {}", inputStr(scene, t.tex1, fl_kind),
                          inputStr(scene, t.tex2, fl_kind || t.scale_is_float));
    } else if (t.type == "mix") {
      what += fmt::format(": {}, {}, amount {}", inputStr(scene, t.tex1, fl_kind),
                          inputStr(scene, t.tex2, fl_kind), inputStr(scene, t.amount, true));
    } else if (t.type == "checkerboard") {
      what += fmt::format(": {}, {}, {}D, uv scale {} × {}", inputStr(scene, t.tex1, fl_kind),
                          inputStr(scene, t.tex2, fl_kind), t.dimension, t.uscale, t.vscale);
    } else {
      what += fmt::format(": {}", inputStr(scene, t.tex1, fl_kind));
    }
    line(what);
  }
}

/// Each light: area lights with the shapes they are on, others with their emission.
void lightsSummary(const Scene& scene, Lines& line) {
  line(fmt::format("lights: {}", scene.lights.size()));
  for (const Light& l : scene.lights) {
    if (l.type == "diffuse") {
      std::vector<std::pair<std::string, int>> k;
      for (const Shape& sh : scene.shapes)
        if (sh.area_light >= 0 && &scene.lights[static_cast<size_t>(sh.area_light)] == &l)
          addCount(k, std::string(shapeTypeName(sh.type)));
      line(fmt::format("  area light {}: L {}{}{}, on {}{}", renamed(l.type_as_written, l.type),
                       l.emission.str(), l.scale != 1 ? fmt::format(", scale {}", l.scale) : "",
                       l.two_sided ? ", two-sided" : "",
                       plural(static_cast<size_t>(l.shape_count), "shape"),
                       k.empty() ? "" : " (" + countList(k) + ")"));
    } else {
      line(fmt::format("  {}: {} {}{}{}", l.type, l.type == "point" || l.type == "spot" ? "I" : "L",
                       l.emission.str(), l.scale != 1 ? fmt::format(", scale {}", l.scale) : "",
                       l.filename.empty() ? "" : fmt::format(", map \"{}\"", l.filename)));
    }
  }
}

/// Each participating medium, and the one the camera is in.
void mediaSummary(const Scene& scene, Lines& line) {
  if (scene.media.empty()) return;
  line(fmt::format("media: {}", scene.media.size()));
  for (const Medium& m : scene.media) {
    if (m.type.empty()) {
      line(fmt::format("  \"{}\": {} (not rendered)", m.name, m.type_as_written));
      continue;
    }
    if (m.type == "cloud" || m.type == "nanovdb") {
      line(fmt::format("  \"{}\": {}{}{}, g {}", m.name, m.type,
                       m.type == "nanovdb" ? fmt::format(", \"{}\"", m.filename) : "",
                       m.scale != 1 ? fmt::format(", scale {}", m.scale) : "", m.g));
      continue;
    }
    if (m.type != "homogeneous") {
      line(fmt::format("  \"{}\": {}, {} × {} × {} voxels{}, g {}", m.name,
                       renamed(m.type_as_written, m.type), m.nx, m.ny, m.nz,
                       m.scale != 1 ? fmt::format(", scale {}", m.scale) : "", m.g));
      continue;
    }
    line(fmt::format("  \"{}\": {}, sigma_a {}, sigma_s {}{}{}, g {}{}", m.name, m.type,
                     m.sigma_a.str(), m.sigma_s.str(),
                     m.preset.empty() ? "" : fmt::format(" (preset \"{}\")", m.preset),
                     m.scale != 1 ? fmt::format(", scale {}", m.scale) : "", m.g,
                     m.Le.rgb == Vec3{0, 0, 0} && m.Le.kind == SpectrumValue::Kind::Rgb
                         ? ""
                         : fmt::format(", Le {} x {}", m.Le.str(), m.Le_scale)));
  }
  if (scene.camera.medium >= 0)
    line(fmt::format("  camera inside \"{}\"",
                     scene.media[static_cast<size_t>(scene.camera.medium)].name));
}

}  // namespace

std::string summary(const Scene& scene) {
  Lines line;
  line(fmt::format("scene: {} ({} syntax)", scene.path,
                   scene.legacy_syntax ? "pbrt-v1–v3" : "pbrt-v4"));
  cameraSummary(scene, line);
  const Film& f = scene.film;
  line(fmt::format("film: {}, {}×{}, output \"{}\"{}", renamed(f.type_as_written, f.type),
                   f.x_resolution, f.y_resolution, f.filename, f.defaulted ? " (default)" : ""));
  const Sampler& s = scene.sampler;
  line(fmt::format("sampler: {}, {} samples per pixel{}", renamed(s.type_as_written, s.type),
                   s.pixel_samples, s.defaulted ? " (default)" : ""));
  const Filter& fl = scene.filter;
  line(fmt::format(
      "pixel filter: {}, radius {} × {}{}", renamed(fl.type_as_written, fl.type), fl.x_radius,
      fl.y_radius,
      fl.defaulted ? (scene.legacy_syntax ? " (pbrt-v1–v3 default)" : " (default)") : ""));
  const Integrator& in = scene.integrator;
  line(fmt::format(
      "integrator: {}, maxdepth {}{}", renamed(in.type_as_written, in.type), in.max_depth,
      in.defaulted ? (scene.legacy_syntax ? " (pbrt-v1–v3 default)" : " (default)") : ""));
  geometrySummary(scene, line);
  materialsSummary(scene, line);
  lightsSummary(scene, line);
  mediaSummary(scene, line);
  size_t warnings = 0;
  for (const Diagnostic& d : scene.diagnostics) warnings += d.severity == Severity::Warning;
  line(fmt::format("warnings: {}", warnings));
  for (const Diagnostic& d : scene.diagnostics)
    if (d.severity == Severity::Warning) line("  " + d.str());
  return line.text;
}

namespace {

std::string quote(const std::string& s) {
  std::string r = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') r += '\\';
    if (c == '\n') {
      r += "\\n";
      continue;
    }
    r += c;
  }
  return r + "\"";
}

// pbrt-v4 parameter names for v1–v3 names with the same meaning, by directive and type.
std::string v4ParamName(const std::string& directive, const std::string& type,
                        const std::string& name) {
  if (directive == "Material" || directive == "MakeNamedMaterial") {
    if (name == "Kd" &&
        (type == "matte" || type == "plastic" || type == "uber" || type == "substrate"))
      return "reflectance";
    if (name == "Kr" && type == "mirror") return "reflectance";
    if (name == "index") return "eta";
    if (name == "bumpmap") return "displacement";
  }
  if (directive == "LightSource" && name == "mapname") return "filename";
  if ((directive == "PixelFilter" || directive == "Filter") && name == "xwidth") return "xradius";
  if ((directive == "PixelFilter" || directive == "Filter") && name == "ywidth") return "yradius";
  if (directive == "Shape" && name == "nlevels") return "levels";
  if (directive == "Shape" && name == "st") return "uv";
  if (directive == "Texture" && type == "scale" && name == "tex1") return "tex";
  return name;
}

std::string v4TypeName(const std::string& directive, const std::string& type) {
  static const std::map<std::string, std::string> materials = {
      {"matte", "diffuse"},           {"plastic", "coateddiffuse"}, {"uber", "coateddiffuse"},
      {"substrate", "coateddiffuse"}, {"metal", "conductor"},       {"mirror", "conductor"},
      {"glass", "dielectric"}};
  if (directive == "Material") {
    auto it = materials.find(type);
    return it == materials.end() ? type : it->second;
  }
  if (directive == "AreaLightSource" && type == "area") return "diffuse";
  if ((directive == "PixelFilter" || directive == "Filter") && type == "sinc") return "lanczos";
  if (directive == "Sampler" && (type == "lowdiscrepancy" || type == "02sequence"))
    return "paddedsobol";
  if (directive == "Sampler" && (type == "maxmindist" || type == "bestcandidate")) return "pmj02bn";
  if (directive == "Integrator" && type == "directlighting") return "path";
  if (directive == "Sampler" && type == "random") return "independent";
  if (directive == "Film" && type == "image") return "rgb";
  return type;
}

std::string paramStr(const std::string& directive, const std::string& type, const Param& p) {
  std::string t(paramTypeName(p.type));
  std::string name = v4ParamName(directive, type, p.name);
  // pbrt-v1–v3 float uv arrays are point2 in pbrt-v4.
  if (directive == "Shape" && name == "uv" && p.type == ParamType::Float) t = "point2";
  std::string values;
  for (double v : p.numbers) values += fmt::format("{}{}", values.empty() ? "" : " ", v);
  for (const std::string& s : p.strings)
    values += fmt::format("{}{}", values.empty() ? "" : " ", quote(s));
  for (bool b : p.bools) values += fmt::format("{}{}", values.empty() ? "" : " ", b);
  size_t n = p.numbers.size() + p.strings.size() + p.bools.size();
  return fmt::format("{} {}", quote(t + " " + name), n == 1 ? values : "[ " + values + " ]");
}

}  // namespace

std::string formatPbrtV4(const SceneDesc& desc) {
  std::string out =
      fmt::format("# {} in normalised pbrt-v4 syntax (lensim check --format)\n", desc.path);
  std::string file = desc.path;
  int indent = 0;
  for (const Directive& d : desc.directives) {
    if (d.loc.file != file) {
      file = d.loc.file;
      out += fmt::format("{:{}}# from {}\n", "", indent * 2, file);
    }
    std::string name = d.name;
    if (name == "Filter") name = "PixelFilter";
    if (name == "SurfaceIntegrator") name = "Integrator";
    if (name == "WorldEnd") continue;
    if (name == "AttributeEnd" || name == "TransformEnd" || name == "ObjectEnd")
      indent = std::max(0, indent - 1);
    std::string line = fmt::format("{:{}}", "", indent * 2);
    if (name == "VolumeIntegrator") line += "# (pbrt-v1–v3, no pbrt-v4 equivalent) ";
    if (name == "Renderer") line += "# (pbrt-v2, no pbrt-v4 equivalent) ";
    if (name == "Camera" && d.strings[0] == "realistic")
      for (const Param& p : d.params)
        if (p.name == "specfile")
          line += "# pbrt-v1/v2 realistic camera: no pbrt-v4 equivalent; lensim reads it as is\n" +
                  std::string(static_cast<size_t>(indent) * 2, ' ');
    line += name;
    std::string type = d.strings.empty() ? "" : d.strings[0];
    if (name == "Texture") type = d.strings[2];
    for (size_t i = 0; i < d.strings.size(); ++i) {
      std::string s = d.strings[i];
      if (i == 0 && name != "Texture") s = v4TypeName(name, s);
      if (name == "Texture" && i == 1 && (s == "color" || s == "rgb")) s = "spectrum";
      line += fmt::format(" {}", quote(s));
    }
    for (double v : d.numbers) line += fmt::format(" {}", v);
    if (!d.word.empty()) line += fmt::format(" {}", d.word);
    if (name == "Option") {  // pbrt-v4: Option "name" value
      const Param& p = d.params[0];
      std::string v = !p.strings.empty() ? quote(p.strings[0])
                      : !p.bools.empty() ? std::string(p.bools[0] ? "true" : "false")
                                         : fmt::format("{}", p.numbers.at(0));
      out += fmt::format("{} {} {}\n", line, quote(p.name), v);
      continue;
    }
    for (const Param& p : d.params) {
      // pbrt-v1–v3 sample counts that pbrt-v4 does not have.
      if ((name == "AreaLightSource" || name == "LightSource") && p.name == "nsamples") continue;
      if (name == "Sampler" && p.name == "dimensions") continue;
      if (name == "Integrator" &&
          (p.name == "rrthreshold" || (type == "directlighting" && p.name == "maxdepth")))
        continue;
      // A grey rgb factor of a pbrt-v1–v3 scale texture is pbrt-v4's float "scale".
      if (name == "Texture" && type == "scale" && p.name == "tex2" && p.type == ParamType::Rgb &&
          p.numbers.size() == 3 && p.numbers[0] == p.numbers[1] && p.numbers[1] == p.numbers[2]) {
        line += fmt::format(" \"float scale\" {}", p.numbers[0]);
        continue;
      }
      line += fmt::format(" {}", paramStr(name, type, p));
    }
    if (name == "Integrator" && type == "directlighting") line += " \"integer maxdepth\" 1";
    if (name == "Shape" && (type == "cone" || type == "paraboloid" || type == "hyperboloid"))
      line += "  # pbrt-v1–v3 shape (not in pbrt-v4); lensim reads it";
    out += line + "\n";
    if (name == "AttributeBegin" || name == "TransformBegin" || name == "ObjectBegin") ++indent;
  }
  return out;
}

}  // namespace lensim::scene
