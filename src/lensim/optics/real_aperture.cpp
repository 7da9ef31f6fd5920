#include "lensim/optics/real_aperture.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

namespace lensim::optics {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Radial height of a ray parallel to the axis at entrance height h on each surface it reaches
// (apertures ignored); the list ends where the ray misses a surface or is totally reflected.
// The ray is in the y-z plane: for an anamorphic lens, the section whose EFL the f-number uses.
std::vector<double> heightsAt(const LensSystem& lens, double h, Ray* out = nullptr) {
  std::vector<Vec3> path;
  const Ray ray{{0, h, -1.0}, {0, 0, 1}};
  TraceResult r = lens.tracer().traceFromScene(ray, TraceOptions{false}, &path);
  std::vector<double> hs;
  // path[0] is the start; path[k + 1] is surface k. A ray stopped at surface k (miss, TIR) still
  // reached it when the point was recorded, but a miss records no point.
  for (size_t k = 1; k < path.size(); ++k) hs.push_back(std::hypot(path[k].x, path[k].y));
  if (!r.ok() && r.reason == BlockReason::TotalInternalReflection && !hs.empty()) hs.pop_back();
  if (out && r.ok()) *out = r.ray;
  return hs;
}

}  // namespace

RealAxialBeam realAxialBeam(const LensSystem& lens, double efl_mm) {
  const auto& s = lens.interfaces();
  const int n = lens.surfaceCount();
  const double H = s.front().semi_aperture_mm;
  RealAxialBeam b;
  b.surface_limit_height_mm.assign(n, kInf);
  // Whether the ray at height h gets through surface i: 1 inside its aperture, 0 outside it (or
  // missed or totally reflected there), -1 lost before it (surface i does not limit it).
  auto inside = [&](const std::vector<double>& hs, int i) {
    const int reached = static_cast<int>(hs.size());
    if (i < reached) return hs[i] <= s[i].semi_aperture_mm ? 1 : 0;
    return i == reached ? 0 : -1;
  };
  constexpr int kScan = 400;
  std::vector<double> prev_ok(n, 0.0);  // the last scanned height that passed surface i
  std::vector<bool> found(n, false);
  for (int k = 1; k <= kScan; ++k) {
    const double h = H * k / kScan;
    const std::vector<double> hs = heightsAt(lens, h);
    for (int i = 0; i < n; ++i) {
      if (found[i]) continue;
      const int in = inside(hs, i);
      if (in != 0) {
        if (in > 0) prev_ok[i] = h;
        continue;
      }
      found[i] = true;
      // Bisect between the last passing height and this one.
      double lo = prev_ok[i], hi = h;
      for (int it = 0; it < 60 && hi - lo > 1e-12 * H; ++it) {
        const double mid = 0.5 * (lo + hi);
        (inside(heightsAt(lens, mid), i) > 0 ? lo : hi) = mid;
      }
      b.surface_limit_height_mm[i] = lo;
    }
  }
  b.marginal_height_mm = kInf;
  for (int i = 0; i < n; ++i)
    if (b.surface_limit_height_mm[i] < b.marginal_height_mm) {
      b.marginal_height_mm = b.surface_limit_height_mm[i];
      b.limit_surface = i;
    }
  if (b.limit_surface < 0) {  // nothing limits before the front rim: the front surface does
    b.marginal_height_mm = H;
    b.limit_surface = 0;
    b.surface_limit_height_mm[0] = H;
  }
  if (!(b.marginal_height_mm > 0))
    throw Error(FileLoc{lens.prescription().path},
                "no real ray parallel to the axis gets through the lens");
  // The marginal ray itself (a hair inside, so that it passes every aperture).
  Ray out;
  heightsAt(lens, b.marginal_height_mm * (1 - 1e-9), &out);
  const double sin_u = std::hypot(out.direction.x, out.direction.y);
  b.f_number = sin_u > 0 ? 1 / (2 * lens.imageIor() * sin_u) : kInf;
  b.f_number_entrance = std::abs(efl_mm) / (2 * b.marginal_height_mm);
  return b;
}

}  // namespace lensim::optics
