#include "lensim/scene/builder.h"
#include "lensim/scene/shapes_tessellated.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <set>
#include <unordered_map>

#include "lensim/io/ply.h"
#include "lensim/scene/film_sensor.h"
#include "lensim/scene/media_presets.h"
#include "lensim/scene/params.h"
#include "lensim/util/limits.h"

namespace lensim::scene {

namespace fs = std::filesystem;

std::string_view shapeTypeName(ShapeType t) {
  switch (t) {
    case ShapeType::Sphere:
      return "sphere";
    case ShapeType::Disk:
      return "disk";
    case ShapeType::Cylinder:
      return "cylinder";
    case ShapeType::Cone:
      return "cone";
    case ShapeType::TriangleMesh:
      return "trianglemesh";
    case ShapeType::BilinearMesh:
      return "bilinearmesh";
    case ShapeType::Curve:
      return "curve";
  }
  return "?";
}

std::string SpectrumValue::str() const {
  switch (kind) {
    case Kind::Rgb:
      return fmt::format("rgb [{} {} {}]", rgb.x, rgb.y, rgb.z);
    case Kind::Blackbody:
      return blackbody_scale == 1
                 ? fmt::format("blackbody {}", temperature_k)
                 : fmt::format("blackbody [{} {}]", temperature_k, blackbody_scale);
    case Kind::Sampled: {
      std::string s = "spectrum [";
      for (size_t i = 0; i < samples.size(); ++i)
        s += fmt::format("{}{} {}", i ? " " : "", samples[i].first, samples[i].second);
      return s + "]";
    }
    case Kind::Named:
    case Kind::File:
      return fmt::format("spectrum \"{}\"", name);
  }
  return {};
}

bool Scene::hasErrors() const {
  for (const Diagnostic& d : diagnostics)
    if (d.severity == Severity::Error) return true;
  return false;
}

size_t Scene::triangleCount() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.faceCount() * (m.vertices_per_face == 4 ? 2 : 1);
  return n;
}

Bounds3 objectBounds(const Scene& scene, const Shape& s) {
  Bounds3 b;
  switch (s.type) {
    case ShapeType::Sphere:
      b.extend({-s.radius, -s.radius, s.zmin});
      b.extend({s.radius, s.radius, s.zmax});
      break;
    case ShapeType::Cylinder:
      b.extend({-s.radius, -s.radius, s.zmin});
      b.extend({s.radius, s.radius, s.zmax});
      break;
    case ShapeType::Disk:
      b.extend({-s.radius, -s.radius, s.height});
      b.extend({s.radius, s.radius, s.height});
      break;
    case ShapeType::Cone:
      b.extend({-s.radius, -s.radius, 0});
      b.extend({s.radius, s.radius, s.height});
      break;
    case ShapeType::TriangleMesh:
    case ShapeType::BilinearMesh:
      if (s.mesh >= 0)
        for (const Vec3f& p : scene.meshes[static_cast<size_t>(s.mesh)].positions)
          b.extend(Vec3(p));
      break;
    case ShapeType::Curve:
      if (s.curve >= 0) {
        const Curve& c = scene.curves[static_cast<size_t>(s.curve)];
        for (size_t i = 0; i < c.cp.size(); ++i) {
          const double r = 0.5 * c.width[i];
          b.extend(c.cp[i] - Vec3{r, r, r});
          b.extend(c.cp[i] + Vec3{r, r, r});
        }
      }
      break;
  }
  return b;
}

Bounds3 worldBounds(const Scene& scene, const Instance& inst) {
  Bounds3 b;
  if (inst.object < 0) return b;
  for (int si : scene.objects[static_cast<size_t>(inst.object)].shapes) {
    const Shape& s = scene.shapes[static_cast<size_t>(si)];
    b.extend((inst.transform * s.transform).applyBounds(objectBounds(scene, s)));
  }
  return b;
}

namespace {

// pbrt-v4's named spectra (util/spectrum.cpp): materials and illuminants by exact name; camera
// sensor curves by maker prefix.
const std::vector<std::string>& namedSpectra() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v = {"glass-BK7",    "glass-BAF10",  "glass-FK51A",  "glass-LASF9",
                                  "glass-F5",     "glass-F10",    "glass-F11",    "stdillum-A",
                                  "stdillum-D50", "stdillum-D65", "illum-acesD60"};
    for (const char* m : {"Ag", "Al", "Au", "Cu", "CuZn", "MgO", "TiO2"})
      for (const char* part : {"eta", "k"}) v.push_back(fmt::format("metal-{}-{}", m, part));
    for (int i = 1; i <= 12; ++i) v.push_back(fmt::format("stdillum-F{}", i));
    return v;
  }();
  return names;
}

enum class SpectrumName { Named, Unknown, NotAName };

SpectrumName classifySpectrumName(const std::string& n) {
  for (const std::string& k : namedSpectra())
    if (n == k) return SpectrumName::Named;
  for (const char* p : {"metal-", "glass-", "stdillum-", "illum-"})
    if (n.rfind(p, 0) == 0) return SpectrumName::Unknown;
  for (const char* p : {"canon_", "nikon_", "sony_", "hasselblad_", "fujifilm_", "dji_", "gopro_",
                        "apple_", "google_", "samsung_", "phase_one_"})
    if (n.rfind(p, 0) == 0) return SpectrumName::Named;
  return SpectrumName::NotAName;
}

// The edges of a triangle mesh and the one-rings of its vertices.
struct MeshTopology {
  struct Edge {
    int faces = 0;
    int opposite[2] = {-1, -1};
    int new_vertex = -1;
  };
  std::unordered_map<uint64_t, Edge> edges;
  std::vector<std::set<int>> neighbours;
  std::vector<std::vector<int>> boundary;  // neighbours across boundary edges

  static uint64_t key(int a, int b) {
    if (a > b) std::swap(a, b);
    return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) | static_cast<uint32_t>(b);
  }
  static std::pair<int, int> ends(uint64_t k) {
    return {static_cast<int>(k >> 32), static_cast<int>(k & 0xffffffffu)};
  }

  MeshTopology(size_t nv, const std::vector<int>& idx) : neighbours(nv), boundary(nv) {
    for (size_t f = 0; f + 2 < idx.size(); f += 3)
      for (size_t e = 0; e < 3; ++e) {
        int a = idx[f + e], b = idx[f + (e + 1) % 3], c = idx[f + (e + 2) % 3];
        Edge& info = edges[key(a, b)];
        if (info.faces < 2) info.opposite[info.faces] = c;
        ++info.faces;
      }
    for (const auto& [k, info] : edges) {
      auto [a, b] = ends(k);
      neighbours[a].insert(b);
      neighbours[b].insert(a);
      if (info.faces == 1) {
        boundary[a].push_back(b);
        boundary[b].push_back(a);
      }
    }
  }
};

// Loop subdivision (Loop 1987) of a triangle mesh, `levels` times, then the vertices are moved
// to the limit surface as pbrt does; boundary edges follow the cubic B-spline rules. Vertices on
// non-manifold or corner configurations keep their position. Normals are not computed.
void loopSubdivide(std::vector<Vec3>& P, std::vector<int>& idx, int levels) {
  auto beta = [](size_t n) { return n == 3 ? 3.0 / 16 : 3.0 / (8.0 * static_cast<double>(n)); };
  for (int level = 0; level < levels; ++level) {
    const size_t nv = P.size();
    MeshTopology topo(nv, idx);
    // Even (old) vertices.
    std::vector<Vec3> newP(nv);
    for (size_t v = 0; v < nv; ++v) {
      const auto& bnd = topo.boundary[v];
      size_t n = topo.neighbours[v].size();
      if (!bnd.empty() || n == 0) {
        newP[v] = bnd.size() == 2 ? P[v] * 0.75 + (P[bnd[0]] + P[bnd[1]]) * 0.125 : P[v];
        continue;
      }
      Vec3 sum;
      for (int u : topo.neighbours[v]) sum += P[u];
      newP[v] = P[v] * (1 - static_cast<double>(n) * beta(n)) + sum * beta(n);
    }
    // Odd (edge) vertices.
    for (auto& [k, e] : topo.edges) {
      auto [a, b] = MeshTopology::ends(k);
      e.new_vertex = static_cast<int>(newP.size());
      if (e.faces == 2)
        newP.push_back((P[a] + P[b]) * 0.375 + (P[e.opposite[0]] + P[e.opposite[1]]) * 0.125);
      else
        newP.push_back((P[a] + P[b]) * 0.5);
    }
    std::vector<int> newIdx;
    newIdx.reserve(idx.size() * 4);
    for (size_t f = 0; f + 2 < idx.size(); f += 3) {
      int v0 = idx[f], v1 = idx[f + 1], v2 = idx[f + 2];
      int e01 = topo.edges[MeshTopology::key(v0, v1)].new_vertex;
      int e12 = topo.edges[MeshTopology::key(v1, v2)].new_vertex;
      int e20 = topo.edges[MeshTopology::key(v2, v0)].new_vertex;
      newIdx.insert(newIdx.end(), {v0, e01, e20, v1, e12, e01, v2, e20, e12, e01, e12, e20});
    }
    P = std::move(newP);
    idx = std::move(newIdx);
  }
  if (levels == 0) return;
  // Limit positions: interior (1 - n g) v + g sum, g = 1 / (n + 3 / (8 beta));
  // boundary 3/5 v + 1/5 (b0 + b1).
  MeshTopology topo(P.size(), idx);
  std::vector<Vec3> limit(P.size());
  for (size_t v = 0; v < P.size(); ++v) {
    const auto& bnd = topo.boundary[v];
    size_t n = topo.neighbours[v].size();
    if (!bnd.empty() || n == 0) {
      limit[v] = bnd.size() == 2 ? P[v] * 0.6 + (P[bnd[0]] + P[bnd[1]]) * 0.2 : P[v];
      continue;
    }
    double g = 1 / (static_cast<double>(n) + 3 / (8 * beta(n)));
    Vec3 sum;
    for (int u : topo.neighbours[v]) sum += P[u];
    limit[v] = P[v] * (1 - static_cast<double>(n) * g) + sum * g;
  }
  P = std::move(limit);
}

// Graphics state pushed by AttributeBegin.
struct GraphicsState {
  Transform ctm[2];
  bool active[2] = {true, true};
  bool reverse_orientation = false;
  int material = -1;
  int area_light = -1;
  ParamList shape_attrs, light_attrs, material_attrs, texture_attrs, medium_attrs;
  // MediumInterface: medium names ("" is vacuum) and where they were given.
  std::string inside_medium, outside_medium;
  FileLoc medium_loc;
};

class Builder {
 public:
  explicit Builder(const SceneDesc& desc) : desc_(desc) {
    scene_.path = desc.path;
    scene_.legacy_syntax = desc.legacy_syntax;
    scene_.diagnostics = desc.diagnostics;
    top_dir_ = fs::path(desc.path).parent_path();
    // pbrt-v4's default integrator is volpath (on scenes without media it renders as path does,
    // within noise, for about 2% more time: bench/volpath).
    if (!desc.legacy_syntax) scene_.integrator.type = "volpath";
    if (desc.legacy_syntax) {
      // pbrt-v2 defaults where the file does not say.
      scene_.film.type = "rgb";
      scene_.film.type_as_written = "image";
      scene_.film.x_resolution = 640;
      scene_.film.y_resolution = 480;
      scene_.filter.type = "box";
      scene_.filter.x_radius = scene_.filter.y_radius = 0.5;
      // pbrt-v2's default surface integrator is directlighting: a path tracer of depth 1 here,
      // as for an explicit directlighting (the reference renders of the assignment's scenes
      // have no indirect light).
      scene_.integrator.type_as_written = "directlighting";
      scene_.integrator.max_depth = 1;
    }
  }

  bool pbrt_v2_ = false;  // the file uses syntax only pbrt-v1/v2 have

  Scene run() {
    for (const Directive& d : desc_.directives) {
      try {
        directive(d);
      } catch (const Error& e) {
        scene_.diagnostics.push_back(
            {Severity::Error, e.loc().valid() ? e.loc() : d.loc, e.message()});
      }
    }
    for (const auto& [name, loc, transform] : pending_instances_) {
      auto it = object_index_.find(name);
      if (it == object_index_.end()) {
        scene_.diagnostics.push_back(
            {Severity::Error, loc, fmt::format("ObjectInstance of unknown object \"{}\"", name)});
        continue;
      }
      scene_.instances.push_back({it->second, transform, loc});
    }
    resolveMedia();
    // pbrt-v1/v2 looked image textures up with t = 0 at the image's first (top) row; pbrt-v3
    // and v4 flip it. Files with syntax only v1/v2 have (a `specfile` realistic camera, a
    // SurfaceIntegrator or VolumeIntegrator) keep the v1/v2 orientation.
    if (pbrt_v2_)
      for (Texture& t : scene_.textures) t.rows_from_top = true;
    return std::move(scene_);
  }

 private:
  // ---- diagnostics -------------------------------------------------------------------------
  void warn(const FileLoc& loc, std::string msg) {
    scene_.diagnostics.push_back({Severity::Warning, loc, std::move(msg)});
  }
  void warnOnce(const std::string& key, const FileLoc& loc, std::string msg) {
    if (warned_.insert(key).second) warn(loc, std::move(msg));
  }
  void finish(ParamSet& ps) { ps.reportUnused(scene_.diagnostics); }

