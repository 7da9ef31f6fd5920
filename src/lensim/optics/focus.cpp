#include "lensim/optics/focus.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

namespace lensim::optics {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kBundleRays = 256;
constexpr double kPupilOverfill = 1.25;

// A meridional fan of real rays emerging into a homogeneous medium; each ray stands for an
// equal-area ring of the pupil, so the RMS over the fan is the RMS over the pupil.
struct Fan {
  std::vector<double> x;      // height at z_ref
  std::vector<double> slope;  // dx/dz
  double z_ref = 0;
};

// Axial position where the fan's RMS spot radius is smallest (closed form: the spot at z is
// x + m (z - z_ref), whose mean square is quadratic in z).
std::optional<double> bestFocusZ(const Fan& fan) {
  double sxm = 0, smm = 0;
  for (size_t k = 0; k < fan.x.size(); ++k) {
    sxm += fan.x[k] * fan.slope[k];
    smm += fan.slope[k] * fan.slope[k];
  }
  if (fan.x.size() < 2 || smm < 1e-300) return std::nullopt;
  return fan.z_ref - sxm / smm;
}

double ringRadius(int k, double r_max) {
  return r_max * std::sqrt((k + 0.5) / kBundleRays);
}

// Fan from an axial object point (or from infinity) traced to the film side, heights at the
// rear vertex plane.
Fan sceneFan(const LensSystem& lens, const ParaxialData& p, std::optional<double> object_z_mm) {
  Fan fan;
  fan.z_ref = lens.rearVertexZ_mm();
  const double r_aim = kPupilOverfill * p.entrance_pupil_diameter_mm / 2;
  for (int k = 0; k < kBundleRays; ++k) {
    const double h = ringRadius(k, r_aim);
    Ray ray;
    if (!object_z_mm) {
      ray = {{h, 0, -1.0}, {0, 0, 1}};
    } else {
      const Vec3 from{0, 0, *object_z_mm};
      const Vec3 to{h, 0, p.entrance_pupil_z_mm};
      ray = {from, normalize(to - from)};
    }
    TraceResult r = lens.tracer().traceFromScene(ray);
    if (!r.ok() || !(r.ray.direction.z > 0)) continue;
    const double m = r.ray.direction.x / r.ray.direction.z;
    fan.x.push_back(r.ray.origin.x + m * (fan.z_ref - r.ray.origin.z));
    fan.slope.push_back(m);
  }
  return fan;
}

}  // namespace

FocusMethod parseFocusMethod(const std::string& name) {
  if (name == "thick") return FocusMethod::Thick;
  if (name == "exact") return FocusMethod::Exact;
  throw Error(fmt::format("unknown focus method '{}'; expected 'thick' or 'exact'", name));
}

const char* focusMethodName(FocusMethod m) {
  return m == FocusMethod::Thick ? "thick" : "exact";
}

double closestFocusDistance_m(const LensSystem& /*lens*/, const ParaxialData& p) {
  const double f = p.effective_focal_length_mm;
  const double hiatus = p.principal_plane_back_z_mm - p.principal_plane_front_z_mm;
  return (4 * f + hiatus) / 1000;
}

static double thickFilmDistance(const LensSystem& lens, const ParaxialData& p, double D_m) {
  const double f = p.effective_focal_length_mm;
  if (std::isinf(D_m)) return p.back_focal_point_z_mm - lens.rearVertexZ_mm();
  // D = s_o + hiatus + s_i with 1/s_o + 1/s_i = 1/f (distances from the principal planes):
  // s_i^2 - L s_i + L f = 0 with L = D - hiatus; the film takes the root nearer to f.
  const double hiatus = p.principal_plane_back_z_mm - p.principal_plane_front_z_mm;
  const double L = D_m * 1000 - hiatus;
  const double disc = L * L - 4 * L * f;
  if (!(L > 0) || disc < 0)
    throw Error(
        fmt::format("focus distance {} m is closer than this lens can focus; the closest "
                    "is {:.4f} m (from the film)",
                    D_m, closestFocusDistance_m(lens, p)));
  const double s_i = 0.5 * (L - std::sqrt(disc));
  return p.principal_plane_back_z_mm + s_i - lens.rearVertexZ_mm();
}

double axialRmsSpot_mm(const LensSystem& lens, const ParaxialData& p, double focus_distance_m) {
  std::optional<double> obj;
  if (!std::isinf(focus_distance_m)) obj = lens.filmZ_mm() - focus_distance_m * 1000;
  Fan fan = sceneFan(lens, p, obj);
  if (fan.x.empty()) return std::nan("");
  double s2 = 0;
  const double dz = lens.filmZ_mm() - fan.z_ref;
  for (size_t k = 0; k < fan.x.size(); ++k) {
    const double x = fan.x[k] + fan.slope[k] * dz;
    s2 += x * x;
  }
  return std::sqrt(s2 / fan.x.size());
}

