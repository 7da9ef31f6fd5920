#include "lens_info_placed.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "lensim/optics/glass.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/off_axis_mirror.h"
#include "lensim/optics/placed_lens.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

using nlohmann::json;
using optics::PlacedLens;

namespace {

std::string notComputed(const optics::LensPrescription& p) {
  return fmt::format("focal lengths, principal planes, pupils, f-number, field of view, "
                     "distortion and MTF need a rotationally symmetric (coaxial) system; this "
                     "lens has {}",
                     optics::firstGrating(p) ? "a diffraction grating"
                                             : "tilted or decentred surfaces");
}

// The chief ray at one wavelength (a lens with a grating diffracts each its own way).
struct ChiefAt {
  double wavelength_nm = 0;
  std::optional<Vec3> image, direction;  // image surface's frame
};

struct FieldReport {
  std::string label;
  PlacedLens::Field field;
  std::optional<Vec3> chief_image, chief_direction;  // image surface's frame
  std::vector<ChiefAt> chief_by_wavelength;          // lenses with a grating
  std::vector<std::pair<std::string, std::optional<Vec3>>> marginal;  // image surface's frame
  std::optional<PlacedLens::Spot> spot;
};

// The image-frame point and direction of the ray aimed at stop_xy, if it gets through.
std::optional<std::pair<Vec3, Vec3>> aimedRay(const PlacedLens& lens,
                                              const PlacedLens::Field& f, Vec2 stop_xy) {
  const auto e = lens.aim(f, stop_xy);
  if (!e) return std::nullopt;
  const optics::TraceResult t = lens.trace(lens.fieldRay(f, *e));
  if (!t.ok()) return std::nullopt;
  const Vec3 dir = lens.toImageFrame(t.ray.origin + t.ray.direction) -
                   lens.toImageFrame(t.ray.origin);
  return std::pair{lens.toImageFrame(t.ray.origin), dir};
}

FieldReport reportField(const PlacedLens& lens, const PlacedLens::Field& f, std::string label) {
  FieldReport r;
  r.label = std::move(label);
  r.field = f;
  if (auto c = aimedRay(lens, f, {0, 0})) r.chief_image = c->first, r.chief_direction = c->second;
  // Just inside the stop's edge, so that rounding in the aim does not clip the ray there.
  const double a = lens.stopSemiAperture_mm() * (1 - 1e-9);
  const std::pair<const char*, Vec2> edges[] = {
      {"+y", {0, a}}, {"-y", {0, -a}}, {"+x", {a, 0}}, {"-x", {-a, 0}}};
  for (const auto& [name, xy] : edges) {
    const auto m = aimedRay(lens, f, xy);
    r.marginal.push_back({name, m ? std::optional<Vec3>(m->first) : std::nullopt});
  }
  r.spot = lens.spot(f);
  return r;
}

// The file's wavelengths, each once, in order (the lens's own when the file lists none).
std::vector<double> distinctWavelengths(const optics::LensPrescription& p, double lambda) {
  std::vector<double> out;
  for (double w : p.wavelengths_nm)
    if (std::find(out.begin(), out.end(), w) == out.end()) out.push_back(w);
  if (out.empty()) out.push_back(lambda);
  return out;
}

json vecJson(const std::optional<Vec3>& v) {
  return v ? json::array({v->x, v->y, v->z}) : json(nullptr);
}

// `lens info --json` of a non-coaxial lens.
json placedJson(const optics::LensPrescription& p, const PlacedLens& lens,
                const std::vector<FieldReport>& fields, double lambda, bool at_inf) {
  json j;
  j["lens"] = {{"name", p.name}, {"path", p.path}, {"format", p.format}};
  j["noncoaxial"] = {{"reason", p.noncoaxial_reason},
                     {"line", p.noncoaxial_loc->line},
                     {"not_computed", notComputed(p)}};
  j["wavelength_nm"] = lambda;
  j["stop"] = {{"surface_row", lens.stopIndex()},
               {"semi_diameter_mm", lens.stopSemiAperture_mm()},
               {"aperture", p.aperture_spec}};
  json surfaces = json::array();
  for (const auto& s : p.surfaces) {
    const auto& f = *s.frame;
    json row = {{"line", s.loc.line},
                {"vertex_mm", f.origin_mm},
                {"axis", {f.rotation[0][2], f.rotation[1][2], f.rotation[2][2]}},
                {"radius_mm", s.radius_mm},
                {"semi_diameter_mm", s.semiAperture_mm()},
                {"mirror", s.mirror}};
    if (s.grating)
      row["grating"] = {{"lines_per_um", s.grating->lines_per_um},
                        {"order", s.grating->order}};
    if (s.shape.conic != 0) row["conic"] = s.shape.conic;
    if (s.apertureDecentred()) row["aperture_decentre_mm"] = s.aperture_decentre_mm;
    if (const auto oap = optics::offAxisParabola(s))
      row["off_axis_paraboloid"] = {{"parent_focal_length_mm", oap->parent_focal_length_mm},
                                    {"reflected_focal_length_mm", oap->reflected_focal_length_mm},
                                    {"off_axis_angle_deg", oap->off_axis_angle_deg}};
    surfaces.push_back(row);
  }
  j["surfaces"] = surfaces;
  j["image_surface"] = {{"vertex_mm", p.image_frame.origin_mm},
                        {"axis", {p.image_frame.rotation[0][2], p.image_frame.rotation[1][2],
                                  p.image_frame.rotation[2][2]}}};
  json fj = json::array();
  for (const FieldReport& r : fields) {
    json m = json::object();
    for (const auto& [name, v] : r.marginal) m[name] = vecJson(v);
    json spot = nullptr;
    if (r.spot)
      spot = {{"rays", r.spot->rays},
              {"centroid_mm", {r.spot->centroid.x, r.spot->centroid.y}},
              {"rms_radius_mm", r.spot->rms_mm}};
    json fr = {{"field", r.label},
               {"field_unit", at_inf ? "degrees" : "mm"},
               {"chief_ray_image_mm", vecJson(r.chief_image)},
               {"chief_ray_direction", vecJson(r.chief_direction)},
               {"marginal_rays_image_mm", m},
               {"spot", spot}};
    if (lens.hasGrating()) {
      json per = json::array();
      for (const ChiefAt& c : r.chief_by_wavelength)
        per.push_back({{"wavelength_nm", c.wavelength_nm},
                       {"image_mm", vecJson(c.image)},
                       {"direction", vecJson(c.direction)}});
      fr["chief_ray_by_wavelength"] = per;
    }
    fj.push_back(fr);
  }
  j["fields"] = fj;
  return j;
}

}  // namespace