  // A singular current transform is accepted (pbrt-v4 keeps a NaN inverse:
  // src/pbrt/util/transform.h) and is an error only where it is applied to something rendered.
  void requireInvertible(const FileLoc& loc, std::string_view what, int which = 0) {
    if (gs_.ctm[which].isSingular())
      throw Error(loc, fmt::format("{}: the current transformation matrix is singular (not "
                                   "invertible), so it cannot place what is rendered",
                                   what));
  }

  // ---- light scale ---------------------------------------------------------------------------
  // pbrt-v4 reads a light's "scale" as a float; pbrt-v3 as a spectrum (`"rgb scale"`, `"color
  // scale"`, `"spectrum scale"`: pbrt-v3's CreatePointLight & co. call
  // paramSet.FindOneSpectrum("scale", Spectrum(1.0)) and multiply the emission by it in RGB).
  const Param* findLightScale(ParamSet& ps) {
    return ps.find({"scale"}, {ParamType::Float, ParamType::Rgb, ParamType::Spectrum});
  }
  void applyLightScale(const Param* p, Light& l) {
    if (!p) return;
    if (p->type == ParamType::Float) {
      if (p->numbers.size() != 1)
        throw Error(p->loc,
                    fmt::format("\"{}\": expected 1 value, got {}", p->name, p->numbers.size()));
      l.scale = p->numbers[0];
      return;
    }
    SpectrumValue sv = spectrumOf(*p);
    if (sv.kind == SpectrumValue::Kind::Rgb) {
      const Vec3 c = sv.rgb;
      if (c.x == c.y && c.y == c.z) {
        l.scale = c.x;  // grey: a plain factor
        return;
      }
      if (l.emission.kind == SpectrumValue::Kind::Rgb && l.filename.empty()) {
        // pbrt-v3 multiplies RGB emission by the RGB scale channel by channel; so does this.
        l.emission.rgb = {l.emission.rgb.x * c.x, l.emission.rgb.y * c.y, l.emission.rgb.z * c.z};
        return;
      }
      l.scale = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
      warn(p->loc, fmt::format("\"{}\": a coloured scale of a light whose emission is an image "
                               "or a spectrum is applied as its luminance {:.4g}",
                               p->name, l.scale));
      return;
    }
    double mean = 1;
    if (sv.kind == SpectrumValue::Kind::Sampled && !sv.samples.empty()) {
      mean = 0;
      for (const auto& [lambda, v] : sv.samples) mean += v;
      mean /= static_cast<double>(sv.samples.size());
    }
    l.scale = mean;
    warn(p->loc, fmt::format("\"{}\": a spectrum-valued light scale is applied as its mean value "
                             "{:.4g}",
                             p->name, mean));
  }

  // ---- files ---------------------------------------------------------------------------------
  // pbrt resolves file names relative to the top-level scene file's directory; lensim also
  // accepts them relative to the file that names them.
  std::string resolve(const std::string& name, const FileLoc& loc, std::string_view what) {
    fs::path p(name);
    std::vector<fs::path> candidates;
    if (p.is_absolute()) {
      candidates.push_back(p);
    } else {
      candidates.push_back((top_dir_ / p).lexically_normal());
      fs::path local = (fs::path(loc.file).parent_path() / p).lexically_normal();
      if (local != candidates[0]) candidates.push_back(local);
    }
    for (const fs::path& c : candidates) {
      std::error_code ec;
      if (fs::is_regular_file(c, ec)) return c.string();
    }
    throw Error(loc, fmt::format("{} \"{}\" not found (looked for {})", what, name,
                                 candidates[0].string()));
  }

  // ---- values --------------------------------------------------------------------------------
  SpectrumValue spectrumOf(const Param& p) {
    SpectrumValue s;
    switch (p.type) {
      case ParamType::Rgb:
        if (p.numbers.size() != 3)
          throw Error(p.loc, fmt::format("\"{}\": expected one rgb value (3 numbers), got {}",
                                         p.name, p.numbers.size()));
        s.kind = SpectrumValue::Kind::Rgb;
        s.rgb = {p.numbers[0], p.numbers[1], p.numbers[2]};
        if (s.rgb.x < 0 || s.rgb.y < 0 || s.rgb.z < 0)
          throw Error(p.loc, fmt::format("\"{}\": rgb value has a negative component", p.name));
        break;
      case ParamType::Blackbody:
        s.kind = SpectrumValue::Kind::Blackbody;
        s.temperature_k = p.numbers[0];
        if (p.numbers.size() > 1) s.blackbody_scale = p.numbers[1];
        if (!(s.temperature_k > 0 && s.temperature_k <= 1e6))
          throw Error(p.loc, fmt::format("\"{}\": blackbody temperature {} K is out of range; "
                                         "expected (0, 1e6] K",
                                         p.name, s.temperature_k));
        break;
      case ParamType::Spectrum:
        if (!p.strings.empty()) {
          const std::string& n = p.strings[0];
          SpectrumName c = classifySpectrumName(n);
          if (c == SpectrumName::Named) {
            s.kind = SpectrumValue::Kind::Named;
            s.name = n;
          } else if (c == SpectrumName::Unknown) {
            std::string best;
            size_t best_d = 3;
            for (const std::string& k : namedSpectra())
              if (size_t dist = editDistance(n, k); dist < best_d) best_d = dist, best = k;
            throw Error(
                p.loc,
                fmt::format("\"{}\": unknown named spectrum \"{}\"{}", p.name, n,
                            best.empty() ? "" : fmt::format("; did you mean \"{}\"?", best)));
          } else {
            s.kind = SpectrumValue::Kind::File;
            s.name = resolve(n, p.loc, "spectrum file");
          }
        } else {
          s.kind = SpectrumValue::Kind::Sampled;
          for (size_t i = 0; i + 1 < p.numbers.size(); i += 2) {
            if (!s.samples.empty() && !(p.numbers[i] > s.samples.back().first))
              throw Error(p.loc, fmt::format("\"{}\": spectrum wavelength {} nm after {} nm; "
                                             "expected increasing wavelengths",
                                             p.name, p.numbers[i], s.samples.back().first));
            s.samples.push_back({p.numbers[i], p.numbers[i + 1]});
          }
        }
        break;
      default:
        throw Error(p.loc, fmt::format("\"{}\": not a spectrum", p.name));
    }
    return s;
  }

  int textureIndex(const std::string& name, TextureKind kind, const FileLoc& loc) {
    auto& map = kind == TextureKind::Float ? float_textures_ : spectrum_textures_;
    auto it = map.find(name);
    if (it != map.end()) return it->second;
    auto& other = kind == TextureKind::Float ? spectrum_textures_ : float_textures_;
    throw Error(loc,
                fmt::format("unknown {} texture \"{}\"{}",
                            kind == TextureKind::Float ? "float" : "spectrum", name,
                            other.count(name)
                                ? fmt::format(" (\"{}\" is a {} texture)", name,
                                              kind == TextureKind::Float ? "spectrum" : "float")
                                : ""));
  }

