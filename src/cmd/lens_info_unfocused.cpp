#include "lens_info_unfocused.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/lens_report.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

using namespace lensim::optics;
using nlohmann::json;

// The surface and element tables of `lens info`, and the shapes of the non-spherical surfaces.
void printSurfaceTables(const LensSystem& lens) {
  const auto& pr = lens.prescription();
  std::cout << fmt::format("\n  {:>3} {:>5} {:>12} {:>11} {:>8} {:>10} {:>11}\n", "#", "line",
                           "radius", "thickness", "index", "aperture", "z");
  for (int i = 0; i < lens.surfaceCount(); ++i) {
    const Interface& s = lens.interfaces()[i];
    const double t =
        i + 1 < lens.surfaceCount() ? pr.surfaces[i].thickness_mm : lens.filmDistance_mm();
    // A plane stop shows as "stop"; a curved stop (a mirror) keeps its radius, marked below.
    std::cout << fmt::format(
        "  {:>3} {:>5} {:>12} {:>11.4f} {:>8.4f} {:>10.4f} {:>11.4f}{}{}{}\n", i,
        pr.surfaces[i].loc.line,
        s.is_stop && s.radius_mm == 0 ? std::string("stop") : fmt::format("{:.4f}", s.radius_mm), t,
        s.ior_after, 2 * s.semi_aperture_mm, s.z_mm, s.is_mirror ? "  mirror" : "",
        s.is_stop && s.radius_mm != 0 ? "  stop" : "",
        s.obscuration_radius_mm > 0 ? fmt::format("  obscured r < {:.4f}", s.obscuration_radius_mm)
                                    : std::string());
  }
  if (lens.mirrorCount() > 0)
    std::cout << fmt::format(
        "  {} mirror{}: thicknesses are signed z distances (negative after an odd number of "
        "mirrors){}\n",
        lens.mirrorCount(), lens.mirrorCount() == 1 ? "" : "s",
        lens.imageSpaceReversed()
            ? fmt::format("; the image lies toward -z, at z = {:.4f} mm (image-side z above are "
                          "unfolded about the rear vertex plane)",
                          lens.realFilmZ_mm())
            : "");
  // Per element: the glass, n_d, V_d and the index at the analysis wavelength.
  std::cout << fmt::format("\n  {:>8} {:>5}  {:<28} {:>9} {:>8} {:>10}\n", "element", "line",
                           "glass", "n_d", "V_d", fmt::format("n({:.0f})", lens.wavelength_nm()));
  for (int i = 0; i + 1 < lens.surfaceCount(); ++i) {
    const Glass& g = lens.glasses()[i];
    if (g.isAir()) continue;
    std::cout << fmt::format("  {:>8} {:>5}  {:<28} {:>9.6f} {:>8} {:>10.6f}\n",
                             fmt::format("{}-{}", i, i + 1), pr.surfaces[i].loc.line, g.describe(),
                             g.n_d(), std::isfinite(g.v_d()) ? fmt::format("{:.3f}", g.v_d()) : "-",
                             lens.interfaces()[i].ior_after);
  }
  for (int i = 0; i < lens.surfaceCount(); ++i) {
    const SurfaceShape& sh = lens.interfaces()[i].shape;
    if (sh.isSpherical()) continue;
    std::string d = fmt::format("  surface {}: ", i);
    if (sh.radius_x_mm) d += fmt::format("x-section radius {:.4f} mm, ", *sh.radius_x_mm);
    if (sh.rotation_radius_mm)
      d += *sh.rotation_radius_mm != 0
               ? fmt::format("toroidal, radius of rotation {:.4f} mm, ", *sh.rotation_radius_mm)
               : std::string("toroidal, radius of rotation infinite (cylinder), ");
    d += fmt::format("conic {:.6g}", sh.conic);
    for (size_t k = 1; k < sh.poly.size(); ++k)
      if (sh.poly[k] != 0)
        d += fmt::format(", {}^{} {:.6g}", sh.isToroidal() ? "y" : "r", k, sh.poly[k]);
    std::cout << d << "\n";
  }
}

