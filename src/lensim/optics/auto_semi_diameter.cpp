#include "lensim/optics/auto_semi_diameter.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/surface_shape.h"

namespace lensim::optics {

namespace {

// Points around the pupil's edge (besides its centre, the chief ray).
constexpr int kPupilEdgePoints = 64;
// Bounds on the work (OpticStudio's own limits are 200 fields and 24 wavelengths).
constexpr size_t kMaxFields = 200, kMaxWavelengths = 64;

// The paraxial entrance pupil: its z (lens space) and the stop's height per unit height at the
// entrance pupil (the pupil magnification's inverse), from the stop's position alone.
struct PupilPlane {
  double z_mm = 0;
  double stop_per_pupil = 1;
};

PupilPlane paraxialEntrancePupil(const LensSystem& sys, int stop) {
  if (stop == 0) return {};
  const auto& in = sys.interfaces();
  // (y, n u) from the front vertex plane to just after surface stop - 1, then to the stop.
  const RayMatrix m = systemMatrix(sys, 0, stop - 1);
  const double t = (in[size_t(stop)].z_mm - in[size_t(stop - 1)].z_mm) / in[size_t(stop)].nBefore();
  const double a = m.a + t * m.c, b = m.b + t * m.d;
  if (a == 0)
    throw Error(sys.prescription().surfaces[size_t(stop)].loc,
                "automatic semi-diameters: the stop is imaged to infinity in object space (no "
                "entrance pupil to aim rays at)");
  // The ray through the stop's centre: y0 a + w0 b = 0; it crosses the axis at z = -y0 / w0.
  return {b / a, a};
}

/// What the rays of every field and wavelength share: the lens, the entrance pupil they aim at
/// and the plane they start from.
struct RaySetup {
  const LensPrescription& p;
  const AutoSemiDiameterSpec& spec;
  PupilPlane ep;
  int stop;
  double rp;         ///< the entrance pupil's radius (mm)
  double stop_semi;  ///< the stop's semi-diameter (mm)
  double z_launch;   ///< the plane in front of the lens where rays from infinity start
  bool finite;       ///< the object is at a finite distance
  std::vector<bool> computed;  ///< per surface: its semi-diameter is being computed
};

/// Why no ray fills the stop when the entrance pupil is the stop's paraxial image (FLOA): the
/// highest point of the stop that real rays from the axial object point reach, scanning the
/// entrance pupil's plane from the axis out to its paraxial radius until a ray fails. Empty when
/// the pupil is given (ENPD, FNUM) or some ray reaches the stop's rim (the failure has another
/// cause then).
std::string unfilledStopReason(const RaySetup& c, const LensSystem& sys, double lambda) {
  if (c.spec.entrance_pupil_diameter_mm > 0) return {};
  constexpr int kSteps = 4000;
  const TraceOptions unclipped{false, false};
  std::vector<Vec3> path;
  double highest = 0, highest_at = 0;
  std::optional<double> fails_at;
  bool falling = false;
  for (int i = 1; i <= kSteps; ++i) {
    const double v = c.rp * i / kSteps;
    const Vec3 pupil{0, v, c.ep.z_mm};
    Ray ray;
    if (c.finite) {
      ray.origin = {0, 0, -*c.p.object_distance_mm};
      ray.direction = normalize(pupil - ray.origin);
    } else {
      ray.direction = {0, 0, 1};
      ray.origin = {0, v, c.z_launch};
    }
    path.clear();
    const TraceResult r = sys.tracer().traceFromScene(ray, unclipped, &path);
    const size_t at = size_t(c.stop) + 1;
    if (path.size() <= at || !(r.ok() || r.blocked_surface > c.stop) ||
        !std::isfinite(path[at].y)) {
      fails_at = v;
      break;
    }
    // Only the rays whose stop height still grows with their pupil height: past the first
    // maximum the height falls (and may cross the axis), so ray aiming continued outward from
    // the axis cannot get beyond it.
    const double h = std::hypot(path[at].x, path[at].y);
    if (!falling && h >= highest)
      highest = h, highest_at = v;
    else
      falling = true;
  }
  if (highest >= c.stop_semi) return {};
  return fmt::format(
      "; the system aperture is the stop's size (FLOA): its semi-diameter {:.6g} mm images to a "
      "paraxial entrance pupil of radius {:.6g} mm, but real rays {} at {:.6g} nm, traced "
      "outward from the axis, meet the stop at most {:.6g} mm from its centre (through the "
      "entrance pupil's plane {:.6g} mm off the axis){}{}: no ray aimed at the paraxial pupil or "
      "at the stop (RAIM) fills it; give the stop a DIAM of at most {:.6g} mm, or the file an "
      "ENPD or FNUM",
      c.stop_semi, c.rp, c.finite ? "from the axial object point" : "parallel to the axis", lambda,
      highest, highest_at, falling ? ", their stop height falling beyond (aberration)" : "",
      fails_at ? fmt::format(", and from {:.6g} mm off the axis they miss a surface or are "
                             "totally reflected",
                             *fails_at)
               : std::string(),
      highest);
}

/// Traces the chief ray and the pupil's edge of field f (number f + 1 in messages) at the
/// wavelength of sys (lambda nm), aimed at the stop when asked, and widens semi[i] to the
/// heights at which they cross surfaces[i].
void widenForField(const RaySetup& c, const LensSystem& sys, double lambda, size_t f,
                   const std::pair<double, double>& field, const std::vector<int>& surfaces,
                   std::vector<double>& semi) {
  // The names the ray constructions below use.
  const LensPrescription& p = c.p;
  const AutoSemiDiameterSpec& spec = c.spec;
  const PupilPlane& ep = c.ep;
  const int stop = c.stop;
  const double rp = c.rp, stop_semi = c.stop_semi, z_launch = c.z_launch;
  const bool finite = c.finite;
  const std::vector<bool>& computed = c.computed;
  const TraceOptions unclipped{false, false};
  std::vector<Vec3> path;
  const auto [fx, fy] = field;
  // The ray through the point (u, v) of the entrance pupil's plane.
  double field_scale = 1;  // < 1 while continuing from the axis (ray aiming)
  auto rayThrough = [&](double u, double v) {
    const double ax = field_scale * field.first, ay = field_scale * field.second;
    const Vec3 pupil{u, v, ep.z_mm};
    Ray ray;
    if (spec.object_heights || finite) {
      Vec3 obj{ax, ay, -*p.object_distance_mm};
      if (!spec.object_heights) {
        // A field angle from a finite object: the chief ray's slope through the pupil centre.
        const double tx = std::tan(ax * std::numbers::pi / 180);
        const double ty = std::tan(ay * std::numbers::pi / 180);
        obj = {(obj.z - ep.z_mm) * tx, (obj.z - ep.z_mm) * ty, obj.z};
      }
      ray.origin = obj;
      ray.direction = normalize(pupil - obj);
    } else {
      const Vec3 d = normalize(Vec3{std::tan(ax * std::numbers::pi / 180),
                                    std::tan(ay * std::numbers::pi / 180), 1.0});
      ray.direction = d;
      ray.origin = pupil + d * ((z_launch - ep.z_mm) / d.z);
    }
    return ray;
  };
  // Where the ray through (u, v) meets the stop's plane, if it gets there.
  auto stopHit = [&](double u, double v, Vec2& at) {
    path.clear();
    const TraceResult r = sys.tracer().traceFromScene(rayThrough(u, v), unclipped, &path);
    if (path.size() <= size_t(stop) + 1) return false;
    at = {path[size_t(stop) + 1].x, path[size_t(stop) + 1].y};
    return std::isfinite(at.x) && std::isfinite(at.y) && (r.ok() || r.blocked_surface > stop);
  };
  Vec2 guess{0, 0};  // the last aim (the chief ray's for the pupil's edge)
  for (int k = -1; k < kPupilEdgePoints; ++k) {
    const double phi = 2 * std::numbers::pi * k / kPupilEdgePoints;
    const Vec2 pupil{k < 0 ? 0.0 : rp * std::cos(phi), k < 0 ? 0.0 : rp * std::sin(phi)};
    Vec2 aim = pupil;
    if (spec.aim_at_stop) {
      // Real ray aiming: the point of the pupil's plane whose ray meets the stop at the
      // pupil point scaled to the stop (Newton's method, differences for the Jacobian),
      // continued from the axis (the chief ray, by field: 32 steps) or from the chief ray
      // (by pupil radius: 4 steps).
      const int steps = k < 0 ? 32 : 4;
      Vec2 target{}, start = k < 0 ? Vec2{0, 0} : guess;
      bool converged = false;
      for (int step = 1; step <= steps; ++step) {
        const double t = double(step) / steps;
        field_scale = k < 0 ? t : 1.0;
        target = pupil * (stop_semi / rp) * (k < 0 ? 1.0 : t);
        aim = start + (k < 0 ? Vec2{0, 0} : pupil * (1.0 / steps));
        converged = false;
        for (int it = 0; it < 30 && !converged; ++it) {
          Vec2 h0, hu, hv;
          const double e = 1e-6 * rp;
          if (!stopHit(aim.x, aim.y, h0) || !stopHit(aim.x + e, aim.y, hu) ||
              !stopHit(aim.x, aim.y + e, hv))
            break;
          const Vec2 r = h0 - target;
          if (std::hypot(r.x, r.y) <= 1e-10 * (stop_semi + 1)) {
            converged = true;
            break;
          }
          const double a = (hu.x - h0.x) / e, b = (hv.x - h0.x) / e;
          const double c = (hu.y - h0.y) / e, d = (hv.y - h0.y) / e;
          const double det = a * d - b * c;
          if (!(std::abs(det) > 0)) break;
          aim = aim - Vec2{(d * r.x - b * r.y) / det, (a * r.y - c * r.x) / det};
        }
        if (!converged) break;
        start = aim;
      }
      field_scale = 1;
      if (!converged)
        throw Error(spec.fields_loc,
                    fmt::format("automatic semi-diameters with ray aiming: no real ray of "
                                "field {} ({}, {}) at {:.6g} nm meets the stop at ({:.6g}, "
                                "{:.6g}) mm{}",
                                f + 1, fx, fy, lambda, target.x, target.y,
                                k < 0 ? std::string() : unfilledStopReason(c, sys, lambda)));
      if (k < 0) guess = aim;
    }
    path.clear();
    const TraceResult r =
        sys.tracer().traceFromScene(rayThrough(aim.x, aim.y), unclipped, &path);
    // Where the ray is stopped by an aperture the file gives (the stop aside: rays aimed at
    // the paraxial pupil may pass its rim, as in OpticStudio), it counts no further.
    size_t reach = path.size() - 1;  // surfaces [0, reach) were met
    for (size_t j = 0; j < reach; ++j) {
      const Interface& in = sys.interfaces()[j];
      if (computed[j] || in.is_stop) continue;
      if (std::hypot(path[j + 1].x, path[j + 1].y) > in.semi_aperture_mm) {
        reach = j;
        break;
      }
    }
    if (!r.ok() && r.blocked_surface >= 0 && size_t(r.blocked_surface) <= reach) {
      const LensSurface& s = p.surfaces[size_t(r.blocked_surface)];
      throw Error(s.loc, fmt::format("automatic semi-diameters: the {} ray of field {} ({}, {}) at "
                                     "{:.6g} nm {} this surface before any aperture the file gives "
                                     "stops it{}",
                                     k < 0 ? "chief" : "pupil-edge", f + 1, fx, fy, lambda,
                                     r.reason == BlockReason::TotalInternalReflection
                                         ? "is totally reflected at"
                                         : "misses",
                                     k < 0 ? std::string() : unfilledStopReason(c, sys, lambda)));
    }
    for (size_t i = 0; i < surfaces.size(); ++i)
      if (size_t(surfaces[i]) < reach)
        semi[i] = std::max(semi[i], std::hypot(path[size_t(surfaces[i]) + 1].x,
                                               path[size_t(surfaces[i]) + 1].y));
  }
}

}  // namespace

std::vector<double> computeAutoSemiDiameters(const LensPrescription& p,
                                             const std::vector<int>& surfaces,
                                             const AutoSemiDiameterSpec& spec) {
  std::vector<double> semi(surfaces.size(), 0.0);
  if (surfaces.empty()) return semi;
  const LensSystem base(p);
  const auto stop = base.stopIndex();
  if (!stop) throw Error(p.surfaces.front().loc, "automatic semi-diameters need an aperture stop");
  const PupilPlane ep = paraxialEntrancePupil(base, *stop);
  // The entrance pupil's radius: given, else the stop's image (FLOA: the stop's size).
  const double rp =
      spec.entrance_pupil_diameter_mm > 0
          ? spec.entrance_pupil_diameter_mm / 2
          : base.interfaces()[size_t(*stop)].semi_aperture_mm / std::abs(ep.stop_per_pupil);
  if (!(rp > 0) || !std::isfinite(rp))
    throw Error(spec.fields_loc, fmt::format("automatic semi-diameters: entrance pupil radius "
                                             "{} mm must be > 0 and finite",
                                             rp));
  const double stop_semi = base.interfaces()[size_t(*stop)].semi_aperture_mm;
  const bool finite = p.object_distance_mm.has_value();
  if (spec.object_heights && !finite)
    throw Error(spec.fields_loc,
                "automatic semi-diameters: object-height fields need a finite "
                "object distance (the object surface's DISZ)");
  std::vector<double> waves = p.wavelengths_nm;  // each distinct one once
  std::sort(waves.begin(), waves.end());
  waves.erase(std::unique(waves.begin(), waves.end()), waves.end());
  if (waves.empty()) waves.push_back(base.wavelength_nm());
  if (waves.size() > kMaxWavelengths || spec.fields.size() > kMaxFields)
    throw Error(spec.fields_loc,
                fmt::format("automatic semi-diameters: {} fields and {} wavelengths; at most {} "
                            "and {} are traced",
                            spec.fields.size(), waves.size(), kMaxFields, kMaxWavelengths));
  std::vector<std::pair<double, double>> fields = spec.fields;
  if (fields.empty()) fields.push_back({0.0, 0.0});

  // Launch planes: well in front of the lens (and of the entrance pupil).
  double track = 0;
  for (const LensSurface& s : p.surfaces) track += std::abs(s.thickness_mm);
  const double z_launch = std::min(ep.z_mm, 0.0) - track - 10 * rp - 1;

  RaySetup setup{p, spec, ep, *stop, rp, stop_semi, z_launch, finite,
                 std::vector<bool>(p.surfaces.size(), false)};
  for (int i : surfaces) setup.computed[size_t(i)] = true;
  for (double lambda : waves) {
    const LensSystem sys = base.atWavelength(lambda);
    for (size_t f = 0; f < fields.size(); ++f)
      widenForField(setup, sys, lambda, f, fields[f], surfaces, semi);
  }
  for (size_t i = 0; i < surfaces.size(); ++i) {
    const LensSurface& s = p.surfaces[size_t(surfaces[i])];
    semi[i] *= 1 + 1e-9;
    const double extent = sagDomainRadius(s.radius_mm, s.shape);
    if (!(semi[i] > 0) || semi[i] >= extent)
      throw Error(s.loc, fmt::format("automatic semi-diameters: the rays need a semi-diameter of "
                                     "{:.6g} mm here, beyond the surface's extent ({:.6g} mm)",
                                     semi[i], extent));
  }
  return semi;
}

std::optional<double> realImageHeightFieldAngle(const LensPrescription& p, double image_height_mm,
                                                bool aim_at_stop) {
  if (image_height_mm == 0) return 0.0;
  const LensSystem sys(p);
  const auto stop = sys.stopIndex();
  if (!stop) throw Error(p.surfaces.front().loc, "real image height fields need an aperture stop");
  const PupilPlane ep = paraxialEntrancePupil(sys, *stop);
  double track = 0;
  for (const LensSurface& s : p.surfaces) track += std::abs(s.thickness_mm);
  const double z_launch = std::min(ep.z_mm, 0.0) - track - 1;
  const TraceOptions unclipped{false, false};
  // The ray at field angle th (radians) through the point (u, 0) of the entrance pupil's plane.
  auto rayAt = [&](double th, double u) {
    const Vec3 d = normalize(Vec3{std::tan(th), 0, 1});
    const Vec3 pupil{u, 0, ep.z_mm};
    return Ray{pupil + d * ((z_launch - ep.z_mm) / d.z), d};
  };
  std::vector<Vec3> path;
  auto stopX = [&](double th, double u) -> std::optional<double> {
    path.clear();
    const TraceResult r = sys.tracer().traceFromScene(rayAt(th, u), unclipped, &path);
    if (path.size() <= size_t(*stop) + 1 || (!r.ok() && r.blocked_surface <= *stop))
      return std::nullopt;
    const double x = path[size_t(*stop) + 1].x;
    return std::isfinite(x) ? std::optional<double>(x) : std::nullopt;
  };
  // The chief ray's pupil point: the centre, or (aiming) where the ray meets the stop's centre
  // (secant steps from the centre).
  auto chiefAim = [&](double th) -> std::optional<double> {
    if (!aim_at_stop) return 0.0;
    double u0 = 0, u1 = 1e-3 * (1 + std::abs(ep.z_mm) * std::abs(std::tan(th)));
    std::optional<double> x0 = stopX(th, u0), x1 = stopX(th, u1);
    for (int i = 0; i < 60 && x0 && x1; ++i) {
      if (*x1 == 0 || *x1 == *x0) return u1;
      const double u2 = u1 - *x1 * (u1 - u0) / (*x1 - *x0);
      u0 = u1, x0 = x1, u1 = u2, x1 = stopX(th, u1);
      if (x1 && std::abs(*x1) < 1e-13 * (1 + std::abs(u1))) return u1;
    }
    return std::nullopt;
  };
  auto height = [&](double th) -> std::optional<double> {
    const std::optional<double> u = chiefAim(th);
    if (!u) return std::nullopt;
    const TraceResult r = sys.tracer().traceFromScene(rayAt(th, *u), unclipped);
    if (!r.ok() || r.ray.direction.z == 0) return std::nullopt;
    const double t = (sys.realFilmZ_mm() - r.ray.origin.z) / r.ray.direction.z;
    const double x = r.ray.origin.x + t * r.ray.direction.x;
    return std::isfinite(x) ? std::optional<double>(x) : std::nullopt;
  };
  constexpr double kStep = 0.25 * std::numbers::pi / 180;
  const std::optional<double> first = height(kStep);
  if (!first || *first == 0) return std::nullopt;
  const double side = *first > 0 ? 1 : -1, target = std::abs(image_height_mm);
  // Scan for the first bracket, then bisect it to the last representable angle.
  double lo = 0, hi = 0;
  bool bracketed = false;
  for (int k = 1; k * kStep < std::numbers::pi / 2; ++k) {
    const std::optional<double> h = height(k * kStep);
    if (!h) break;
    if (side * *h >= target) {
      hi = k * kStep;
      bracketed = true;
      break;
    }
    lo = k * kStep;
  }
  if (!bracketed) return std::nullopt;
  for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) {
    const double mid = (lo + hi) / 2;
    if (mid <= lo || mid >= hi) break;
    const std::optional<double> h = height(mid);
    if (!h) return std::nullopt;  // a gap between two traced angles: no continuous solution
    (side * *h >= target ? hi : lo) = mid;
  }
  const double sign = (image_height_mm > 0 ? 1 : -1) * side;
  return sign * (lo + hi) / 2 * 180 / std::numbers::pi;
}

}  // namespace lensim::optics