  std::optional<Input> spectrumInput(ParamSet& ps, ParamSet::Names names) {
    const Param* p = ps.find(
        names, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody, ParamType::Texture});
    if (!p) return std::nullopt;
    Input in;
    if (p->type == ParamType::Texture)
      in.texture = textureIndex(p->strings[0], TextureKind::Spectrum, p->loc);
    else
      in.spectrum = spectrumOf(*p);
    return in;
  }
  Input spectrumInput(ParamSet& ps, ParamSet::Names names, double def) {
    auto in = spectrumInput(ps, names);
    if (in) return *in;
    Input d;
    d.spectrum = SpectrumValue::gray(def);
    return d;
  }

  std::optional<Input> floatInput(ParamSet& ps, ParamSet::Names names) {
    const Param* p = ps.find(names, {ParamType::Float, ParamType::Texture});
    if (!p) return std::nullopt;
    Input in;
    if (p->type == ParamType::Texture) {
      in.texture = textureIndex(p->strings[0], TextureKind::Float, p->loc);
    } else {
      ps.expectCount(*p, 1);
      in.value = p->numbers[0];
    }
    return in;
  }
  Input floatInput(ParamSet& ps, ParamSet::Names names, double def) {
    auto in = floatInput(ps, names);
    if (in) return *in;
    Input d;
    d.value = def;
    return d;
  }

  // ---- directives ----------------------------------------------------------------------------
  void directive(const Directive& d) {
    const std::string& n = d.name;
    GraphicsState& g = gs_;
    auto apply = [&](const Transform& t, bool concat) {
      for (int i = 0; i < 2; ++i)
        if (g.active[i]) g.ctm[i] = concat ? g.ctm[i] * t : t;
    };
    if (n == "Identity")
      apply(Transform(), false);
    else if (n == "Translate")
      apply(Transform::translate({d.numbers[0], d.numbers[1], d.numbers[2]}), true);
    else if (n == "Scale")
      apply(Transform::scale(d.numbers[0], d.numbers[1], d.numbers[2]), true);
    else if (n == "Rotate")
      apply(Transform::rotate(d.numbers[0], {d.numbers[1], d.numbers[2], d.numbers[3]}), true);
    else if (n == "LookAt")
      apply(Transform::lookAt({d.numbers[0], d.numbers[1], d.numbers[2]},
                              {d.numbers[3], d.numbers[4], d.numbers[5]},
                              {d.numbers[6], d.numbers[7], d.numbers[8]}),
            true);
    else if (n == "Transform" || n == "ConcatTransform") {
      std::array<double, 16> v{};
      std::copy(d.numbers.begin(), d.numbers.end(), v.begin());
      apply(Transform::fromPbrt(v), n == "ConcatTransform");
    } else if (n == "CoordinateSystem") {
      named_cs_[d.strings[0]] = {g.ctm[0], g.ctm[1]};
    } else if (n == "CoordSysTransform") {
      auto it = named_cs_.find(d.strings[0]);
      if (it == named_cs_.end()) {
        warn(d.loc, fmt::format("unknown coordinate system \"{}\"; the transform is unchanged",
                                d.strings[0]));
      } else {
        g.ctm[0] = it->second.first;
        g.ctm[1] = it->second.second;
      }
    } else if (n == "TransformTimes") {
      scene_.transform_start_time = d.numbers[0];
      scene_.transform_end_time = d.numbers[1];
    } else if (n == "ActiveTransform") {
      g.active[0] = d.word != "EndTime";
      g.active[1] = d.word != "StartTime";
    } else if (n == "ReverseOrientation") {
      g.reverse_orientation = !g.reverse_orientation;
    } else if (n == "WorldBegin") {
      g.ctm[0] = g.ctm[1] = Transform();
      named_cs_["world"] = {g.ctm[0], g.ctm[1]};
    } else if (n == "WorldEnd") {
      // pbrt v1–v3: end of the scene; nothing to do.
    } else if (n == "AttributeBegin") {
      checkStackMemory(d);
      stack_.push_back(gs_);
    } else if (n == "AttributeEnd") {
      popState(false);
    } else if (n == "TransformBegin") {
      // pbrt-v1–v3 save only the transform; pbrt-v4 treats it as AttributeBegin (deprecated).
      if (!scene_.legacy_syntax)
        warnOnce("TransformBegin", d.loc,
                 "TransformBegin/TransformEnd are deprecated in pbrt-v4 and act as "
                 "AttributeBegin/AttributeEnd");
      checkStackMemory(d);
      stack_.push_back(gs_);
    } else if (n == "TransformEnd") {
      popState(scene_.legacy_syntax);
    } else if (n == "ObjectBegin") {
      objectBegin(d);
    } else if (n == "ObjectEnd") {
      current_object_ = -1;
      popState(false);
    } else if (n == "ObjectInstance") {
      requireInvertible(d.loc, "ObjectInstance");
      if (g.ctm[0] != g.ctm[1])
        warnOnce("motion", d.loc,
                 "animated transforms are not rendered; the start transform is used");
      pending_instances_.push_back({d.strings[0], d.loc, g.ctm[0]});
    } else if (n == "Option") {
      option(d);
    } else if (n == "ColorSpace") {
      scene_.color_space = d.strings[0];
      if (d.strings[0] != "srgb")
        warnOnce("colorspace", d.loc,
                 fmt::format("color space \"{}\" is not rendered; colours are read as sRGB",
                             d.strings[0]));
    } else if (n == "Camera") {
      camera(d);
    } else if (n == "Film") {
      film(d);
    } else if (n == "Sampler") {
      sampler(d);
    } else if (n == "PixelFilter" || n == "Filter") {
      filter(d);
    } else if (n == "Integrator" || n == "SurfaceIntegrator") {
      if (n == "SurfaceIntegrator") pbrt_v2_ = true;
      integrator(d);
    } else if (n == "VolumeIntegrator") {
      pbrt_v2_ = true;
      ParamSet ps(d.params, d.loc, "VolumeIntegrator");
      ps.markAllUsed();
      warnOnce("VolumeIntegrator", d.loc,
               fmt::format("VolumeIntegrator \"{}\" is ignored: participating media are not "
                           "rendered",
                           d.strings[0]));
    } else if (n == "Renderer") {
      // pbrt-v2 only (pbrt-v3 and v4 have no such directive); its renderers' parameters
      // do not apply to lensim's path tracer.
      pbrt_v2_ = true;
      ParamSet ps(d.params, d.loc, "Renderer");
      ps.markAllUsed();
      warnOnce("Renderer", d.loc,
               fmt::format("Renderer \"{}\" (pbrt-v2) is ignored: lensim renders with its "
                           "Integrator",
                           d.strings[0]));
    } else if (n == "Accelerator") {
      ParamSet ps(d.params, d.loc, "Accelerator");
      ps.markAllUsed();
      warnOnce(
          "Accelerator", d.loc,
          fmt::format("Accelerator \"{}\" is ignored: lensim builds Embree BVHs", d.strings[0]));
    } else if (n == "MakeNamedMedium") {
      makeNamedMedium(d);
    } else if (n == "MediumInterface") {
      // One name: the same medium on both sides (pbrt-v4); names are resolved at the end.
      g.inside_medium = d.strings[0];
      g.outside_medium = d.strings.size() > 1 ? d.strings[1] : d.strings[0];
      g.medium_loc = d.loc;
    } else if (n == "Attribute") {
      attribute(d);
    } else if (n == "Shape") {
      shape(d);
    } else if (n == "Material") {
      ParamSet ps(d.params, d.loc, fmt::format("Material \"{}\"", d.strings[0]));
      ps.addDefaults(g.material_attrs);
      Material m = material(d.strings[0], ps, d.loc);
      finish(ps);
      scene_.materials.push_back(std::move(m));
      g.material = static_cast<int>(scene_.materials.size()) - 1;
    } else if (n == "MakeNamedMaterial") {
      ParamSet ps(d.params, d.loc, fmt::format("MakeNamedMaterial \"{}\"", d.strings[0]));
      ps.addDefaults(g.material_attrs);
      auto type = ps.findString({"type"});
      if (!type)
        throw Error(d.loc,
                    fmt::format("MakeNamedMaterial \"{}\": missing \"string type\"", d.strings[0]));
      Material m = material(*type, ps, d.loc);
      m.name = d.strings[0];
      finish(ps);
      if (named_materials_.count(m.name))
        warn(d.loc, fmt::format("named material \"{}\" redefined", m.name));
      scene_.materials.push_back(std::move(m));
      named_materials_[d.strings[0]] = static_cast<int>(scene_.materials.size()) - 1;
    } else if (n == "NamedMaterial") {
      auto it = named_materials_.find(d.strings[0]);
      if (it == named_materials_.end())
        throw Error(d.loc, fmt::format("NamedMaterial: unknown material \"{}\"", d.strings[0]));
      g.material = it->second;
    } else if (n == "Texture") {
      texture(d);
    } else if (n == "LightSource") {
      light(d);
    } else if (n == "AreaLightSource") {
      areaLight(d);
    } else {
      throw Error(d.loc, fmt::format("directive \"{}\" is not handled", n));
    }
  }

  void popState(bool transform_only) {
    if (stack_.empty()) return;  // the parser checked the nesting
    if (transform_only) {
      gs_.ctm[0] = stack_.back().ctm[0];
      gs_.ctm[1] = stack_.back().ctm[1];
    } else {
      gs_ = stack_.back();
    }
    stack_.pop_back();
  }

  void objectBegin(const Directive& d) {
    stack_.push_back(gs_);
    ObjectDef o;
    o.name = d.strings[0];
    o.loc = d.loc;
    scene_.objects.push_back(o);
    current_object_ = static_cast<int>(scene_.objects.size()) - 1;
    object_index_[o.name] = current_object_;
  }

  void option(const Directive& d) {
    static const std::set<std::string> known = {"disablepixeljitter",
                                                "disabletexturefiltering",
                                                "disablewavelengthjitter",
                                                "displacementedgescale",
                                                "msereferenceimage",
                                                "msereferenceout",
                                                "rendercoordsys",
                                                "seed",
                                                "forcediffuse",
                                                "pixelstats",
                                                "wavefront"};
    const Param& p = d.params[0];
    if (!known.count(p.name)) throw Error(p.loc, fmt::format("\"{}\": unknown option", p.name));
    std::vector<std::string> words;
    for (double x : p.numbers) words.push_back(fmt::format("{}", x));
    for (const std::string& s : p.strings) words.push_back(s);
    for (bool b : p.bools) words.push_back(b ? "true" : "false");
    scene_.options[p.name] = fmt::format("{}", fmt::join(words, " "));
  }

  void attribute(const Directive& d) {
    const std::string& target = d.strings[0];
    ParamList* list = target == "shape"      ? &gs_.shape_attrs
                      : target == "light"    ? &gs_.light_attrs
                      : target == "material" ? &gs_.material_attrs
                      : target == "texture"  ? &gs_.texture_attrs
                      : target == "medium"   ? &gs_.medium_attrs
                                             : nullptr;
    if (!list)
      throw Error(d.loc, fmt::format("Attribute: unknown target \"{}\" (expected shape, light, "
                                     "material, medium or texture)",
                                     target));
    for (const Param& p : d.params) {
      std::erase_if(*list, [&](const Param& q) { return q.name == p.name; });
      list->push_back(p);
    }
  }

  // ---- camera and options --------------------------------------------------------------------
  void camera(const Directive& d) {
    const std::string& type = d.strings[0];
    if (!scene_.camera.defaulted)
      warn(d.loc, fmt::format("second Camera (the first is at {}); the last one is used",
                              scene_.camera.loc.str()));
    ParamSet ps(d.params, d.loc, fmt::format("Camera \"{}\"", type));
    Camera c;
    c.defaulted = false;
    c.type_as_written = type;
    c.loc = d.loc;
    requireInvertible(d.loc, fmt::format("Camera \"{}\"", type));
    c.camera_from_world = gs_.ctm[0];
    c.camera_from_world_end = gs_.ctm[1];
    named_cs_["camera"] = {inverse(gs_.ctm[0]), inverse(gs_.ctm[1])};
    pending_media_.push_back({-1, "", gs_.outside_medium, gs_.medium_loc});
    c.shutter_open = ps.getFloat({"shutteropen"}, 0);
    c.shutter_close = ps.getFloat({"shutterclose"}, 1);
    c.hither = ps.getFloat({"hither"}, 1e-3);
    c.yon = ps.getFloat({"yon"}, 1e30);
    if (c.shutter_close < c.shutter_open)
      warn(d.loc, "shutterclose is before shutteropen; they are swapped");
    if (c.shutter_close < c.shutter_open) std::swap(c.shutter_open, c.shutter_close);
    auto screen = [&]() {
      c.frame_aspect_ratio = ps.findFloat({"frameaspectratio"});
      if (const Param* p = ps.find({"screenwindow"}, {ParamType::Float})) {
        ps.expectCount(*p, 4);
        c.screen_window =
            std::array<double, 4>{p->numbers[0], p->numbers[1], p->numbers[2], p->numbers[3]};
      }
      c.lens_radius = ps.getFloat({"lensradius"}, 0);
      c.focal_distance = ps.getFloat({"focaldistance"}, 1e6);
    };
    if (type == "perspective") {
      c.type = "perspective";
      screen();
      c.fov_deg = ps.getFloat({"fov"}, 90);
      if (auto half = ps.findFloat({"halffov"})) c.fov_deg = 2 * *half;  // pbrt-v1/v2
    } else if (type == "orthographic") {
      c.type = "orthographic";
      screen();
    } else if (type == "spherical") {
      c.type = "spherical";
      ps.find({"screenwindow"}, {ParamType::Float});
      ps.getFloat({"lensradius"}, 0);
      ps.getFloat({"focaldistance"}, 1e6);
      ps.findFloat({"frameaspectratio"});
      c.spherical_mapping = ps.getString({"mapping"}, "equalarea");
      if (c.spherical_mapping != "equirectangular" && c.spherical_mapping != "equalarea")
        throw Error(ps.peek({"mapping"})->loc,
                    fmt::format("spherical camera: unknown mapping \"{}\" (expected "
                                "\"equalarea\" or \"equirectangular\")",
                                c.spherical_mapping));
    } else if (type == "realistic") {
      c.type = "realistic";
      if (ps.peek({"specfile"})) {
        // pbrt-v1/v2 (CS348B): camera-space millimetres.
        pbrt_v2_ = true;
        LegacyRealistic r;
        const Param* spec = ps.find({"specfile"}, {ParamType::String});
        r.lens_file_as_written = spec->strings[0];
        r.lens_file = resolve(spec->strings[0], spec->loc, "lens file");
        const Param* fd = ps.find({"filmdistance"}, {ParamType::Float});
        if (!fd) throw Error(d.loc, "realistic camera: missing \"float filmdistance\" (mm)");
        ps.expectCount(*fd, 1);
        r.film_distance_mm = fd->numbers[0];
        const Param* ad = ps.find({"aperture_diameter"}, {ParamType::Float});
        if (!ad) throw Error(d.loc, "realistic camera: missing \"float aperture_diameter\" (mm)");
        ps.expectCount(*ad, 1);
        r.aperture_diameter_mm = ad->numbers[0];
        r.film_diagonal_mm = ps.getFloat({"filmdiag"}, 35);
        if (const Param* af = ps.find({"af_zones"}, {ParamType::String}))
          r.af_zones_file = resolve(af->strings[0], af->loc, "autofocus zone file");
        if (r.film_distance_mm <= 0) ps.fail(*fd, "film distance must be positive (mm)");
        if (r.aperture_diameter_mm <= 0) ps.fail(*ad, "aperture diameter must be positive (mm)");
        c.legacy_realistic = r;
      } else {
        Realistic r;
        const Param* lf = ps.find({"lensfile"}, {ParamType::String});
        if (!lf) throw Error(d.loc, "realistic camera: missing \"string lensfile\"");
        r.lens_file_as_written = lf->strings[0];
        // Catalogue names (lentil:KEY, lenses:NAME; see optics/lens_formats.h) are not paths.
        const std::string& lname = lf->strings[0];
        r.lens_file = lname.rfind("lentil:", 0) == 0 || lname.rfind("lenses:", 0) == 0
                          ? lname
                          : resolve(lname, lf->loc, "lens file");
        r.aperture_diameter_mm = ps.getFloat({"aperturediameter"}, 1.0);
        r.focus_distance_m = ps.getFloat({"focusdistance"}, 10.0);
        // pbrt-v3's default is true; pbrt-v4 has no such parameter (always irradiance).
        r.simple_weighting = ps.getBool({"simpleweighting"}, scene_.legacy_syntax);
        r.glass_match = ps.getBool({"glassmatch"}, false);
        if (const Param* fd = ps.find({"filmdistance"}, {ParamType::Float})) {
          ps.expectCount(*fd, 1);
          if (!(fd->numbers[0] > 0)) ps.fail(*fd, "film distance must be positive (mm)");
          if (ps.peek({"focusdistance"}))
            ps.fail(*fd, "give filmdistance or focusdistance, not both");
          r.film_distance_mm = fd->numbers[0];
        }
        if (const Param* fm = ps.find({"focusmethod"}, {ParamType::String})) {
          if (fm->strings[0] != "thick" && fm->strings[0] != "exact")
            ps.fail(*fm, fmt::format("\"{}\": expected \"thick\" or \"exact\"", fm->strings[0]));
          r.focus_method = fm->strings[0];
        }
        if (const Param* b = ps.find({"blades"}, {ParamType::Integer})) {
          ps.expectCount(*b, 1);
          if (b->numbers[0] != 0 && b->numbers[0] < 3)
            ps.fail(*b, "a polygonal stop needs at least 3 blades (0: round)");
          r.blades = static_cast<int>(b->numbers[0]);
        }
        r.blade_rotation_deg = ps.getFloat({"bladerotation"}, 0);
        if (const Param* ap = ps.find({"aperture"}, {ParamType::String})) {
          const std::string& a = ap->strings[0];
          static const std::set<std::string> builtin = {"gaussian", "square", "pentagon", "star"};
          r.aperture = builtin.count(a) ? a : resolve(a, ap->loc, "aperture image");
        }
        c.realistic = r;
      }
    } else {
      ps.markAllUsed();
      warnOnce("camera " + type, d.loc,
               fmt::format("camera \"{}\" is not rendered by lensim; it renders as a perspective "
                           "camera with a 90 degree field of view",
                           type));
    }
    finish(ps);
    scene_.camera = std::move(c);
  }

  // pbrt-v4's "sensor" (src/pbrt/film.cpp, PixelSensor::Create): a name pbrt-v4 does not know
  // is an error there ("unknown sensor type") and here; a camera pbrt-v4 knows but whose
  // measured curves lensim does not bundle is warned and recorded through the CIE 1931 observer.
  void checkSensor(ParamSet& ps, const Film& f) {
    const Param* p = ps.find({"sensor"}, {ParamType::String});
    if (!p) return;
    const auto list = [](const std::vector<std::string>& v) {
      std::string out;
      for (const std::string& n : v) out += (out.empty() ? "" : ", ") + n;
      return out;
    };
    switch (sensorSupport(f.sensor)) {
      case SensorSupport::Applied: return;
      case SensorSupport::NotBundled:
        warn(p->loc, fmt::format("\"sensor\": the measured response curves of pbrt-v4's camera "
                                 "sensor \"{}\" are not bundled with lensim; the film records "
                                 "CIE 1931 XYZ instead (sensors lensim applies: {})",
                                 f.sensor, list(bundledSensorNames())));
        return;
      case SensorSupport::Unknown:
        throw Error(p->loc, fmt::format("\"sensor\": unknown sensor \"{}\"; expected {} or one "
                                        "of pbrt-v4's camera sensors ({})",
                                        f.sensor, list(bundledSensorNames()),
                                        list(pbrtCameraSensorNames())));
    }
  }

  // pbrt-v4's SpectralFilm::Create (src/pbrt/film.cpp): "nbuckets" (16), "lambdamin" and
  // "lambdamax" (360 and 830 nm, pbrt-v4's Lambda_min/Lambda_max, outside which it refuses to
  // render), an EXR file only.
  void spectralFilm(ParamSet& ps, Film& f) {
    f.type = "spectral";
    const Param* nb = ps.find({"nbuckets"}, {ParamType::Integer});
    f.spectral_buckets = ps.getInt({"nbuckets"}, 16);
    if (f.spectral_buckets < 1 || f.spectral_buckets > 4096)
      throw Error(nb ? nb->loc : f.loc,
                  fmt::format("\"nbuckets\": {} buckets; expected 1 to 4096", f.spectral_buckets));
    const Param* lo = ps.find({"lambdamin"}, {ParamType::Float});
    const Param* hi = ps.find({"lambdamax"}, {ParamType::Float});
    f.lambda_min_nm = ps.getFloat({"lambdamin"}, 360);
    f.lambda_max_nm = ps.getFloat({"lambdamax"}, 830);
    if (f.lambda_min_nm < 360 || f.lambda_max_nm > 830 || !(f.lambda_min_nm < f.lambda_max_nm))
      throw Error(lo ? lo->loc : hi ? hi->loc : f.loc,
                  fmt::format("\"lambdamin\"/\"lambdamax\": [{}, {}] nm; expected an interval "
                              "within [360, 830] nm (the wavelengths lensim and pbrt-v4 render)",
                              f.lambda_min_nm, f.lambda_max_nm));
  }

  void film(const Directive& d) {
    const std::string& type = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("Film \"{}\"", type));
    Film& f = scene_.film;
    f.defaulted = false;
    f.type_as_written = type;
    f.loc = d.loc;
    f.type = "rgb";
    if (type == "spectral") {
      spectralFilm(ps, f);
    } else if (type != "rgb" && type != "image")
      warnOnce("film " + type, d.loc,
               fmt::format("film \"{}\" is not rendered by lensim; it renders as an \"rgb\" film",
                           type));
    f.x_resolution = ps.getInt({"xresolution"}, f.x_resolution);
    f.y_resolution = ps.getInt({"yresolution"}, f.y_resolution);
    if (f.x_resolution <= 0 || f.y_resolution <= 0)
      throw Error(d.loc, fmt::format("film resolution {}x{} must be positive", f.x_resolution,
                                     f.y_resolution));
    // The film's buffers (accumulated XYZ and weights, then the RGB image): about 64 bytes a pixel.
    checkMemory(64.0 * f.x_resolution * f.y_resolution, d.loc,
                fmt::format("a {}x{} film", f.x_resolution, f.y_resolution));
    f.filename = ps.getString({"filename"}, f.filename);
    if (const Param* p = ps.find({"cropwindow"}, {ParamType::Float})) {
      ps.expectCount(*p, 4);
      f.crop_window = {p->numbers[0], p->numbers[1], p->numbers[2], p->numbers[3]};
    }
    if (const Param* p = ps.find({"pixelbounds"}, {ParamType::Integer})) {
      ps.expectCount(*p, 4);
      f.pixel_bounds = std::array<int, 4>{int(p->numbers[0]), int(p->numbers[1]),
                                          int(p->numbers[2]), int(p->numbers[3])};
    }
    f.scale = ps.getFloat({"scale"}, 1);  // pbrt-v3 image film
    f.diagonal_mm = ps.getFloat({"diagonal"}, 35);
    f.iso = ps.getFloat({"iso"}, 100);
    f.white_balance_k = ps.getFloat({"whitebalance"}, 0);
    // Ranges that keep the film's arithmetic finite (a NaN or 1e-300 here made every pixel NaN).
    if (!(f.iso > 0 && f.iso <= 1e7))
      throw Error(d.loc, fmt::format("film \"iso\" {} is out of range; expected (0, 1e7]", f.iso));
    if (f.white_balance_k != 0 && !(f.white_balance_k >= 1000 && f.white_balance_k <= 100000))
      throw Error(d.loc, fmt::format("film \"whitebalance\" {} K is out of range; expected 0 (none) "
                                     "or a colour temperature in [1000, 100000] K",
                                     f.white_balance_k));
    if (!(f.diagonal_mm > 0))
      throw Error(d.loc, fmt::format("film \"diagonal\" {} mm must be > 0", f.diagonal_mm));
    f.sensor = ps.getString({"sensor"}, "cie1931");
    checkSensor(ps, f);
    f.max_component_value = ps.getFloat({"maxcomponentvalue", "maxsampleluminance"}, 1e300);
    f.save_fp16 = ps.getBool({"savefp16"}, true);
    ps.getBool({"display"}, false);  // pbrt-v2 image film: open a window
    if (type == "gbuffer") ps.markAllUsed();
    if (f.x_resolution <= 0 || f.y_resolution <= 0)
      throw Error(d.loc, "film resolution must be positive");
    finish(ps);
  }

  void sampler(const Directive& d) {
    const std::string& type = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("Sampler \"{}\"", type));
    Sampler& s = scene_.sampler;
    s.defaulted = false;
    s.type_as_written = type;
    s.loc = d.loc;
    static const std::set<std::string> v4 = {"independent", "stratified", "halton", "sobol",
                                             "paddedsobol", "zsobol",     "pmj02bn"};
    s.seed = ps.getInt({"seed"}, 0);
    s.randomization = ps.getString({"randomization"}, "");
    ps.getBool({"samplepixelcenter"}, false);  // pbrt-v3 halton
    if (type == "stratified") {
      int x = ps.getInt({"xsamples"}, 4), y = ps.getInt({"ysamples"}, 4);
      s.jitter = ps.getBool({"jitter"}, true);
      // The product in 64 bits: 65536 x 65536 must not wrap around.
      const int64_t xy = int64_t{x} * int64_t{y};
      if (x <= 0 || y <= 0 || xy > kMaxSamplesPerPixel)
        throw Error(d.loc, fmt::format("stratified sampler: {} x {} samples per pixel; expected "
                                       "positive counts with a product of at most {}",
                                       x, y, kMaxSamplesPerPixel));
      s.pixel_samples = static_cast<int>(xy);
      s.type = type;
    } else if (v4.count(type)) {
      s.type = type;
      s.pixel_samples = ps.getInt({"pixelsamples"}, 16);
    } else if (type == "lowdiscrepancy" || type == "02sequence" || type == "bestcandidate" ||
               type == "maxmindist" || type == "random" || type == "adaptive") {
      // The pbrt-v4 equivalents its --upgrade uses.
      s.type = type == "random"                                  ? "independent"
               : type == "maxmindist" || type == "bestcandidate" ? "pmj02bn"
                                                                 : "paddedsobol";
      s.pixel_samples = ps.getInt({"pixelsamples"}, 4);
      if (type == "adaptive") {
        s.pixel_samples = ps.getInt({"maxsamples"}, 32);
        ps.markAllUsed();
      }
      ps.getInt({"dimensions"}, 4);
      warnOnce("sampler " + type, d.loc,
               fmt::format("sampler \"{}\" (pbrt-v1–v3) renders as \"{}\" with {} samples per "
                           "pixel",
                           type, s.type, s.pixel_samples));
    } else {
      ps.markAllUsed();
      s.type = "zsobol";
      warnOnce(
          "sampler " + type, d.loc,
          fmt::format("sampler \"{}\" is not rendered by lensim; it renders as \"zsobol\"", type));
    }
    if (s.pixel_samples <= 0) throw Error(d.loc, "pixelsamples must be positive");
    if (s.pixel_samples > kMaxSamplesPerPixel)
      throw Error(d.loc, fmt::format("pixelsamples {} is too large; at most {} are taken",
                                     s.pixel_samples, kMaxSamplesPerPixel));
    finish(ps);
  }

  void filter(const Directive& d) {
    const std::string& type = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("PixelFilter \"{}\"", type));
    Filter& f = scene_.filter;
    f.defaulted = false;
    f.type_as_written = type;
    f.loc = d.loc;
    double def = type == "box"        ? 0.5
                 : type == "gaussian" ? 1.5
                 : type == "mitchell" ? 2
                 : type == "triangle" ? 2
                                      : 4;
    f.type = type == "sinc" ? "lanczos" : type;
    f.x_radius = ps.getFloat({"xradius", "xwidth"}, def);
    f.y_radius = ps.getFloat({"yradius", "ywidth"}, def);
    if (type == "gaussian") {
      f.sigma = ps.getFloat({"sigma"}, 0.5);
      if (auto alpha = ps.findFloat({"alpha"}))  // pbrt-v2: exp(-alpha x^2) = exp(-x^2/(2 sigma^2))
        f.sigma = 1 / std::sqrt(2 * *alpha);
    } else if (type == "mitchell") {
      f.b = ps.getFloat({"B"}, 1.0 / 3);
      f.c = ps.getFloat({"C"}, 1.0 / 3);
    } else if (type == "sinc" || type == "lanczos") {
      f.tau = ps.getFloat({"tau"}, 3);
    } else if (type != "box" && type != "triangle") {
      ps.markAllUsed();
      f.type = "gaussian";
      warnOnce(
          "filter " + type, d.loc,
          fmt::format("filter \"{}\" is not rendered by lensim; it renders as \"gaussian\"", type));
    }
    finish(ps);
  }

  void integrator(const Directive& d) {
    const std::string& type = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("{} \"{}\"", d.name, type));
    Integrator& it = scene_.integrator;
    it.defaulted = false;
    it.type_as_written = type;
    it.loc = d.loc;
    it.type = "path";
    it.max_depth = ps.getInt({"maxdepth"}, 5);
    if (type == "path" || type == "volpath") {
      it.regularize = ps.getBool({"regularize"}, false);
      it.light_sampler = ps.getString({"lightsampler", "lightsamplestrategy"}, "bvh");
      // pbrt-v4's samplers (LightSampler::Create, src/pbrt/lightsamplers.cpp): an unknown name
      // is reported and "bvh" used. pbrt-v3's "spatial" (its default, a light distribution
      // that depends on position) is nearest to "bvh".
      if (it.light_sampler == "spatial") it.light_sampler = "bvh";
      if (it.light_sampler != "bvh" && it.light_sampler != "power" &&
          it.light_sampler != "uniform" && it.light_sampler != "exhaustive") {
        const Param* p = ps.peek({"lightsampler", "lightsamplestrategy"});
        warn(p ? p->loc : d.loc,
             fmt::format("unknown light sampler \"{}\" (expected bvh, power, uniform or "
                         "exhaustive); \"bvh\" is used",
                         it.light_sampler));
        it.light_sampler = "bvh";
      }
      ps.getFloat({"rrthreshold"}, 1);  // pbrt-v3
      if (const Param* p = ps.find({"pixelbounds"}, {ParamType::Integer})) ps.expectCount(*p, 4);
      if (type == "volpath") it.type = "volpath";
    } else if (type == "lighttracer") {
      it.type = "lighttracer";  // pbrt-v4's LightPathIntegrator (render/lighttracer.h)
    } else if (type == "bdpt") {
      integratorBdpt(ps, it);
    } else if (type == "directlighting") {
      // As pbrt-v4's --upgrade: direct lighting is a path tracer of depth 1.
      ps.markAllUsed();
      it.max_depth = 1;
      warnOnce("integrator " + type, d.loc,
               "integrator \"directlighting\" (pbrt-v1–v3) renders as \"path\" with maxdepth 1");
    } else {
      ps.markAllUsed();
      // pbrt-v4's other integrators (bdpt, mlt, sppm, ...) handle media: volpath keeps them.
      if (!scene_.legacy_syntax) it.type = "volpath";
      warnOnce("integrator " + type, d.loc,
               fmt::format("integrator \"{}\" is not rendered by lensim; it renders as \"{}\" "
                           "with maxdepth {}",
                           type, it.type, it.max_depth));
    }
    finish(ps);
  }

  // pbrt-v4's BDPTIntegrator::Create (src/pbrt/cpu/integrators.cpp): maxdepth, regularize,
  // lightsampler (default "power"), visualizestrategies, visualizeweights.
  void integratorBdpt(ParamSet& ps, Integrator& it) {
    it.type = "bdpt";
    it.regularize = ps.getBool({"regularize"}, false);
    it.light_sampler = ps.getString({"lightsampler"}, "power");
    if (it.light_sampler != "power" && it.light_sampler != "uniform") {
      const Param* p = ps.peek({"lightsampler"});
      warn(p ? p->loc : it.loc,
           fmt::format("bdpt chooses lights by \"power\" or \"uniform\" (light subpaths need a "
                       "choice that does not depend on a point), not \"{}\"; \"power\" is used",
                       it.light_sampler));
      it.light_sampler = "power";
    }
    for (const char* name : {"visualizestrategies", "visualizeweights"})
      if (ps.getBool({name}, false)) {
        const Param* p = ps.peek({name});
        warn(p ? p->loc : it.loc,
             fmt::format("bdpt \"{}\" (pbrt-v4's per-strategy debug images) is not supported; "
                         "the image is rendered as usual",
                         name));
      }
  }

  // ---- textures and materials ----------------------------------------------------------------
  void texture(const Directive& d) {
    const std::string &name = d.strings[0], &kind_s = d.strings[1], &cls = d.strings[2];
    Texture t;
    t.name = name;
    t.loc = d.loc;
    t.type_as_written = cls;
    if (kind_s == "float")
      t.kind = TextureKind::Float;
    else if (kind_s == "spectrum" || kind_s == "color" || kind_s == "rgb")
      t.kind = TextureKind::Spectrum;
    else
      throw Error(d.loc, fmt::format("texture \"{}\": unknown texture type \"{}\" (expected "
                                     "\"float\" or \"spectrum\")",
                                     name, kind_s));
    t.texture_from_world = inverse(gs_.ctm[0]);
    ParamSet ps(d.params, d.loc, fmt::format("Texture \"{}\"", cls));
    ps.addDefaults(gs_.texture_attrs);
    const bool f = t.kind == TextureKind::Float;
    auto in = [&](ParamSet::Names names, double def) {
      return f ? floatInput(ps, names, def) : spectrumInput(ps, names, def);
    };
    auto mapping = [&]() {
      t.mapping = ps.getString({"mapping"}, "uv");
      t.uscale = ps.getFloat({"uscale"}, 1);
      t.vscale = ps.getFloat({"vscale"}, 1);
      t.udelta = ps.getFloat({"udelta"}, 0);
      t.vdelta = ps.getFloat({"vdelta"}, 0);
      for (auto [name, v] : {std::pair{"v1", &t.v1}, std::pair{"v2", &t.v2}})
        if (const Param* p = ps.find({name}, {ParamType::Vector3})) {
          ps.expectCount(*p, 1);
          *v = {p->numbers[0], p->numbers[1], p->numbers[2]};
        }
    };
    if (cls == "imagemap") {
      t.type = cls;
      mapping();
      const Param* fn = ps.find({"filename"}, {ParamType::String});
      if (!fn)
        throw Error(d.loc, fmt::format("texture \"{}\": imagemap needs \"string filename\"", name));
      t.filename_as_written = fn->strings[0];
      t.filename = resolve(fn->strings[0], fn->loc, "image file");
      t.wrap = ps.getString({"wrap"}, "repeat");
      t.scale = ps.getFloat({"scale"}, 1);
      t.invert = ps.getBool({"invert"}, false);
      t.encoding = ps.getString({"encoding"}, "");
      t.filter = ps.getString({"filter"}, "bilinear");
      t.max_anisotropy = ps.getFloat({"maxanisotropy"}, 8);
      if (ps.getBool({"trilinear"}, false)) t.filter = "trilinear";  // pbrt-v2/v3
      // pbrt-v2: "float gamma"; pbrt-v3: "bool gamma" (true: sRGB).
      if (const Param* g = ps.find({"gamma"}, {ParamType::Float, ParamType::Bool})) {
        ps.expectCount(*g, 1);
        if (g->type == ParamType::Float)
          t.encoding = fmt::format("gamma {}", g->numbers[0]);
        else
          t.encoding = g->bools[0] ? "sRGB" : "linear";
      }
      // "sRGB", "linear" or "gamma G" with a positive G, checked here at the parameter.
      if (!t.encoding.empty() && t.encoding != "sRGB" && t.encoding != "linear") {
        double gamma = 0;
        const std::string_view e = t.encoding;
        const bool ok = e.rfind("gamma ", 0) == 0 &&
                        std::from_chars(e.data() + 6, e.data() + e.size(), gamma).ptr ==
                            e.data() + e.size() &&
                        gamma > 0 && gamma <= 100;
        if (!ok) {
          const Param* ep = ps.find({"encoding", "gamma"}, {ParamType::String, ParamType::Float});
          throw Error(ep ? ep->loc : d.loc,
                      fmt::format("image texture encoding \"{}\"; expected \"sRGB\", \"linear\" "
                                  "or \"gamma G\" with G in (0, 100]",
                                  t.encoding));
        }
      }
    } else if (cls == "scale") {
      t.type = cls;
      t.tex1 = in({"tex", "tex1"}, 1);
      if (auto s = floatInput(ps, {"scale"})) {
        t.tex2 = *s;
        t.scale_is_float = true;
      } else {
        t.tex2 = in({"tex2"}, 1);
      }
    } else if (cls == "mix") {
      t.type = cls;
      t.tex1 = in({"tex1"}, 0);
      t.tex2 = in({"tex2"}, 1);
      t.amount = floatInput(ps, {"amount"}, 0.5);
    } else if (cls == "directionmix") {
      t.type = cls;
      t.tex1 = in({"tex1"}, 0);
      t.tex2 = in({"tex2"}, 1);
      if (const Param* p = ps.find({"dir"}, {ParamType::Vector3})) {
        ps.expectCount(*p, 1);
        t.direction = {p->numbers[0], p->numbers[1], p->numbers[2]};
      }
      // pbrt-v4: the direction is given in the texture's space; kept in world space here.
      t.direction = inverse(t.texture_from_world).applyVector(t.direction);
      if (length(t.direction) == 0) throw Error(d.loc, "directionmix: \"dir\" must not be zero");
      t.direction = normalize(t.direction);
    } else if (cls == "checkerboard") {
      t.type = cls;
      mapping();
      t.tex1 = in({"tex1"}, 1);
      t.tex2 = in({"tex2"}, 0);
      t.dimension = ps.getInt({"dimension"}, 2);
      ps.getString({"aamode"}, "closedform");  // pbrt-v2/v3
      if (t.dimension != 2 && t.dimension != 3)
        throw Error(d.loc, fmt::format("checkerboard dimension {} (expected 2 or 3)", t.dimension));
    } else if (cls == "constant") {
      t.type = cls;
      t.tex1 = in({"value"}, 1);
    } else if (cls == "fbm" || cls == "wrinkled" || cls == "windy" || cls == "marble") {
      // pbrt-v4 (src/pbrt/textures.cpp): fbm, wrinkled and windy are float textures, marble a
      // spectrum texture; 3-D mapping by the inverse of the declaration's transform.
      t.type = cls;
      if ((cls == "marble") == f)
        throw Error(d.loc, fmt::format("texture \"{}\": \"{}\" is a {} texture in pbrt", name, cls,
                                       f ? "spectrum" : "float"));
      if (cls != "windy") {
        t.octaves = ps.getInt({"octaves"}, 8);
        t.omega = ps.getFloat({"roughness"}, 0.5);
        if (t.octaves < 0 || t.octaves > 64)
          throw Error(
              d.loc, fmt::format("texture \"{}\": octaves {} (expected 0 to 64)", name, t.octaves));
      }
      if (cls == "marble") {
        t.scale = ps.getFloat({"scale"}, 1);
        t.variation = ps.getFloat({"variation"}, 0.2);
      }
      if (t.texture_from_world.isSingular())
        throw Error(d.loc, fmt::format("texture \"{}\": its 3-D mapping uses the current "
                                       "transformation matrix, which is singular (not invertible)",
                                       name));
    } else if (cls == "dots") {
      t.type = cls;
      mapping();
      t.tex1 = in({"inside"}, 1);
      t.tex2 = in({"outside"}, 0);
    } else if (cls == "bilerp") {
      t.type = cls;
      mapping();
      t.v00 = in({"v00"}, 0);
      t.v01 = in({"v01"}, 1);
      t.v10 = in({"v10"}, 0);
      t.v11 = in({"v11"}, 1);
    } else {
      ps.markAllUsed();
      t.type = "constant";
      t.tex1 = f ? floatInput(ps, {"__none__"}, 0.5) : spectrumInput(ps, {"__none__"}, 0.5);
      warnOnce("texture " + cls, d.loc,
               fmt::format("texture \"{}\" is not rendered by lensim; it renders as a constant 0.5",
                           cls));
    }
    if ((t.mapping != "uv" || (t.type == "checkerboard" && t.dimension == 3)) &&
        t.texture_from_world.isSingular())
      throw Error(d.loc, fmt::format("texture \"{}\": its {} mapping uses the current "
                                     "transformation matrix, which is singular (not invertible)",
                                     name, t.mapping != "uv" ? t.mapping : "3-D"));
    finish(ps);
    auto& map = f ? float_textures_ : spectrum_textures_;
    if (map.count(name))
      warn(d.loc, fmt::format("{} texture \"{}\" redefined", f ? "float" : "spectrum", name));
    scene_.textures.push_back(std::move(t));
    map[name] = static_cast<int>(scene_.textures.size()) - 1;
  }

  Material material(const std::string& type, ParamSet& ps, const FileLoc& loc) {
    Material m;
    m.type_as_written = type;
    m.loc = loc;
    m.displacement = floatInput(ps, {"displacement", "bumpmap"});  // bump mapping
    if (const Param* nm = ps.find({"normalmap"}, {ParamType::String}))
      if (!nm->strings[0].empty()) m.normal_map = resolve(nm->strings[0], nm->loc, "normal map");
    auto roughness = [&](double def) {
      Input r = floatInput(ps, {"roughness"}, def);
      m.uroughness = floatInput(ps, {"uroughness"}).value_or(r);
      m.vroughness = floatInput(ps, {"vroughness"}).value_or(r);
      m.remap_roughness = ps.getBool({"remaproughness"}, true);
    };
    auto conductorDefaults = [&]() {
      m.eta =
          spectrumInput(ps, {"eta"}).value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-eta")});
      m.k = spectrumInput(ps, {"k"}).value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-k")});
    };
    auto dielectricEta = [&](ParamSet::Names names) {
      const Param* p = ps.find(names, {ParamType::Float, ParamType::Spectrum, ParamType::Texture});
      m.eta.value = 1.5;
      if (!p) return;
      if (p->type == ParamType::Float) {
        ps.expectCount(*p, 1);
        m.eta.value = p->numbers[0];
      } else if (p->type == ParamType::Texture) {
        m.eta.texture = textureIndex(p->strings[0], TextureKind::Float, p->loc);
      } else {
        m.eta.spectrum = spectrumOf(*p);
      }
    };
    if (type == "diffuse" || type == "matte") {
      m.type = "diffuse";
      m.reflectance = spectrumInput(ps, {"reflectance", "Kd"}, 0.5);
      m.has_reflectance = true;
      if (type == "matte") m.sigma = floatInput(ps, {"sigma"}, 0);  // Oren–Nayar, degrees
    } else if (type == "coateddiffuse") {
      m.type = "coateddiffuse";
      m.reflectance = spectrumInput(ps, {"reflectance", "Kd"}, 0.5);
      m.has_reflectance = true;
      roughness(0);
      m.thickness = floatInput(ps, {"thickness"}, 0.01);
      m.albedo = spectrumInput(ps, {"albedo"}, 0);
      m.g = floatInput(ps, {"g"}, 0);
      m.max_depth = ps.getInt({"maxdepth"}, 10);
      m.n_samples = ps.getInt({"nsamples"}, 1);
      dielectricEta({"eta"});
    } else if (type == "plastic" || type == "uber" || type == "substrate" ||
               type == "translucent") {
      // pbrt-v3's materials, rendered as pbrt-v3 defines them (render/v3materials.h), with
      // pbrt-v3's defaults (src/materials/{plastic,uber,substrate,translucent}.cpp).
      m.type = type;
      const bool half = type == "substrate";
      m.reflectance = spectrumInput(ps, {"Kd", "reflectance"}, half ? 0.5 : 0.25);
      m.has_reflectance = true;
      m.specular = spectrumInput(ps, {"Ks"}, half ? 0.5 : 0.25);
      roughness(0.1);
      if (type == "uber") {
        m.kr = spectrumInput(ps, {"Kr"}, 0);
        m.kt = spectrumInput(ps, {"Kt"}, 0);
        m.opacity = spectrumInput(ps, {"opacity"}, 1);
        dielectricEta({"eta", "index"});
      } else if (type == "translucent") {
        m.v3_reflect = spectrumInput(ps, {"reflect"}, 0.5);
        m.transmittance = spectrumInput(ps, {"transmit"}, 0.5);
      }
    } else if (type == "conductor" || type == "metal") {
      // pbrt-v3's metal keeps its name: its roughness is remapped as pbrt-v3 does.
      m.type = type;
      conductorDefaults();
      if (type == "conductor")
        if (auto r = spectrumInput(ps, {"reflectance"})) {
          m.reflectance = *r;
          m.has_reflectance = true;
        }
      roughness(type == "metal" ? 0.01 : 0);
    } else if (type == "mirror") {
      m.type = "mirror";  // pbrt-v3: a specular reflection of Kr at every angle
      m.kr = spectrumInput(ps, {"Kr"}, 0.9);
    } else if (type == "dielectric" || type == "glass" || type == "thindielectric") {
      m.type = type;
      dielectricEta({"eta", "index"});
      if (type != "thindielectric") roughness(0);
      if (type == "glass") {
        m.kr = spectrumInput(ps, {"Kr"}, 1);
        m.kt = spectrumInput(ps, {"Kt"}, 1);
      }
    } else if (type == "coatedconductor") {
      m.type = type;
      Input r = floatInput(ps, {"interface.roughness"}, 0);
      m.uroughness = floatInput(ps, {"interface.uroughness"}).value_or(r);
      m.vroughness = floatInput(ps, {"interface.vroughness"}).value_or(r);
      Input cr = floatInput(ps, {"conductor.roughness"}, 0);
      m.conductor_uroughness = floatInput(ps, {"conductor.uroughness"}).value_or(cr);
      m.conductor_vroughness = floatInput(ps, {"conductor.vroughness"}).value_or(cr);
      m.remap_roughness = ps.getBool({"remaproughness"}, true);
      dielectricEta({"interface.eta"});
      m.conductor_eta = spectrumInput(ps, {"conductor.eta"})
                            .value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-eta")});
      m.conductor_k = spectrumInput(ps, {"conductor.k"})
                          .value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-k")});
      if (auto rr = spectrumInput(ps, {"reflectance"})) {
        m.conductor_reflectance = *rr;
        m.conductor_has_reflectance = true;
      }
      m.thickness = floatInput(ps, {"thickness"}, 0.01);
      m.albedo = spectrumInput(ps, {"albedo"}, 0);
      m.g = floatInput(ps, {"g"}, 0);
      m.max_depth = ps.getInt({"maxdepth"}, 10);
      m.n_samples = ps.getInt({"nsamples"}, 1);
    } else if (type == "diffusetransmission") {
      m.type = "diffusetransmission";
      m.reflectance = spectrumInput(ps, {"reflectance"}, 0.25);
      m.transmittance = spectrumInput(ps, {"transmittance"}, 0.25);
      m.scale = ps.getFloat({"scale"}, 1);
      m.has_reflectance = true;
    } else if (type == "mix") {
      m.type = "mix";
      std::vector<std::string> names;
      if (const Param* p = ps.find({"materials"}, {ParamType::String}))
        names = p->strings;
      else
        names = {ps.getString({"namedmaterial1"}, ""), ps.getString({"namedmaterial2"}, "")};
      if (names.size() != 2)
        throw Error(loc, fmt::format("mix: expected 2 materials, got {}", names.size()));
      for (int i = 0; i < 2; ++i) {
        auto it = named_materials_.find(names[size_t(i)]);
        if (it == named_materials_.end())
          throw Error(loc, fmt::format("mix: unknown material \"{}\"", names[size_t(i)]));
        m.mix[size_t(i)] = it->second;
      }
      m.amount = floatInput(ps, {"amount"}, 0.5);
    } else if (type == "interface" || type == "" || type == "none") {
      m.type = "interface";
    } else if (type == "measured") {
      // pbrt-v2: measured BRDF data; the irregular isotropic `.brdf` format is rendered.
      const Param* f = ps.find({"filename"}, {ParamType::String});
      if (!f) throw Error(loc, "measured: missing \"string filename\"");
      const std::string& name = f->strings[0];
      if (name.size() < 5 || name.substr(name.size() - 5) != ".brdf")
        ps.fail(*f,
                "only pbrt-v2's irregular isotropic .brdf files are rendered (expected a "
                "file name ending in .brdf)");
      m.type = "measured";
      m.measured_file = resolve(name, f->loc, "measured BRDF file");
    } else {
      ps.markAllUsed();
      m.type = "diffuse";
      m.reflectance.spectrum = SpectrumValue::gray(0.5);
      m.has_reflectance = true;
      m.fallback = true;
      warnOnce("material " + type, loc,
               fmt::format("material \"{}\" is not rendered by lensim; it renders as diffuse grey "
                           "(reflectance 0.5)",
                           type));
    }
    return m;
  }

  int currentMaterial() {
    if (gs_.material >= 0) return gs_.material;
    if (default_material_ < 0) {
      Material m;
      m.type = "diffuse";
      m.type_as_written = "(default)";
      m.reflectance.spectrum = SpectrumValue::gray(0.5);
      m.has_reflectance = true;
      scene_.materials.push_back(m);
      default_material_ = static_cast<int>(scene_.materials.size()) - 1;
    }
    return default_material_;
  }

  // Each AttributeBegin copies the graphics state, attribute lists included: thousands of nested
  // blocks after a large "Attribute" would multiply it (20,000 x 100k floats: 16 GB).
  void checkStackMemory(const Directive& d) {
    double bytes = sizeof(GraphicsState);
    for (const ParamList* list :
         {&gs_.shape_attrs, &gs_.light_attrs, &gs_.material_attrs, &gs_.texture_attrs})
      for (const Param& p : *list) {
        bytes += sizeof(Param) + 8.0 * static_cast<double>(p.numbers.size()) + p.bools.size();
        for (const std::string& str : p.strings) bytes += sizeof(std::string) + str.size();
      }
    // The entries below hold copies of about this size too (estimate).
    if (bytes > 4096)
      checkMemory(bytes * static_cast<double>(stack_.size() + 1), d.loc,
                  fmt::format("{} nested AttributeBegin blocks (each copies the attributes)",
                              stack_.size() + 1));
  }

  // ---- lights --------------------------------------------------------------------------------
  void light(const Directive& d) {
    const std::string& type = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("LightSource \"{}\"", type));
    ps.addDefaults(gs_.light_attrs);
    Light l;
    l.type = type;
    l.type_as_written = type;
    l.loc = d.loc;
    l.transform = gs_.ctm[0];
    const Param* scale_param = findLightScale(ps);
    l.power = ps.findFloat({"power", "illuminance"});
    ps.getInt({"nsamples", "samples"}, 1);  // pbrt-v1–v3 sample count
    auto emission = [&](ParamSet::Names names) {
      const Param* p = ps.find(names, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody});
      if (p) l.emission = spectrumOf(*p);
    };
    if (type == "point" || type == "spot") {
      emission({"I"});
      l.from = ps.findPoint3({"from"}).value_or(Vec3{0, 0, 0});
      if (type == "spot") {
        l.to = ps.findPoint3({"to"}).value_or(Vec3{0, 0, 1});
        l.cone_angle_deg = ps.getFloat({"coneangle"}, 30);
        l.cone_delta_deg = ps.getFloat({"conedeltaangle"}, 5);
        if (l.from == l.to)
          throw Error(d.loc, "spot light: \"from\" and \"to\" are the same point; they give "
                             "the light's direction");
      }
    } else if (type == "projection") {
      l.fov_deg = ps.getFloat({"fov"}, 90);
      const Param* p = ps.find({"filename", "mapname"}, {ParamType::String});
      if (!p || p->strings[0].empty())
        throw Error(d.loc, "projection light: missing \"string filename\"");
      l.filename = resolve(p->strings[0], p->loc, "projection image");
      if (l.fov_deg <= 0 || l.fov_deg >= 180)
        throw Error(d.loc, fmt::format("projection light: fov {} is not in (0, 180)", l.fov_deg));
    } else if (type == "goniometric") {
      emission({"I"});
      if (const Param* p = ps.find({"filename", "mapname"}, {ParamType::String}))
        if (!p->strings[0].empty())
          l.filename = resolve(p->strings[0], p->loc, "goniometric image");
    } else if (type == "distant") {
      emission({"L"});
      l.from = ps.findPoint3({"from"}).value_or(Vec3{0, 0, 0});
      l.to = ps.findPoint3({"to"}).value_or(Vec3{0, 0, 1});
      if (l.from == l.to)
        throw Error(d.loc, "distant light: \"from\" and \"to\" are the same point; they give "
                           "the light's direction");
    } else if (type == "infinite") {
      emission({"L"});
      if (const Param* p = ps.find({"filename", "mapname"}, {ParamType::String}))
        if (!p->strings[0].empty()) l.filename = resolve(p->strings[0], p->loc, "environment map");
      l.portal = ps.getVec3s({"portal"}, {ParamType::Point3});
      if (!l.portal.empty() && l.portal.size() != 4)
        ps.fail(*ps.peek({"portal"}), fmt::format("expected 4 points, got {}", l.portal.size()));
    } else {
      ps.markAllUsed();
      warnOnce("light " + type, d.loc,
               fmt::format("light \"{}\" is not rendered by lensim; it is left out", type));
      return;
    }
    applyLightScale(scale_param, l);
    requireInvertible(d.loc, fmt::format("LightSource \"{}\"", type));
    finish(ps);
    scene_.lights.push_back(std::move(l));
  }

  void areaLight(const Directive& d) {
    const std::string& type = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("AreaLightSource \"{}\"", type));
    ps.addDefaults(gs_.light_attrs);
    Light l;
    l.type = "diffuse";
    l.type_as_written = type;
    l.loc = d.loc;
    l.transform = gs_.ctm[0];
    if (type != "diffuse" && type != "area") {
      ps.markAllUsed();
      warnOnce("arealight " + type, d.loc,
               fmt::format("area light \"{}\" is not rendered by lensim; it renders as "
                           "\"diffuse\" with L = 1",
                           type));
    } else {
      const Param* p = ps.find({"L"}, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody});
      if (p) l.emission = spectrumOf(*p);
      const Param* scale_param = findLightScale(ps);
      l.two_sided = ps.getBool({"twosided"}, false);
      l.power = ps.findFloat({"power"});
      ps.getInt({"nsamples", "samples"}, 1);  // pbrt-v1–v3 sample count
      if (const Param* fn = ps.find({"filename"}, {ParamType::String})) {
        l.filename = resolve(fn->strings[0], fn->loc, "image file");
      }
      applyLightScale(scale_param, l);
    }
    finish(ps);
    scene_.lights.push_back(std::move(l));
    gs_.area_light = static_cast<int>(scene_.lights.size()) - 1;
  }

  // ---- shapes --------------------------------------------------------------------------------
  void shape(const Directive& d) {
    const std::string& type = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("Shape \"{}\"", type));
    ps.addDefaults(gs_.shape_attrs);
    Shape s;
    s.type_as_written = type;
    s.loc = d.loc;
    s.transform = gs_.ctm[0];
    s.reverse_orientation = gs_.reverse_orientation;
    s.alpha = floatInput(ps, {"alpha"});
    requireInvertible(d.loc, fmt::format("Shape \"{}\"", type));
    if (gs_.ctm[0] != gs_.ctm[1])
      warnOnce("motion", d.loc,
               "animated transforms are not rendered; the start transform is used");
    if (type == "sphere") {
      s.type = ShapeType::Sphere;
      s.radius = ps.getFloat({"radius"}, 1);
      s.zmin = std::clamp(ps.getFloat({"zmin"}, -s.radius), -s.radius, s.radius);
      s.zmax = std::clamp(ps.getFloat({"zmax"}, s.radius), -s.radius, s.radius);
      if (s.zmin > s.zmax) std::swap(s.zmin, s.zmax);
      s.phimax_deg = ps.getFloat({"phimax"}, 360);
    } else if (type == "disk") {
      s.type = ShapeType::Disk;
      s.height = ps.getFloat({"height"}, 0);
      s.radius = ps.getFloat({"radius"}, 1);
      s.inner_radius = ps.getFloat({"innerradius"}, 0);
      if (s.inner_radius < 0 || s.inner_radius >= s.radius)
        throw Error(
            ps.peek({"innerradius"}) ? ps.peek({"innerradius"})->loc : d.loc,
            fmt::format("disk inner radius {} outside [0, radius {})", s.inner_radius, s.radius));
      s.phimax_deg = ps.getFloat({"phimax"}, 360);
    } else if (type == "cylinder") {
      s.type = ShapeType::Cylinder;
      s.radius = ps.getFloat({"radius"}, 1);
      s.zmin = ps.getFloat({"zmin"}, -1);
      s.zmax = ps.getFloat({"zmax"}, 1);
      if (s.zmin > s.zmax) std::swap(s.zmin, s.zmax);
      s.phimax_deg = ps.getFloat({"phimax"}, 360);
    } else if (type == "cone") {
      s.type = ShapeType::Cone;
      s.height = ps.getFloat({"height"}, 1);
      s.radius = ps.getFloat({"radius"}, 1);
      s.phimax_deg = ps.getFloat({"phimax"}, 360);
    } else if (type == "trianglemesh" || type == "bilinearmesh" || type == "loopsubdiv") {
      s.type = type == "bilinearmesh" ? ShapeType::BilinearMesh : ShapeType::TriangleMesh;
      s.mesh = inlineMesh(type, ps, d.loc);
    } else if (type == "plymesh") {
      s.type = ShapeType::TriangleMesh;
      s.mesh = plyMesh(ps, d.loc);
    } else if (type == "curve") {
      s.type = ShapeType::Curve;
      s.curve = curveShape(ps, d.loc);
    } else if (type == "hyperboloid" || type == "paraboloid" || type == "heightfield" ||
               type == "nurbs") {
      s.type = ShapeType::TriangleMesh;
      s.mesh = tessellatedShape(type, ps, d.loc);
    } else {
      ps.markAllUsed();
      warnOnce("shape " + type, d.loc,
               fmt::format("shape \"{}\" is not rendered by lensim; it is left out", type));
      return;
    }
    if (s.phimax_deg <= 0 || s.phimax_deg > 360) {
      const Param* p = ps.peek({"phimax"});
      throw Error(p ? p->loc : d.loc,
                  fmt::format("phimax {} outside (0, 360] degrees", s.phimax_deg));
    }
    if (s.radius <= 0 && s.type != ShapeType::TriangleMesh && s.type != ShapeType::BilinearMesh &&
        s.type != ShapeType::Curve) {
      const Param* p = ps.peek({"radius"});
      throw Error(p ? p->loc : d.loc, fmt::format("radius {} must be positive", s.radius));
    }
    finish(ps);
    s.material = currentMaterial();
    if (gs_.area_light >= 0) {
      if (s.type == ShapeType::Curve) {
        warnOnce("curve area light", d.loc,
                 "area lights on curves are not supported; the curve does not emit");
      } else if (current_object_ >= 0) {
        warnOnce("instanced area light", d.loc,
                 "area lights in object definitions are not supported (as in pbrt-v4); the shape "
                 "does not emit");
      } else {
        s.area_light = gs_.area_light;
        ++scene_.lights[static_cast<size_t>(gs_.area_light)].shape_count;
      }
    }
    if (current_object_ >= 0) {
      s.object = current_object_;
      scene_.objects[static_cast<size_t>(current_object_)].shapes.push_back(
          static_cast<int>(scene_.shapes.size()));
    }
    if (!gs_.inside_medium.empty() || !gs_.outside_medium.empty())
      pending_media_.push_back({static_cast<int>(scene_.shapes.size()), gs_.inside_medium,
                                gs_.outside_medium, gs_.medium_loc});
    scene_.shapes.push_back(std::move(s));
  }

  int inlineMesh(const std::string& type, ParamSet& ps, const FileLoc& loc) {
    Mesh m;
    const int fv = type == "bilinearmesh" ? 4 : 3;
    m.vertices_per_face = fv;
    const Param* P = ps.find({"P"}, {ParamType::Point3});
    if (!P) throw Error(loc, fmt::format("{}: missing \"point3 P\"", type));
    std::vector<Vec3> pos;
    for (size_t i = 0; i + 2 < P->numbers.size(); i += 3)
      pos.push_back({P->numbers[i], P->numbers[i + 1], P->numbers[i + 2]});
    const Param* I = ps.find({"indices"}, {ParamType::Integer});
    std::vector<int> idx;
    if (I) {
      for (double v : I->numbers) idx.push_back(static_cast<int>(v));
      if (idx.size() % static_cast<size_t>(fv) != 0)
        ps.fail(*I, fmt::format("expected a multiple of {} indices, got {}", fv, idx.size()));
      for (int i : idx)
        if (i < 0 || static_cast<size_t>(i) >= pos.size())
          ps.fail(*I, fmt::format("index {} out of range: there are {} vertices", i, pos.size()));
    } else if (pos.size() == static_cast<size_t>(fv)) {
      for (int i = 0; i < fv; ++i) idx.push_back(i);
    } else {
      throw Error(loc, fmt::format("{}: missing \"integer indices\" (only a single {} may omit "
                                   "them)",
                                   type, fv == 3 ? "triangle" : "patch"));
    }
    if (type == "loopsubdiv") {
      int levels = ps.getInt({"levels", "nlevels"}, 3);
      if (levels < 0 || levels > 8) throw Error(loc, fmt::format("loopsubdiv: {} levels", levels));
      // Every level makes four triangles of one; with the topology tables about 400 bytes a
      // triangle at the last level.
      const double triangles = static_cast<double>(idx.size() / 3) * std::pow(4.0, levels);
      checkMemory(400.0 * triangles, loc,
                  fmt::format("loopsubdiv: {} levels of {} triangles ({:.3g} triangles)", levels,
                              idx.size() / 3, triangles));
      loopSubdivide(pos, idx, levels);
    }
    for (const Vec3& p : pos) m.positions.push_back(Vec3f(p));
    m.indices = std::move(idx);
    auto perVertex = [&](const Param* p, size_t per) {
      if (p && p->numbers.size() != pos.size() * per)
        ps.fail(*p, fmt::format("expected one value per vertex ({}), got {}", pos.size(),
                                p->numbers.size() / per));
    };
    if (type != "loopsubdiv") {
      const Param* N = ps.find({"N"}, {ParamType::Normal3});
      perVertex(N, 3);
      if (N)
        for (size_t i = 0; i + 2 < N->numbers.size(); i += 3)
          m.normals.push_back(Vec3f(Vec3{N->numbers[i], N->numbers[i + 1], N->numbers[i + 2]}));
      const Param* UV = ps.find({"uv", "st"}, {ParamType::Point2, ParamType::Float});
      perVertex(UV, 2);
      if (UV)
        for (size_t i = 0; i + 1 < UV->numbers.size(); i += 2)
          m.uvs.push_back({float(UV->numbers[i]), float(UV->numbers[i + 1])});
      if (fv == 3) {
        const Param* S = ps.find({"S"}, {ParamType::Vector3});
        perVertex(S, 3);
        if (S)
          for (size_t i = 0; i + 2 < S->numbers.size(); i += 3)
            m.tangents.push_back(Vec3f(Vec3{S->numbers[i], S->numbers[i + 1], S->numbers[i + 2]}));
      }
      m.face_indices = ps.getInts({"faceIndices"});
    }
    scene_.meshes.push_back(std::move(m));
    return static_cast<int>(scene_.meshes.size()) - 1;
  }

  // pbrt-v4 Curve::Create (src/pbrt/shapes.cpp): "P", "basis" bezier|bspline, "degree" 2|3
  // (3), "type" flat|ribbon|cylinder (flat), "N" for ribbons (nSegments + 1), "width" (1),
  // "width0"/"width1" (width), "splitdepth" (pbrt's refinement; read and ignored).
  int curveShape(ParamSet& ps, const FileLoc& loc) {
    const std::string basis = ps.getString({"basis"}, "bezier");
    if (basis != "bezier" && basis != "bspline") {
      const Param* p = ps.peek({"basis"});
      throw Error(p ? p->loc : loc, fmt::format("curve basis \"{}\": expected \"bezier\" or "
                                                "\"bspline\"",
                                                basis));
    }
    const int degree = ps.getInt({"degree"}, 3);
    if (degree != 2 && degree != 3) {
      const Param* p = ps.peek({"degree"});
      throw Error(p ? p->loc : loc, fmt::format("curve degree {}: expected 2 or 3", degree));
    }
    const std::vector<Vec3> P = ps.getVec3s({"P"}, {ParamType::Point3});
    const bool bspline = basis == "bspline";
    const int segments = curveSegmentCount(bspline, degree, P.size());
    if (segments <= 0) {
      const Param* p = ps.peek({"P"});
      throw Error(p ? p->loc : loc,
                  bspline ? fmt::format("curve: {} control points; a degree {} b-spline needs at "
                                        "least {}",
                                        P.size(), degree, degree + 1)
                          : fmt::format("curve: {} control points; a degree {} Bézier curve "
                                        "needs {} + n * {}",
                                        P.size(), degree, degree + 1, degree));
    }
    const std::string type = ps.getString({"type"}, "flat");
    CurveKind kind = CurveKind::Flat;
    if (type == "ribbon")
      kind = CurveKind::Ribbon;
    else if (type == "cylinder")
      kind = CurveKind::Cylinder;
    else if (type != "flat") {
      // pbrt-v4 reports an unknown type and uses "cylinder".
      const Param* p = ps.peek({"type"});
      warnOnce(fmt::format("curve type {}", type), p ? p->loc : loc,
               fmt::format("unknown curve type \"{}\"; using \"cylinder\" (as pbrt-v4)", type));
      kind = CurveKind::Cylinder;
    }
    std::vector<Vec3> N = ps.getVec3s({"N"}, {ParamType::Normal3});
    if (!N.empty() && kind != CurveKind::Ribbon) {
      warnOnce("curve normals", loc, "curve normals \"N\" are only used with \"ribbon\" curves");
      N.clear();
    } else if (kind == CurveKind::Ribbon && N.size() != size_t(segments) + 1) {
      throw Error(loc, fmt::format("ribbon curve: {} normals \"N\" given; {} needed (one per "
                                   "segment end, {} segments)",
                                   N.size(), segments + 1, segments));
    }
    const double width = ps.getFloat({"width"}, 1);
    const double w0 = ps.getFloat({"width0"}, width), w1 = ps.getFloat({"width1"}, width);
    if (w0 < 0 || w1 < 0) throw Error(loc, fmt::format("curve widths {} and {} must be >= 0", w0, w1));
    ps.getInt({"splitdepth"}, 3);  // pbrt's subdivision depth: Embree needs none
    scene_.curves.push_back(makeCurve(kind, bspline, degree, P, w0, w1, N));
    return static_cast<int>(scene_.curves.size()) - 1;
  }

  // pbrt's hyperboloid, paraboloid, heightfield and nurbs as meshes (scene/shapes_tessellated).
  int tessellatedShape(const std::string& type, ParamSet& ps, const FileLoc& loc) {
    auto phimaxOf = [&] {
      const double phimax = ps.getFloat({"phimax"}, 360);
      if (phimax <= 0 || phimax > 360) {
        const Param* p = ps.peek({"phimax"});
        throw Error(p ? p->loc : loc, fmt::format("phimax {} outside (0, 360] degrees", phimax));
      }
      return phimax;
    };
    Mesh m;
    if (type == "hyperboloid") {
      // pbrt-v3 CreateHyperboloidShape (src/shapes/hyperboloid.cpp): p1 (0,0,0), p2 (1,1,1).
      const Vec3 p1 = ps.findPoint3({"p1"}).value_or(Vec3{0, 0, 0});
      const Vec3 p2 = ps.findPoint3({"p2"}).value_or(Vec3{1, 1, 1});
      const double phimax = phimaxOf();
      if (p1 == p2) throw Error(loc, "hyperboloid: p1 and p2 are the same point");
      m = tessellateHyperboloid(p1, p2, phimax);
    } else if (type == "paraboloid") {
      // pbrt-v3 CreateParaboloidShape (src/shapes/paraboloid.cpp): radius 1, zmin 0, zmax 1;
      // the constructor orders zmin/zmax and keeps z >= 0.
      const double radius = ps.getFloat({"radius"}, 1);
      double zmin = ps.getFloat({"zmin"}, 0), zmax = ps.getFloat({"zmax"}, 1);
      const double phimax = phimaxOf();
      if (zmin > zmax) std::swap(zmin, zmax);
      zmin = std::max(zmin, 0.0);
      if (radius <= 0) {
        const Param* p = ps.peek({"radius"});
        throw Error(p ? p->loc : loc, fmt::format("radius {} must be positive", radius));
      }
      if (zmax <= zmin)
        throw Error(loc, fmt::format("paraboloid: empty z range [{}, {}] (z >= 0)", zmin, zmax));
      m = tessellateParaboloid(radius, zmin, zmax, phimax);
    } else if (type == "heightfield") {
      // pbrt-v3 CreateHeightfield (src/shapes/heightfield.cpp): nu, nv, nu*nv floats Pz.
      const int nu = ps.getInt({"nu"}, -1), nv = ps.getInt({"nv"}, -1);
      const Param* pz = ps.find({"Pz"}, {ParamType::Float});
      if (nu < 2 || nv < 2)
        throw Error(loc, fmt::format("heightfield: \"integer nu\" {} and \"integer nv\" {} "
                                     "must both be given and >= 2",
                                     nu, nv));
      if (!pz) throw Error(loc, "heightfield: missing \"float Pz\"");
      if (pz->numbers.size() != size_t(nu) * size_t(nv))
        ps.fail(*pz, fmt::format("expected nu*nv = {} heights, got {}", nu * nv,
                                 pz->numbers.size()));
      m = heightfieldMesh(nu, nv, pz->numbers);
    } else {
      m = nurbsMeshOf(ps, loc);
    }
    scene_.meshes.push_back(std::move(m));
    return static_cast<int>(scene_.meshes.size()) - 1;
  }

  // pbrt-v3 CreateNURBS (src/shapes/nurbs.cpp): nu, nv, uorder, vorder, uknots (nu+uorder),
  // vknots (nv+vorder), u0/u1 default uknots[uorder-1]/uknots[nu] (v likewise), and either
  // "point3 P" or homogeneous "float Pw" (x w, y w, z w, w); diced 30 x 30.
  Mesh nurbsMeshOf(ParamSet& ps, const FileLoc& loc) {
    NurbsPatch n;
    n.nu = ps.getInt({"nu"}, -1);
    n.nv = ps.getInt({"nv"}, -1);
    n.uorder = ps.getInt({"uorder"}, -1);
    n.vorder = ps.getInt({"vorder"}, -1);
    if (n.nu < 1 || n.nv < 1 || n.uorder < 1 || n.vorder < 1)
      throw Error(loc, "nurbs: \"integer nu\", \"nv\", \"uorder\" and \"vorder\" must be given "
                       "and positive");
    if (n.uorder > n.nu || n.vorder > n.nv)
      throw Error(loc, fmt::format("nurbs: order ({}, {}) exceeds the control points ({}, {})",
                                   n.uorder, n.vorder, n.nu, n.nv));
    auto knots = [&](std::string_view name, size_t count) {
      const Param* k = ps.find({name}, {ParamType::Float});
      if (!k) throw Error(loc, fmt::format("nurbs: missing \"float {}\"", name));
      if (k->numbers.size() != count)
        ps.fail(*k, fmt::format("expected {} knots, got {}", count, k->numbers.size()));
      for (size_t i = 1; i < count; ++i)
        if (k->numbers[i] < k->numbers[i - 1]) ps.fail(*k, "knots must be non-decreasing");
      return k->numbers;
    };
    n.uknots = knots("uknots", size_t(n.nu + n.uorder));
    n.vknots = knots("vknots", size_t(n.nv + n.vorder));
    n.u0 = ps.getFloat({"u0"}, n.uknots[size_t(n.uorder - 1)]);
    n.u1 = ps.getFloat({"u1"}, n.uknots[size_t(n.nu)]);
    n.v0 = ps.getFloat({"v0"}, n.vknots[size_t(n.vorder - 1)]);
    n.v1 = ps.getFloat({"v1"}, n.vknots[size_t(n.nv)]);
    const size_t count = size_t(n.nu) * size_t(n.nv);
    if (const Param* P = ps.find({"P"}, {ParamType::Point3})) {
      if (P->numbers.size() != 3 * count)
        ps.fail(*P, fmt::format("expected nu*nv = {} points, got {}", count,
                                P->numbers.size() / 3));
      for (size_t i = 0; i < count; ++i)
        n.P.push_back({P->numbers[3 * i], P->numbers[3 * i + 1], P->numbers[3 * i + 2]});
      n.w.assign(count, 1.0);
    } else if (const Param* Pw = ps.find({"Pw"}, {ParamType::Float})) {
      if (Pw->numbers.size() != 4 * count)
        ps.fail(*Pw, fmt::format("expected 4 nu*nv = {} values, got {}", 4 * count,
                                 Pw->numbers.size()));
      for (size_t i = 0; i < count; ++i) {
        const double w = Pw->numbers[4 * i + 3];
        if (!(w > 0)) ps.fail(*Pw, fmt::format("weight {} of point {} must be positive", w, i));
        n.P.push_back(Vec3{Pw->numbers[4 * i], Pw->numbers[4 * i + 1], Pw->numbers[4 * i + 2]} / w);
        n.w.push_back(w);
      }
    } else {
      throw Error(loc, "nurbs: missing \"point3 P\" or \"float Pw\"");
    }
    return nurbsMesh(n);
  }

  int plyMesh(ParamSet& ps, const FileLoc& loc) {
    const Param* fn = ps.find({"filename"}, {ParamType::String});
    if (!fn) throw Error(loc, "plymesh: missing \"string filename\"");
    std::string path = resolve(fn->strings[0], fn->loc, "PLY file");
    if (floatInput(ps, {"displacement"}))
      warnOnce("plymesh displacement", ps.peek({"displacement"})->loc,
               "plymesh \"displacement\" is not rendered; the mesh is used undisplaced");
    ps.getFloat({"edgelength"}, 1);
    io::PlyMesh ply;
    try {
      ply = io::readPly(path);
    } catch (const Error& e) {
      throw Error(fn->loc, e.message());
    }
    Mesh m;
    m.source = path;
    m.positions = std::move(ply.positions);
    m.normals = std::move(ply.normals);
    m.uvs = std::move(ply.uvs);
    m.indices = std::move(ply.triangles);
    // Quads (pbrt-v4 bilinear order p00 p10 p01 p11) become two triangles each.
    for (size_t q = 0; q + 3 < ply.quads.size(); q += 4) {
      const int* v = &ply.quads[q];
      m.indices.insert(m.indices.end(), {v[0], v[1], v[3], v[0], v[3], v[2]});
    }
    scene_.meshes.push_back(std::move(m));
    return static_cast<int>(scene_.meshes.size()) - 1;
  }

  const SceneDesc& desc_;
  Scene scene_;
  fs::path top_dir_;
  GraphicsState gs_;
  std::vector<GraphicsState> stack_;
  std::map<std::string, std::pair<Transform, Transform>> named_cs_;
  std::map<std::string, int> float_textures_, spectrum_textures_, named_materials_, object_index_;
  std::set<std::string> warned_;
  int current_object_ = -1;
  int default_material_ = -1;
  struct PendingInstance {
    std::string name;
    FileLoc loc;
    Transform transform;
  };
  std::vector<PendingInstance> pending_instances_;
  // Media named by MediumInterface, resolved after all MakeNamedMedium (as pbrt-v4 does).
  struct PendingMedia {
    int shape;  ///< index into Scene::shapes, or -1 for the camera
    std::string inside, outside;
    FileLoc loc;
  };
  std::vector<PendingMedia> pending_media_;
  std::map<std::string, int> named_media_;

  // ---- media ---------------------------------------------------------------------------------
  void makeNamedMedium(const Directive& d) {
    const std::string& name = d.strings[0];
    ParamSet ps(d.params, d.loc, fmt::format("MakeNamedMedium \"{}\"", name));
    ps.addDefaults(gs_.medium_attrs);
    auto type = ps.findString({"type"});
    if (!type)
      throw Error(d.loc, fmt::format("MakeNamedMedium \"{}\": missing \"string type\"", name));
    Medium m;
    m.name = name;
    m.loc = d.loc;
    m.type_as_written = *type;
    m.medium_from_world = inverse(gs_.ctm[0]);
    if (*type == "uniformgrid" || *type == "rgbgrid" || *type == "heterogeneous") {
      gridMedium(m, ps, d.loc);
      finish(ps);
      if (named_media_.count(name)) warn(d.loc, fmt::format("named medium \"{}\" redefined", name));
      scene_.media.push_back(std::move(m));
      named_media_[name] = static_cast<int>(scene_.media.size()) - 1;
      return;
    }
    if (*type != "homogeneous") {
      ps.markAllUsed();
      warnOnce("medium " + *type, d.loc,
               fmt::format("medium \"{}\" is not rendered by lensim; media of this type are "
                           "left out (vacuum)",
                           *type));
      named_media_[name] = -1;
      return;
    }
    m.type = "homogeneous";
    if (const Param* p = ps.find({"preset"}, {ParamType::String})) {
      m.preset = p->strings[0];
      if (!mediumPreset(m.preset, m.sigma_a, m.sigma_s)) {
        std::string best;
        size_t best_d = 4;
        for (const std::string& k : mediumPresetNames())
          if (size_t dist = editDistance(m.preset, k); dist < best_d) best_d = dist, best = k;
        ps.fail(*p, fmt::format("unknown medium preset \"{}\"{}", m.preset,
                                best.empty() ? "" : fmt::format("; did you mean \"{}\"?", best)));
      }
    } else {
      auto spectrum = [&](const char* pname, SpectrumValue& out) {
        if (const Param* p =
                ps.find({pname}, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody}))
          out = spectrumOf(*p);
      };
      spectrum("sigma_a", m.sigma_a);
      spectrum("sigma_s", m.sigma_s);
    }
    if (const Param* p =
            ps.find({"Le"}, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody}))
      m.Le = spectrumOf(*p);
    m.Le_scale = ps.getFloat({"Lescale"}, 1);
    m.scale = ps.getFloat({"scale"}, 1);
    m.g = ps.getFloat({"g"}, 0);
    if (!(m.g > -1 && m.g < 1)) {
      const Param* p = ps.peek({"g"});
      throw Error(p ? p->loc : d.loc,
                  fmt::format("medium \"{}\": g {} outside (-1, 1)", name, m.g));
    }
    if (!(m.scale >= 0)) {
      const Param* p = ps.peek({"scale"});
      throw Error(p ? p->loc : d.loc,
                  fmt::format("medium \"{}\": scale {} must not be negative", name, m.scale));
    }
    finish(ps);
    if (named_media_.count(name)) warn(d.loc, fmt::format("named medium \"{}\" redefined", name));
    scene_.media.push_back(std::move(m));
    named_media_[name] = static_cast<int>(scene_.media.size()) - 1;
  }

  // pbrt-v4's "uniformgrid" (GridMedium: a density grid scaling sigma_a and sigma_s, optional
  // per-voxel Lescale) and "rgbgrid" (RGBGridMedium: RGB sigma_a, sigma_s and Le grids).
  void gridMedium(Medium& m, ParamSet& ps, const FileLoc& loc) {
    // pbrt-v3's "heterogeneous" (GridDensityMedium) is pbrt-v4's uniformgrid.
    m.type = m.type_as_written == "heterogeneous" ? "uniformgrid" : m.type_as_written;
    m.nx = ps.getInt({"nx"}, 1);
    m.ny = ps.getInt({"ny"}, 1);
    m.nz = ps.getInt({"nz"}, 1);
    if (m.nx < 1 || m.ny < 1 || m.nz < 1)
      throw Error(loc, fmt::format("medium \"{}\": grid resolution {} x {} x {} must be positive",
                                   m.name, m.nx, m.ny, m.nz));
    const size_t n = size_t(m.nx) * size_t(m.ny) * size_t(m.nz);
    if (auto p = ps.findPoint3({"p0"})) m.p0 = *p;
    if (auto p = ps.findPoint3({"p1"})) m.p1 = *p;
    if (!(m.p0.x < m.p1.x && m.p0.y < m.p1.y && m.p0.z < m.p1.z))
      throw Error(ps.peek({"p1"}) ? ps.peek({"p1"})->loc : loc,
                  fmt::format("medium \"{}\": empty bounds p0 ({}, {}, {}) to p1 ({}, {}, {})",
                              m.name, m.p0.x, m.p0.y, m.p0.z, m.p1.x, m.p1.y, m.p1.z));
    auto expectCount = [&](const char* pname, size_t count, size_t per) {
      const Param* p = ps.peek({pname});
      if (count != n)
        throw Error(
            p ? p->loc : loc,
            fmt::format("medium \"{}\": \"{}\" has {} values; expected nx*ny*nz = {}{}", m.name,
                        pname, count, n, per > 1 ? fmt::format(" ({} numbers each)", per) : ""));
    };
    m.scale = ps.getFloat({"scale"}, 1);
    m.g = ps.getFloat({"g"}, 0);
    if (!(m.g > -1 && m.g < 1)) {
      const Param* p = ps.peek({"g"});
      throw Error(p ? p->loc : loc,
                  fmt::format("medium \"{}\": g {} outside (-1, 1)", m.name, m.g));
    }
    auto negative = [&](const char* pname, const std::vector<double>& v) {
      for (double x : v)
        if (!(x >= 0))
          throw Error(
              ps.peek({pname})->loc,
              fmt::format("medium \"{}\": \"{}\" has a negative value {}", m.name, pname, x));
    };
    if (m.type == "uniformgrid") {
      const Param* dp = ps.find({"density"}, {ParamType::Float});
      if (!dp) throw Error(loc, fmt::format("medium \"{}\": missing \"float density\"", m.name));
      m.density = dp->numbers;
      expectCount("density", m.density.size(), 1);
      negative("density", m.density);
      if (ps.peek({"temperature"}))
        throw Error(
            ps.peek({"temperature"})->loc,
            fmt::format("medium \"{}\": \"temperature\" grids are not rendered by lensim", m.name));
      auto spectrum = [&](const char* pname, SpectrumValue& out) {
        if (const Param* p =
                ps.find({pname}, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody}))
          out = spectrumOf(*p);
      };
      spectrum("sigma_a", m.sigma_a);
      spectrum("sigma_s", m.sigma_s);
      spectrum("Le", m.Le);
      if (const Param* p = ps.find({"Lescale"}, {ParamType::Float})) {
        if (p->numbers.size() == 1 && n != 1) {
          m.Le_scale = p->numbers[0];
        } else {
          m.Le_scale_grid = p->numbers;
          expectCount("Lescale", m.Le_scale_grid.size(), 1);
        }
      }
    } else {
      auto rgbs = [&](const char* pname, std::vector<Vec3>& out) {
        if (const Param* p = ps.find({pname}, {ParamType::Rgb})) {
          if (p->numbers.size() % 3)
            throw Error(p->loc, fmt::format("\"{}\": {} numbers is not a whole number of rgb "
                                            "values",
                                            pname, p->numbers.size()));
          negative(pname, p->numbers);
          for (size_t i = 0; i < p->numbers.size(); i += 3)
            out.push_back({p->numbers[i], p->numbers[i + 1], p->numbers[i + 2]});
          expectCount(pname, out.size(), 3);
        }
      };
      rgbs("sigma_a", m.sigma_a_grid);
      rgbs("sigma_s", m.sigma_s_grid);
      rgbs("Le", m.Le_grid);
      if (m.sigma_a_grid.empty() && m.sigma_s_grid.empty())
        throw Error(loc, fmt::format("medium \"{}\": rgbgrid needs \"rgb sigma_a\" or \"rgb "
                                     "sigma_s\" values",
                                     m.name));
      m.Le_scale = ps.getFloat({"Lescale"}, 1);
    }
  }

  int mediumIndex(const std::string& name, const FileLoc& loc) {
    if (name.empty()) return -1;
    auto it = named_media_.find(name);
    if (it != named_media_.end()) return it->second;
    std::string best;
    size_t best_d = 3;
    for (const auto& [k, v] : named_media_)
      if (size_t dist = editDistance(name, k); dist < best_d) best_d = dist, best = k;
    throw Error(loc, fmt::format("MediumInterface: unknown medium \"{}\"{}", name,
                                 best.empty() ? " (no MakeNamedMedium defines it)"
                                              : fmt::format("; did you mean \"{}\"?", best)));
  }

  void resolveMedia() {
    std::set<std::pair<std::string, std::string>> reported;  // each bad name once per place
    for (const PendingMedia& pm : pending_media_) {
      try {
        const int in = mediumIndex(pm.inside, pm.loc), out = mediumIndex(pm.outside, pm.loc);
        if (pm.shape < 0) {
          scene_.camera.medium = out;
        } else {
          Shape& s = scene_.shapes[static_cast<size_t>(pm.shape)];
          s.inside_medium = in;
          s.outside_medium = out;
        }
      } catch (const Error& e) {
        if (reported.insert({e.loc().str(), e.message()}).second)
          scene_.diagnostics.push_back({Severity::Error, e.loc(), e.message()});
      }
    }
    bool used = scene_.camera.medium >= 0;
    for (const Shape& sh : scene_.shapes)
      used = used || sh.inside_medium >= 0 || sh.outside_medium >= 0;
    if (used && scene_.integrator.type == "bdpt") {
      // lensim's bdpt does not trace media (pbrt-v4's does): volpath renders them.
      warn(scene_.integrator.loc.valid() ? scene_.integrator.loc : scene_.camera.loc,
           "the scene has participating media, which lensim's \"bdpt\" does not handle; it "
           "renders as \"volpath\"");
      scene_.integrator.type = "volpath";
    }
    if (used && scene_.integrator.type == "path")
      warn(scene_.integrator.loc.valid() ? scene_.integrator.loc : scene_.camera.loc,
           fmt::format("the scene has participating media but integrator \"{}\" ignores them; "
                       "use \"volpath\"",
                       scene_.integrator.type_as_written.empty()
                           ? "path"
                           : scene_.integrator.type_as_written));
  }
};

}  // namespace

Scene build(const SceneDesc& desc) {
  return Builder(desc).run();
}

Scene loadScene(const std::string& path) {
  Scene s = build(parseFile(path));
  const Diagnostic* first = nullptr;
  int errors = 0;
  for (const Diagnostic& d : s.diagnostics)
    if (d.severity == Severity::Error) {
      if (!first) first = &d;
      ++errors;
    }
  if (first)
    throw Error(first->loc,
                errors == 1 ? first->message
                            : fmt::format("{} (and {} more errors)", first->message, errors - 1));
  return s;
}

}  // namespace lensim::scene