int runInfoNonCoaxial(const LensArgs& args, const optics::LensPrescription& p, bool as_json) {
  for (const Diagnostic& d : p.diagnostics) logDiagnostic(d);
  const double lambda = args.wavelength_nm.value_or(optics::primaryWavelength_nm(p));
  if (args.wavelength_nm) optics::checkWavelength(lambda, "--wavelength");
  const PlacedLens lens(p, lambda);
  for (const Diagnostic& d : lens.diagnostics()) logDiagnostic(d);

  std::vector<FieldReport> fields;
  const bool at_inf = !p.object_distance_mm;
  std::vector<std::string> specs = args.fields.empty() ? std::vector<std::string>{"0,0"}
                                                       : args.fields;
  for (const std::string& spec : specs) {
    const Vec2 v = parsePair(spec, "--field");
    PlacedLens::Field f;
    f.at_infinity = at_inf;
    if (at_inf) {
      if (!(std::abs(v.x) < 90 && std::abs(v.y) < 90))
        throw Error(fmt::format("--field {}: expected angles in degrees between -90 and 90",
                                spec));
      f.angle_x_deg = v.x, f.angle_y_deg = v.y;
    } else {
      f.object_point = {v.x, v.y, -*p.object_distance_mm};
    }
    fields.push_back(reportField(lens, f, spec));
  }
  if (lens.hasGrating()) {
    PlacedLens at = lens;
    for (double w : distinctWavelengths(p, lambda)) {
      at.setWavelength(w);
      for (FieldReport& r : fields) {
        ChiefAt c{w, {}, {}};
        if (auto ray = aimedRay(at, r.field, {0, 0})) c.image = ray->first, c.direction = ray->second;
        r.chief_by_wavelength.push_back(c);
      }
    }
  }

  if (as_json) {
    std::cout << placedJson(p, lens, fields, lambda, at_inf).dump(2) << "\n";
    return 0;
  }

  auto line = [](const std::string& k, const std::string& v) {
    std::cout << fmt::format("  {:<26}{}\n", k, v);
  };
  std::cout << fmt::format("{}\n", p.name);
  line("file", fmt::format("{} ({}, {} surfaces, {})", p.path, p.format, p.surfaces.size(),
                           optics::firstGrating(p) ? "with a grating" : "tilted or decentred"));
  line("not coaxial", fmt::format("{} (line {})", p.noncoaxial_reason, p.noncoaxial_loc->line));
  line("not computed", notComputed(p));
  line("wavelength", fmt::format("{:.4f} nm", lambda));
  line("stop", fmt::format("row {}, semi-diameter {:.6g} mm ({})", lens.stopIndex(),
                           lens.stopSemiAperture_mm(), p.aperture_spec));
  std::cout << "  surfaces (vertex and axis in the front surface's frame, mm):\n";
  for (size_t i = 0; i < p.surfaces.size(); ++i) {
    const auto& s = p.surfaces[i];
    const auto& f = *s.frame;
    std::cout << fmt::format("    {:>3}  line {:>5}  vertex ({:.6f}, {:.6f}, {:.6f})  axis "
                             "({:.6f}, {:.6f}, {:.6f})  R {:.6g}{}{}{}{}\n",
                             i, s.loc.line, f.origin_mm[0], f.origin_mm[1], f.origin_mm[2],
                             f.rotation[0][2], f.rotation[1][2], f.rotation[2][2], s.radius_mm,
                             s.shape.conic != 0 ? fmt::format("  conic {:.6g}", s.shape.conic)
                                                : std::string(),
                             s.mirror ? "  mirror" : "",
                             s.apertureDecentred()
                                 ? fmt::format("  aperture centred at ({:.6g}, {:.6g})",
                                               s.aperture_decentre_mm[0], s.aperture_decentre_mm[1])
                                 : std::string(),
                             s.grating ? fmt::format("  grating {:.6g} lines/um (lines along x), "
                                                     "order {}",
                                                     s.grating->lines_per_um, s.grating->order)
                                       : std::string());
  }
  for (size_t i = 0; i < p.surfaces.size(); ++i)
    if (const auto oap = optics::offAxisParabola(p.surfaces[i]))
      std::cout << fmt::format("    {:>3}  off-axis paraboloid: parent focal length {:.6g} mm, "
                               "reflected focal length {:.6g} mm, off-axis angle {:.6g} deg "
                               "(for light along the parent's axis)\n",
                               i, oap->parent_focal_length_mm, oap->reflected_focal_length_mm,
                               oap->off_axis_angle_deg);
  const auto& im = p.image_frame;
  std::cout << fmt::format("    image          vertex ({:.6f}, {:.6f}, {:.6f})  axis ({:.6f}, "
                           "{:.6f}, {:.6f})\n",
                           im.origin_mm[0], im.origin_mm[1], im.origin_mm[2], im.rotation[0][2],
                           im.rotation[1][2], im.rotation[2][2]);
  std::cout << "  real rays on the image surface (its own frame, mm):\n";
  for (const FieldReport& r : fields) {
    std::cout << fmt::format("    field {} {}\n", r.label, at_inf ? "deg" : "mm");
    std::cout << "      chief ray      "
              << (r.chief_image ? fmt::format("x {:.6f}  y {:.6f}", r.chief_image->x,
                                              r.chief_image->y)
                                : std::string("does not get through"))
              << "\n";
    for (const auto& [name, v] : r.marginal)
      std::cout << fmt::format("      marginal {:<6}{}\n", name,
                               v ? fmt::format("x {:.6f}  y {:.6f}", v->x, v->y)
                                 : std::string("blocked or not found"));
    for (const ChiefAt& c : r.chief_by_wavelength)
      std::cout << fmt::format(
          "      chief ray at {:.4f} nm  {}\n", c.wavelength_nm,
          c.image ? fmt::format("x {:.6f}  y {:.6f}  direction ({:.9f}, {:.9f}, {:.9f})",
                                c.image->x, c.image->y, c.direction->x, c.direction->y,
                                c.direction->z)
                  : std::string("does not get through"));
    if (r.spot)
      std::cout << fmt::format("      spot           RMS radius {:.6f} mm about ({:.6f}, {:.6f}), "
                               "{} rays\n",
                               r.spot->rms_mm, r.spot->centroid.x, r.spot->centroid.y,
                               r.spot->rays);
    else
      std::cout << "      spot           no ray gets through\n";
  }
  return 0;
}

std::optional<int> runInfoIfNonCoaxial(const LensArgs& args, bool tilt_or_shift, bool as_json) {
  applyGlassOptions(args);
  optics::LensPrescription p = optics::readLensFile(args.lens_path);
  if (!p.noncoaxial_loc) {
    if (!args.fields.empty())
      throw Error("--field is for lenses with tilted or decentred surfaces; a coaxial lens's "
                  "fields are set by --film-diagonal");
    return std::nullopt;
  }
  if (tilt_or_shift)
    throw Error("--tilt and --shift need a coaxial lens; this one has tilted or decentred "
                "surfaces");
  return runInfoNonCoaxial(args, applyConfigurationArgs(args, std::move(p)), as_json);
}

}  // namespace lensim::cmd