// `lens info` for a lens that was read but cannot be set up (afocal, no real ray gets through,
// a film that would sit inside the lens): the reason as a warning and the data that exist
// (first-order data where the lens has power, the surface that stops the axial ray, the
// surfaces and glasses); exit status 0. `render` refuses such a camera.
int runInfoUnfocused(const LensArgs& args, bool as_json, const Error& why) {
  LensSystemOptions opts;
  opts.aperture_diameter_mm = args.aperture_diameter_mm;
  LensSystem lens(applyConfigurationArgs(args, readLensFile(args.lens_path)), opts);
  const auto& pr = lens.prescription();
  logDiagnostics(pr.diagnostics);
  logDiagnostics(lens.diagnostics());
  std::vector<Diagnostic> warnings{
      {Severity::Warning, why.loc().valid() ? why.loc() : FileLoc{args.lens_path},
       why.message() + "; lens info shows the data that exist (render refuses this lens)"}};
  std::optional<ParaxialData> p;
  std::optional<double> angular_magnification;
  try {
    p = computeParaxial(lens);
  } catch (const Error&) {
    try {
      p = computeParaxial(lens, false);  // no real ray gets through: first order only
    } catch (const Error&) {
      // Afocal: u' = (n / n') D u for the system matrix [A B; 0 D].
      const RayMatrix m = systemMatrix(lens, 0, lens.surfaceCount() - 1);
      angular_magnification = m.d * lens.objectIor() / lens.imageIor();
    }
  }
  // The ray along the axis (a hair off it), from infinity: where it is stopped, if it is.
  std::optional<TraceResult> axial;
  {
    const double h = 1e-6 * std::max(1e-3, lens.interfaces()[0].semi_aperture_mm);
    TraceResult r = lens.tracer().traceFromScene(Ray{{h, 0, -1}, {0, 0, 1}});
    if (!r.ok()) axial = r;
  }
  if (axial)
    warnings.push_back({Severity::Warning,
                        pr.surfaces[axial->blocked_surface].loc.valid()
                            ? pr.surfaces[axial->blocked_surface].loc
                            : FileLoc{args.lens_path},
                        fmt::format("the ray along the axis is stopped at surface {} ({})",
                                    axial->blocked_surface, blockReasonName(axial->reason))});
  for (const Diagnostic& d : warnings) logDiagnostic(d);

  if (as_json) {
    json j;
    j["lens"] = {{"path", pr.path},
                 {"name", pr.name},
                 {"layout", layoutName(pr.layout)},
                 {"format", pr.format},
                 {"surface_count", lens.surfaceCount()}};
    j["focused"] = false;
    j["not_focused_reason"] = why.message();
    j["afocal"] = angular_magnification.has_value();
    if (angular_magnification) j["angular_magnification"] = *angular_magnification;
    if (p) {
      j["effective_focal_length_mm"] = p->effective_focal_length_mm;
      j["back_focal_length_mm"] = p->back_focal_length_mm;
      j["front_focal_length_mm"] = p->front_focal_length_mm;
      j["principal_plane_front_z_mm"] = p->principal_plane_front_z_mm;
      j["principal_plane_back_z_mm"] = p->principal_plane_back_z_mm;
      j["aperture_stop_surface"] = p->aperture_stop_surface;
      j["entrance_pupil_diameter_mm"] = p->entrance_pupil_diameter_mm;
      j["entrance_pupil_z_mm"] = p->entrance_pupil_z_mm;
      j["exit_pupil_diameter_mm"] = p->exit_pupil_diameter_mm;
      j["exit_pupil_z_mm"] = p->exit_pupil_z_mm;
      j["f_number"] = p->f_number;
      j["paraxial_f_number"] = p->f_number;
      j["paraxial_limit_surface"] = p->paraxial_limit_surface;
      j["paraxial_limit_f_number"] = p->paraxial_limit_f_number;
      if (p->real_limit_surface >= 0) {
        j["real_f_number"] = p->real_f_number;
        j["real_image_space_f_number"] = p->real_image_space_f_number;
        j["real_limit_surface"] = p->real_limit_surface;
      }
    }
    if (axial) {
      j["axial_ray_blocked_at_surface"] = axial->blocked_surface;
      j["axial_ray_blocked_reason"] = blockReasonName(axial->reason);
    }
    j["lens_length_mm"] = lensLength(lens);
    j["surfaces"] = surfacesJson(lens);
    j["wavelength_nm"] = lens.wavelength_nm();
    j["elements"] = elementsJson(lens);
    json diags = json::array();
    for (const Diagnostic& d : pr.diagnostics) diags.push_back(d.str());
    for (const Diagnostic& d : lens.diagnostics()) diags.push_back(d.str());
    for (const Diagnostic& d : warnings) diags.push_back(d.str());
    j["diagnostics"] = diags;
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  auto line = [](const std::string& k, const std::string& v) {
    std::cout << fmt::format("  {:<26}{}\n", k, v);
  };
  std::cout << fmt::format("{}\n", pr.name);
  line("file", fmt::format("{} ({}, {} surfaces)", pr.path, pr.format, lens.surfaceCount()));
  line("not focused", why.message());
  if (angular_magnification)
    line("afocal",
         fmt::format("no optical power; angular magnification {:.6f}", *angular_magnification));
  if (p) {
    line("effective focal length", fmt::format("{:.4f} mm", p->effective_focal_length_mm));
    line("back focal length", fmt::format("{:.4f} mm (rear focal point z = {:.4f})",
                                          p->back_focal_length_mm, p->back_focal_point_z_mm));
    line("front focal length", fmt::format("{:.4f} mm (front focal point z = {:.4f})",
                                           p->front_focal_length_mm, p->front_focal_point_z_mm));
    line("principal planes z",
         fmt::format("front {:.4f}, back {:.4f} mm", p->principal_plane_front_z_mm,
                     p->principal_plane_back_z_mm));
    line("aperture stop",
         fmt::format("surface {} (line {}), diameter {:.3f} mm", p->aperture_stop_surface,
                     pr.surfaces[p->aperture_stop_surface].loc.line, p->aperture_stop_diameter_mm));
    line("f-number", fmt::format("f/{:.3f} paraxial (infinity)", p->f_number));
    if (p->real_limit_surface >= 0)
      line("real f-number", fmt::format("f/{:.3f} (stopped by surface {})", p->real_f_number,
                                        p->real_limit_surface));
  }
  if (axial)
    line("axial ray",
         fmt::format("stopped at surface {} (line {}): {}", axial->blocked_surface,
                     pr.surfaces[axial->blocked_surface].loc.line, blockReasonName(axial->reason)));
  printSurfaceTables(lens);
  return 0;
}

}  // namespace lensim::cmd
