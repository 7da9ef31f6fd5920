#include "lensim/optics/chief_ray.h"

#include <cmath>
#include <functional>
#include <numbers>

#include "lensim/optics/anamorphic.h"

namespace lensim::optics {

namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

// Finds the aim height a for which stop_x(a) = 0, scanning a bracket and bisecting. stop_x
// returns nullopt where the ray cannot be traced.
std::optional<double> solveAim(const std::function<std::optional<double>(double)>& stop_x,
                               double range) {
  constexpr int kScan = 256;
  std::optional<double> best;
  double prev_a = 0;
  std::optional<double> prev_f;
  for (int k = 0; k <= kScan; ++k) {
    const double a = -range + 2 * range * k / kScan;
    std::optional<double> f = stop_x(a);
    if (f && *f == 0) return a;
    if (f && prev_f && (*f > 0) != (*prev_f > 0)) {
      // Bisect this bracket; keep the root nearest to the axis.
      double lo = prev_a, hi = a, flo = *prev_f;
      for (int it = 0; it < 100 && hi - lo > 1e-13 * range; ++it) {
        const double mid = 0.5 * (lo + hi);
        std::optional<double> fm = stop_x(mid);
        if (!fm) break;
        if ((*fm > 0) == (flo > 0)) {
          lo = mid;
          flo = *fm;
        } else {
          hi = mid;
        }
      }
      const double root = 0.5 * (lo + hi);
      if (!best || std::abs(root) < std::abs(*best)) best = root;
    }
    prev_a = a;
    prev_f = f;
  }
  return best;
}

double largestSemiAperture(const LensSystem& lens) {
  double m = 0;
  for (const Interface& s : lens.interfaces()) m = std::max(m, s.semi_aperture_mm);
  return m;
}

}  // namespace

std::optional<ChiefRay> chiefRayFromFilm(const LensSystem& lens, const ParaxialData& p,
                                         double film_height_mm) {
  const int n = lens.surfaceCount();
  const int st = p.aperture_stop_surface;
  const TraceOptions noclip{false};
  const Vec3 from{film_height_mm, 0, lens.filmZ_mm()};
  // Aim on the exit-pupil plane, which is conjugate to the stop: there the stop crossing is a
  // gentle, nearly linear function of the aim point and the root sits near the pupil centre.
  // Aiming at the rear-vertex plane is ill-conditioned when the film is close to the rear
  // vertex or the lens is long. Fall back to it when the exit pupil lies behind the film.
  const double eps = 0.02 * std::abs(p.effective_focal_length_mm);
  const bool use_xp = p.exit_pupil_z_mm < from.z - eps;
  const double z_aim = use_xp ? p.exit_pupil_z_mm : lens.rearVertexZ_mm();
  const double range = use_xp ? 3 * p.exit_pupil_diameter_mm / 2 + 2 * std::abs(film_height_mm)
                              : 3 * largestSemiAperture(lens);
  auto trace = [&](double a, std::vector<Vec3>* path) {
    const Ray ray{from, normalize(Vec3{a, 0, z_aim} - from)};
    return lens.tracer().traceFromFilm(ray, noclip, path);
  };
  auto stop_x = [&](double a) -> std::optional<double> {
    std::vector<Vec3> path;
    TraceResult r = trace(a, &path);
    if (static_cast<int>(path.size()) <= n - st) return std::nullopt;
    if (!r.ok() && r.blocked_surface >= st) return std::nullopt;  // lost before the stop
    return path[n - st].x;
  };
  std::optional<double> a = solveAim(stop_x, range);
  if (!a) return std::nullopt;
  std::vector<Vec3> path;
  TraceResult r = trace(*a, &path);
  if (!r.ok()) return std::nullopt;
  ChiefRay c;
  c.scene_ray = r.ray;
  c.film_ray = Ray{path[0], normalize(path[1] - path[0])};
  c.field_angle_deg = std::acos(std::min(1.0, std::abs(r.ray.direction.z))) * kDeg;
  c.film_height_mm = film_height_mm;
  return c;
}

std::optional<ChiefRay> chiefRayFromScene(const LensSystem& lens, const ParaxialData& p,
                                          double field_angle_deg) {
  const int st = p.aperture_stop_surface;
  const double th = field_angle_deg / kDeg;
  const Vec3 dir{std::sin(th), 0, std::cos(th)};
  const double z_start =
      std::min(p.entrance_pupil_z_mm, 0.0) - 10 * (largestSemiAperture(lens) + 1);
  const TraceOptions noclip{false};
  auto make = [&](double a) {
    const Vec3 at{a, 0, p.entrance_pupil_z_mm};
    return Ray{at + dir * ((z_start - at.z) / dir.z), dir};
  };
  auto stop_x = [&](double a) -> std::optional<double> {
    std::vector<Vec3> path;
    TraceResult r = lens.tracer().traceFromScene(make(a), noclip, &path);
    if (static_cast<int>(path.size()) <= 1 + st) return std::nullopt;
    if (!r.ok() && r.blocked_surface <= st) return std::nullopt;
    return path[1 + st].x;
  };
  const double range =
      3 * largestSemiAperture(lens) + std::abs(std::tan(th)) * std::abs(p.entrance_pupil_z_mm);
  std::optional<double> a = solveAim(stop_x, range);
  if (!a) return std::nullopt;
  Ray in = make(*a);
  TraceResult r = lens.tracer().traceFromScene(in, noclip);
  if (!r.ok() || !(r.ray.direction.z > 0)) return std::nullopt;
  ChiefRay c;
  c.scene_ray = in;
  c.film_ray = r.ray;
  c.field_angle_deg = field_angle_deg;
  const double t = (lens.filmZ_mm() - r.ray.origin.z) / r.ray.direction.z;
  c.film_height_mm = r.ray.origin.x + t * r.ray.direction.x;
  return c;
}

