#include "lensim/optics/coating/ghost_trace.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lensim/util/error.h"

namespace lensim::optics {

std::vector<Interface> ghostPathInterfaces(const LensSystem& lens, int first, int second) {
  const int n = lens.surfaceCount();
  const std::string pair = fmt::format("{},{}", first, second);
  if (lens.mirrorCount() > 0)
    throw Error(
        fmt::format("ghost {}: the lens has mirrors (ghosts of catadioptric lenses are "
                    "not modelled)",
                    pair));
  if (!(second >= 0 && second < first && first < n))
    throw Error(
        fmt::format("ghost {}: expected I,J with 0 <= J < I <= {} (surface indices as "
                    "`lens ghosts` lists them: reflected first at I, then at J)",
                    pair, n - 1));
  const auto& s = lens.interfaces();
  for (int k : {first, second})
    if (s[size_t(k)].ior_before == s[size_t(k)].ior_after)
      throw Error(
          fmt::format("ghost {}: surface {} has the same index on both sides ({}) and "
                      "reflects nothing",
                      pair, k, s[size_t(k)].is_stop ? "the aperture stop" : "a dummy"));
  std::vector<Interface> path;
  for (int k = 0; k < first; ++k) path.push_back(s[size_t(k)]);
  auto mirror = [&](int k, double medium, int dir_before) {
    Interface m = s[size_t(k)];
    m.is_mirror = true;
    m.is_stop = false;
    m.ior_before = m.ior_after = medium;
    m.dir_before = dir_before;
    m.dir_after = -dir_before;
    path.push_back(m);
  };
  mirror(first, s[size_t(first)].ior_before, 1);
  for (int k = first - 1; k > second; --k) {
    Interface b = s[size_t(k)];
    std::swap(b.ior_before, b.ior_after);
    b.dir_before = b.dir_after = -1;
    path.push_back(b);
  }
  mirror(second, s[size_t(second)].ior_after, -1);
  for (int k = second + 1; k < n; ++k) path.push_back(s[size_t(k)]);
  return path;
}

int ghostPathSurface(int first, int second, int index) {
  if (index <= first) return index;
  const int back = 2 * first - second;  // where the path meets `second`
  if (index <= back) return 2 * first - index;
  return index - 2 * (first - second);
}

LensTracer<double> ghostTracer(const LensSystem& lens, int first, int second) {
  return LensTracer<double>(ghostPathInterfaces(lens, first, second));
}

namespace {

/// traceSpot's grid: parallel rays of a point at infinity at angle_rad off the axis (x-z plane)
/// over a disc a quarter wider than the front surface's clear aperture (oblique rays meet a
/// curved front surface off their vertex-plane crossing; those that miss the aperture are
/// clipped), each starting a little in front of the front surface's sag region on the line that
/// crosses the vertex plane at its grid point.
std::vector<Ray> gridRays(const Interface& front, double angle_rad, int grid) {
  if (grid < 2 || grid > 2000)
    throw Error(fmt::format("ghost spot: grid {} (expected 2 to 2000 rays across)", grid));
  if (!(std::abs(angle_rad) < 0.5 * std::numbers::pi))
    throw Error(fmt::format("ghost spot: light angle {} deg (expected within -90..90)",
                            angle_rad * 180 / std::numbers::pi));
  const double r = 1.25 * front.semi_aperture_mm;
  const Vec3T<double> dir{std::sin(angle_rad), 0.0, std::cos(angle_rad)};
  const double back = 2 * r + 1;
  std::vector<Ray> rays;
  for (int i = 0; i < grid; ++i)
    for (int j = 0; j < grid; ++j) {
      const double gx = r * (-1 + 2 * (i + 0.5) / grid), gy = r * (-1 + 2 * (j + 0.5) / grid);
      if (gx * gx + gy * gy > r * r) continue;
      const double t = back / dir.z;
      rays.push_back(Ray{{gx - t * dir.x, gy, front.z_mm - back}, dir});
    }
  return rays;
}

}  // namespace

GhostSpot traceSpot(const LensTracer<double>& tracer, const Interface& front, double film_z_mm,
                    double angle_rad, int grid) {
  GhostSpot s;
  double sx = 0, sy = 0, sxx = 0, syy = 0;
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const Ray& ray : gridRays(front, angle_rad, grid)) {
    ++s.rays_launched;
    const TraceResult res = tracer.traceFromScene(ray);
    if (!res.ok() || !(res.ray.direction.z > 0)) continue;
    const double u = (film_z_mm - res.ray.origin.z) / res.ray.direction.z;
    const double x = res.ray.origin.x + u * res.ray.direction.x;
    const double y = res.ray.origin.y + u * res.ray.direction.y;
    ++s.rays_arrived;
    sx += x, sy += y, sxx += x * x, syy += y * y;
    xmin = std::min(xmin, x), xmax = std::max(xmax, x);
    ymin = std::min(ymin, y), ymax = std::max(ymax, y);
  }
  if (s.rays_arrived == 0) return s;
  const double n = s.rays_arrived;
  s.centroid_x_mm = sx / n;
  s.centroid_y_mm = sy / n;
  s.rms_radius_mm = std::sqrt(std::max(0.0, sxx / n - s.centroid_x_mm * s.centroid_x_mm +
                                                syy / n - s.centroid_y_mm * s.centroid_y_mm));
  s.extent_x_mm = xmax - xmin;
  s.extent_y_mm = ymax - ymin;
  return s;
}

