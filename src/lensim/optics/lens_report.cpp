#include "lensim/optics/lens_report.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/prescription.h"

namespace lensim::optics {

using nlohmann::json;

double lensLength(const LensSystem& lens) {
  if (lens.mirrorCount() == 0) return lens.rearVertexZ_mm();
  double lo = 0, hi = 0;
  for (const Interface& s : lens.interfaces()) lo = std::min(lo, s.z_mm), hi = std::max(hi, s.z_mm);
  return hi - lo;
}

double totalTrack(const LensSystem& lens) {
  if (lens.mirrorCount() == 0) return lens.filmZ_mm();
  double lo = lens.realFilmZ_mm(), hi = lo;
  for (const Interface& s : lens.interfaces()) lo = std::min(lo, s.z_mm), hi = std::max(hi, s.z_mm);
  return hi - lo;
}

json surfacesJson(const LensSystem& lens) {
  json arr = json::array();
  const auto& rows = lens.prescription().surfaces;
  for (int i = 0; i < lens.surfaceCount(); ++i) {
    const Interface& s = lens.interfaces()[i];
    arr.push_back({{"index", i},
                   {"line", rows[i].loc.line},
                   {"radius_mm", s.radius_mm},
                   {"thickness_mm",
                    i + 1 < lens.surfaceCount() ? rows[i].thickness_mm : lens.filmDistance_mm()},
                   {"ior", s.ior_after},
                   {"aperture_diameter_mm", 2 * s.semi_aperture_mm},
                   {"z_mm", s.z_mm},
                   {"is_stop", s.is_stop}});
    if (s.is_mirror) arr.back()["mirror"] = true;
    if (s.obscuration_radius_mm > 0) arr.back()["obscuration_radius_mm"] = s.obscuration_radius_mm;
    if (!s.shape.isSpherical()) {
      json& e = arr.back();
      e["conic"] = s.shape.conic;
      if (s.shape.hasPolynomial()) {
        json a = json::object();
        for (size_t k = 1; k < s.shape.poly.size(); ++k)
          if (s.shape.poly[k] != 0) a[std::to_string(k)] = s.shape.poly[k];
        e["aspheric"] = a;
      }
      if (s.shape.radius_x_mm) e["radius_x_mm"] = *s.shape.radius_x_mm;
      if (s.shape.rotation_radius_mm) e["rotation_radius_mm"] = *s.shape.rotation_radius_mm;
    }
  }
  return arr;
}

json elementsJson(const LensSystem& lens) {
  json arr = json::array();
  const auto& rows = lens.prescription().surfaces;
  for (int i = 0; i + 1 < lens.surfaceCount(); ++i) {
    const Glass& g = lens.glasses()[i];
    if (g.isAir()) continue;
    arr.push_back({{"front_surface", i},
                   {"back_surface", i + 1},
                   {"line", rows[i].loc.line},
                   {"glass", g.describe()},
                   {"kind", g.kind()},
                   {"n_d", g.n_d()},
                   {"v_d", std::isfinite(g.v_d()) ? json(g.v_d()) : json(nullptr)},
                   {"n", lens.interfaces()[i].ior_after}});
  }
  return arr;
}

json diagnosticsJson(const FocusedLens& fl) {
  json arr = json::array();
  for (const Diagnostic& d : fl.allDiagnostics()) arr.push_back(d.str());
  return arr;
}

json firstOrderJson(const FocusedLens& fl, double film_diagonal_mm) {
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  const auto& pr = lens.prescription();
  const bool at_inf = std::isinf(fl.focus_distance_m);
  std::optional<double> object_z;
  if (!at_inf) object_z = lens.filmZ_mm() - fl.focus_distance_m * 1000;
  const FieldOfView fov = fieldOfView(lens, p, film_diagonal_mm);
  json j;
  j["lens"] = {
      {"name", pr.name}, {"layout", layoutName(pr.layout)}, {"surface_count", lens.surfaceCount()}};
  if (pr.nominal_focal_length_mm)
    j["lens"]["nominal_focal_length_mm"] = *pr.nominal_focal_length_mm;
  j["effective_focal_length_mm"] = p.effective_focal_length_mm;
  j["back_focal_length_mm"] = p.back_focal_length_mm;
  j["front_focal_length_mm"] = p.front_focal_length_mm;
  j["aperture_stop_surface"] = p.aperture_stop_surface;
  j["aperture_stop_diameter_mm"] = p.aperture_stop_diameter_mm;
  j["entrance_pupil_diameter_mm"] = p.entrance_pupil_diameter_mm;
  j["entrance_pupil_z_mm"] = p.entrance_pupil_z_mm;
  j["exit_pupil_diameter_mm"] = p.exit_pupil_diameter_mm;
  j["exit_pupil_z_mm"] = p.exit_pupil_z_mm;
  j["f_number"] = p.f_number;
  j["working_f_number"] = workingFNumber(lens, p, object_z);
  j["lens_length_mm"] = lensLength(lens);
  j["total_track_mm"] = totalTrack(lens);
  j["film_distance_mm"] = lens.filmDistance_mm();
  j["focus_distance_m"] = at_inf ? json(nullptr) : json(fl.focus_distance_m);
  j["focus_at_infinity"] = at_inf;
  j["closest_focus_distance_m"] = closestFocusDistance_m(lens, p);
  j["film_diagonal_mm"] = film_diagonal_mm;
  j["field_of_view_deg"] = fov.real_deg ? json(*fov.real_deg) : json(nullptr);
  j["paraxial_field_of_view_deg"] = fov.paraxial_deg;
  if (fov.image_circle_diameter_mm) j["image_circle_diameter_mm"] = *fov.image_circle_diameter_mm;
  j["diagnostics"] = diagnosticsJson(fl);
  return j;
}

namespace {

json vec(const Vec3& v) {
  return json::array({v.x, v.y, v.z});
}

}  // namespace

json tiltShiftJson(const FocusedLens& fl, const TiltShift& ts, double film_diagonal_mm) {
  json j;
  j["tilt_deg"] = json::array({ts.tilt_deg.x, ts.tilt_deg.y});
  j["shift_mm"] = json::array({ts.shift_mm.x, ts.shift_mm.y});
  j["film_reach_from_axis_mm"] = film_diagonal_mm / 2 + std::hypot(ts.shift_mm.x, ts.shift_mm.y);
  if (!ts.tilted()) return j;
  const FilmPlacement placement(ts, fl.lens->filmZ_mm());
  const ScheimpflugData s = scheimpflug(fl.paraxial, placement);
  j["tilt_angle_deg"] = s.tilt_deg;
  j["hinge_distance_mm"] = s.hinge_distance_mm;
  j["hinge_point_mm"] = vec(s.hinge_point_mm);
  j["hinge_direction"] = vec(s.hinge_direction);
  j["scheimpflug_point_mm"] = vec(s.scheimpflug_point_mm);
  j["focus_plane_normal"] = vec(s.focus_plane_normal);
  j["focus_plane_axis_z_mm"] =
      std::isfinite(s.focus_plane_axis_z_mm) ? json(s.focus_plane_axis_z_mm) : json(nullptr);
  j["focus_plane_object_distance_mm"] =
      std::isfinite(s.object_distance_mm) ? json(s.object_distance_mm) : json(nullptr);
  j["focus_plane_to_film_deg"] = s.focus_plane_to_film_deg;
  j["focus_plane_to_lens_plane_deg"] = s.focus_plane_to_lens_plane_deg;
  j["image_distance_mm"] = s.image_distance_mm;
  return j;
}

}  // namespace lensim::optics