std::optional<Vec2> passingRearAim(const LensSystem& lens, const ParaxialData& p,
                                   double film_height_mm) {
  return passingRearAim(lens, p, Vec2{film_height_mm, 0});
}

std::optional<Vec2> passingRearAim(const LensSystem& lens, const ParaxialData& p, Vec2 film_mm) {
  const double h = film_mm.x;
  const Vec3 film{film_mm.x, film_mm.y, lens.filmZ_mm()};
  const double z_rear = lens.rearVertexZ_mm();
  auto passes = [&](Vec2 a) { return lens.traceFromFilmPoint(film_mm, a, kOuterBoundary).ok(); };
  // Where the line from the film point through `q` crosses the rear-vertex plane.
  auto toRear = [&](const Vec3& q) {
    const double t = (z_rear - film.z) / (q.z - film.z);
    return Vec2{film.x + t * (q.x - film.x), film.y + t * (q.y - film.y)};
  };
  if (auto c = film_mm.y == 0 ? chiefRayFromFilm(lens, p, h) : std::nullopt) {
    const Vec2 a = toRear(c->film_ray.origin + c->film_ray.direction);
    if (passes(a)) return a;
  }
  constexpr int kGrid = 41;
  // Without obscurations (where kOuterBoundary is the plain trace) the grid's points are traced
  // in order a batch at a time (LensTracer::traceFromFilmBatch, the same results).
  const bool obscured = lens.hasObscuration();
  auto scanDisc = [&](auto&& point_at) -> std::optional<Vec2> {
    constexpr int kB = LensTracer<double>::kBatch;
    Vec2 pts[kB];
    Ray rays[kB];
    TraceResult res[kB];
    int m = 0;
    auto flush = [&]() -> std::optional<Vec2> {
      lens.tracer().traceFromFilmBatch(rays, m, res);
      const int n = m;
      m = 0;
      for (int i = 0; i < n; ++i)
        if (res[i].ok()) return pts[i];
      return std::nullopt;
    };
    for (int iy = 0; iy < kGrid; ++iy)
      for (int ix = 0; ix < kGrid; ++ix) {
        const double u = 2.0 * ix / (kGrid - 1) - 1, v = 2.0 * iy / (kGrid - 1) - 1;
        if (u * u + v * v > 1) continue;
        const Vec2 a = point_at(u, v);
        if (obscured) {
          if (passes(a)) return a;
          continue;
        }
        pts[m] = a;
        rays[m] = lens.filmPointRay(film_mm, a);
        if (++m == kB)
          if (auto found = flush()) return found;
      }
    if (m > 0) return flush();
    return std::nullopt;
  };
  // The exit pupil (paraxial), overfilled, when it lies between the lens and the film side.
  if (p.exit_pupil_z_mm < film.z - 1e-9) {
    const double r = 2 * p.exit_pupil_diameter_mm / 2;
    auto at = [&](double u, double v) { return toRear(Vec3{u * r, v * r, p.exit_pupil_z_mm}); };
    if (auto a = scanDisc(at)) return a;
  }
  const double rr = 1.5 * lens.interfaces().back().semi_aperture_mm;
  return scanDisc([&](double u, double v) { return Vec2{u * rr, v * rr}; });
}

bool filmPointSeesScene(const LensSystem& lens, const ParaxialData& p, double film_height_mm) {
  return passingRearAim(lens, p, film_height_mm).has_value();
}

bool filmPointSeesScene(const LensSystem& lens, const ParaxialData& p, Vec2 film_mm) {
  return passingRearAim(lens, p, film_mm).has_value();
}

FieldOfView fieldOfView(const LensSystem& lens, const ParaxialData& p, double film_diagonal_mm) {
  FieldOfView fov;
  const double h = film_diagonal_mm / 2;
  fov.paraxial_deg = 2 * std::atan(h / std::abs(p.effective_focal_length_mm)) * kDeg;
  const bool rotational = isRotationallySymmetric(lens.prescription());
  auto covered = [&](double hh) -> std::optional<ChiefRay> {
    if (!filmPointSeesScene(lens, p, hh)) return std::nullopt;
    for (int k = 1; !rotational && k <= 6; ++k) {
      const double phi = std::numbers::pi / 2 * k / 6;
      if (!filmPointSeesScene(lens, p, Vec2{hh * std::cos(phi), hh * std::sin(phi)}))
        return std::nullopt;
    }
    return chiefRayFromFilm(lens, p, hh);
  };
  if (auto c = covered(h)) {
    fov.real_deg = 2 * c->field_angle_deg;
    return fov;
  }
  // The corner is outside the image circle: find the largest film radius that sees the scene.
  double lo = 0, hi = h, lo_angle = 0;
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (auto c = covered(mid)) {
      lo = mid;
      lo_angle = c->field_angle_deg;
    } else {
      hi = mid;
    }
  }
  fov.image_circle_diameter_mm = 2 * lo;
  fov.real_max_deg = 2 * lo_angle;
  return fov;
}

}  // namespace lensim::optics