void forEachPathRay(const LensSystem& lens, const LensCoatings& coatings, int first, int second,
                    double angle_rad, int grid, std::span<const double> wavelengths_nm,
                    double film_z_mm, const std::function<void(const PathRay&)>& visit) {
  const bool ghost = first >= 0;
  const std::vector<Interface> path =
      ghost ? ghostPathInterfaces(lens, first, second) : lens.interfaces();
  const LensTracer<double> tracer(path);
  const std::vector<Ray> rays = gridRays(path.front(), angle_rad, grid);
  const size_t nw = wavelengths_nm.size(), n = size_t(lens.surfaceCount()), m = path.size();
  // The lens's media at each wavelength; whether they are the same at all of them (the coatings
  // are then evaluated for all wavelengths at once).
  std::vector<double> before(nw * n), after(nw * n);
  for (size_t w = 0; w < nw; ++w)
    lens.indicesAt(wavelengths_nm[w], before.data() + w * n, after.data() + w * n);
  bool same = true;
  for (size_t w = 1; w < nw && same; ++w)
    for (size_t k = 0; k < n && same; ++k)
      same = before[w * n + k] == before[k] && after[w * n + k] == after[k];
  std::vector<double> f(nw);
  std::vector<FilmRTA> rta(nw);
  std::vector<Vec3T<double>> pts;
  for (const Ray& ray : rays) {
    pts.clear();
    const TraceResult res = tracer.traceFromScene(ray, {}, &pts);
    if (!res.ok() || !(res.ray.direction.z > 0) || pts.size() != m + 1) continue;
    std::fill(f.begin(), f.end(), 1.0);
    for (size_t i = 0; i < m; ++i) {
      const Interface& in = path[i];
      if (!in.is_mirror && in.ior_before == in.ior_after) continue;
      // The incidence angle from the directions before (a) and after (b) the surface: the normal
      // is parallel to n_before a - n_after b (Snell's law in vector form; a mirror's a - b).
      const Vec3T<double> a = normalize(pts[i + 1] - pts[i]);
      const Vec3T<double> b = i + 1 < m ? normalize(pts[i + 2] - pts[i + 1]) : res.ray.direction;
      const Vec3T<double> nrm = a * in.ior_before - b * in.ior_after;
      const double len = length(nrm);
      const double cos_i = len > 1e-12 ? std::min(1.0, std::abs(dot(a, nrm)) / len) : 1.0;
      const int k = ghost ? ghostPathSurface(first, second, int(i)) : int(i);
      // Between the reflections (the second one included) the light meets the surfaces from the
      // film's side: the coating sees the lens's media the other way round.
      const bool backward = ghost && int(i) > first && int(i) <= 2 * first - second;
      auto media = [&](size_t w) {
        const double nb = before[w * n + size_t(k)], na = after[w * n + size_t(k)];
        return backward ? std::pair{na, nb} : std::pair{nb, na};
      };
      if (same) {
        const auto [from, to] = media(0);
        coatings.rtaSpectral(k, from, to, wavelengths_nm, cos_i, rta.data());
      } else {
        for (size_t w = 0; w < nw; ++w) {
          const auto [from, to] = media(w);
          rta[w] = coatings.rta(k, from, to, wavelengths_nm[w], cos_i);
        }
      }
      for (size_t w = 0; w < nw; ++w) f[w] *= in.is_mirror ? rta[w].R : rta[w].T;
    }
    const double u = (film_z_mm - res.ray.origin.z) / res.ray.direction.z;
    visit(PathRay{res.ray.origin.x + u * res.ray.direction.x,
                  res.ray.origin.y + u * res.ray.direction.y, f});
  }
}

std::vector<double> tracedPathEnergy(const LensSystem& lens, const LensCoatings& coatings,
                                     int first, int second, double angle_rad, int grid,
                                     std::span<const double> wavelengths_nm) {
  std::vector<double> energy(wavelengths_nm.size(), 0.0);
  forEachPathRay(lens, coatings, first, second, angle_rad, grid, wavelengths_nm, lens.filmZ_mm(),
                 [&](const PathRay& r) {
                   for (size_t w = 0; w < energy.size(); ++w) energy[w] += r.weight[w];
                 });
  return energy;
}

std::optional<double> axisCrossingZ(const Ray& out) {
  if (out.direction.x == 0) return std::nullopt;
  return out.origin.z - out.origin.x * out.direction.z / out.direction.x;
}

}  // namespace lensim::optics