double filmDistanceForFocus(const LensSystem& lens, const ParaxialData& p, double focus_distance_m,
                            FocusMethod method) {
  if (!(focus_distance_m > 0))
    throw Error(fmt::format("focus distance {} m must be > 0", focus_distance_m));
  if (!std::isinf(focus_distance_m) && focus_distance_m < closestFocusDistance_m(lens, p))
    throw Error(
        fmt::format("focus distance {} m is closer than this lens can focus; the closest "
                    "is {:.4f} m (from the film)",
                    focus_distance_m, closestFocusDistance_m(lens, p)));
  double s = thickFilmDistance(lens, p, focus_distance_m);
  if (method == FocusMethod::Thick) {
    if (!(s > 0))
      throw Error(
          fmt::format("focusing at {} m puts the film {:.3f} mm in front of the rear "
                      "vertex, inside the lens",
                      focus_distance_m, s));
    return s;
  }

  // Exact: the object sits at z_film - D, so moving the film moves the object too; iterate the
  // closed-form best plane (the image moves by m^2 per unit object motion, a contraction).
  for (int iter = 0; iter < 50; ++iter) {
    std::optional<double> obj;
    if (!std::isinf(focus_distance_m)) obj = lens.rearVertexZ_mm() + s - focus_distance_m * 1000;
    if (obj && *obj >= 0)
      throw Error(fmt::format("focus distance {} m puts the object behind the front vertex",
                              focus_distance_m));
    Fan fan = sceneFan(lens, p, obj);
    std::optional<double> z = bestFocusZ(fan);
    if (!z)
      throw Error(fmt::format("no ray of the on-axis bundle from {} m gets through the lens",
                              focus_distance_m));
    const double s_new = *z - lens.rearVertexZ_mm();
    const bool done = std::abs(s_new - s) < 1e-10 * std::max(1.0, std::abs(s));
    s = s_new;
    if (done || std::isinf(focus_distance_m)) break;
  }
  if (!(s > 0))
    throw Error(
        fmt::format("focusing at {} m puts the film {:.3f} mm in front of the rear vertex, "
                    "inside the lens",
                    focus_distance_m, s));
  return s;
}

double focusDistanceForFilm(const LensSystem& lens, const ParaxialData& p, double film_distance_mm,
                            FocusMethod method) {
  if (!(film_distance_mm > 0))
    throw Error(fmt::format("film distance {} mm must be > 0", film_distance_mm));
  const double z_film = lens.rearVertexZ_mm() + film_distance_mm;
  double z_obj;
  if (method == FocusMethod::Thick) {
    const double f = p.effective_focal_length_mm;
    const double s_i = z_film - p.principal_plane_back_z_mm;
    if (s_i <= f) return kInf;
    const double s_o = 1 / (1 / f - 1 / s_i);
    z_obj = p.principal_plane_front_z_mm - s_o;
  } else {
    // Fan from the axial film point across the exit pupil, traced to the scene; the object in
    // focus is where the emerging rays converge best (closed form, as for the film side).
    Fan fan;
    fan.z_ref = 0;
    const double r_aim = kPupilOverfill * p.exit_pupil_diameter_mm / 2;
    for (int k = 0; k < kBundleRays; ++k) {
      const Vec3 from{0, 0, z_film};
      const Vec3 to{ringRadius(k, r_aim), 0, p.exit_pupil_z_mm};
      if (!(to.z < from.z)) break;
      TraceResult r = lens.tracer().traceFromFilm(Ray{from, normalize(to - from)});
      if (!r.ok() || !(r.ray.direction.z < 0)) continue;
      const double m = r.ray.direction.x / r.ray.direction.z;
      fan.x.push_back(r.ray.origin.x + m * (fan.z_ref - r.ray.origin.z));
      fan.slope.push_back(m);
    }
    std::optional<double> z = bestFocusZ(fan);
    if (!z) {
      if (fan.x.size() < 2)
        throw Error(fmt::format("no ray from the film centre at {} mm gets through the lens",
                                film_distance_mm));
      return kInf;  // parallel bundle
    }
    if (*z >= 0) return kInf;  // rays diverge toward the scene: focused beyond infinity
    z_obj = *z;
  }
  return (z_film - z_obj) / 1000;
}

}  // namespace lensim::optics

namespace lensim::optics {

std::vector<Diagnostic> FocusedLens::allDiagnostics() const {
  std::vector<Diagnostic> all = lens->prescription().diagnostics;
  all.insert(all.end(), lens->diagnostics().begin(), lens->diagnostics().end());
  return all;
}

FocusedLens focusLens(LensPrescription prescription, const LensSetup& setup) {
  if (setup.focus_distance_m && setup.film_distance_mm)
    throw Error("give a focus distance or a film distance, not both");
  LensSystemOptions opts;
  opts.aperture_diameter_mm = setup.aperture_diameter_mm;
  FocusedLens fl;
  if ((!prescription.focus_group.empty() || prescription.floating_focus) &&
      setup.focus_distance_m && std::isfinite(*setup.focus_distance_m)) {
    GroupFocus g = prescription.floating_focus
                       ? focusByFloatingFocus(prescription, setup, *setup.focus_distance_m)
                       : focusByGroup(prescription, setup, *setup.focus_distance_m);
    fl.lens = std::make_unique<LensSystem>(std::move(g.prescription), opts);
    fl.paraxial = computeParaxial(*fl.lens);
    fl.lens->setFilmDistance_mm(g.film_distance_mm);
    fl.focus_distance_m = *setup.focus_distance_m;
    return fl;
  }
  fl.lens = std::make_unique<LensSystem>(std::move(prescription), opts);
  fl.paraxial = computeParaxial(*fl.lens);
  LensSystem& lens = *fl.lens;
  if (setup.film_distance_mm) {
    lens.setFilmDistance_mm(*setup.film_distance_mm);
  } else if (!setup.focus_distance_m && lens.prescription().fileFilmDistance_mm() > 0) {
    lens.setFilmDistance_mm(lens.prescription().fileFilmDistance_mm());
  } else {
    const double D = setup.focus_distance_m ? *setup.focus_distance_m : kInf;
    lens.setFilmDistance_mm(filmDistanceForFocus(lens, fl.paraxial, D, setup.focus_method));
    fl.focus_distance_m = D;
    return fl;
  }
  fl.focus_distance_m =
      focusDistanceForFilm(lens, fl.paraxial, lens.filmDistance_mm(), setup.focus_method);
  return fl;
}

}  // namespace lensim::optics
