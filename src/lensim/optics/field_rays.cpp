#include "lensim/optics/field_rays.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>

#include "lensim/optics/chief_ray.h"

namespace lensim::optics {

double SpectralLens::primaryNm() const {
  double best = kDLineNm, w = -1;
  for (const WeightedWavelength& x : wavelengths)
    if (x.weight > w) {
      w = x.weight;
      best = x.nm;
    }
  return best;
}

SpectralLens monochromatic(const FocusedLens& fl, const std::vector<WeightedWavelength>& wl) {
  SpectralLens s;
  s.focused = &fl;
  s.wavelengths = wl;
  return s;
}

SpectralLens spectral(const FocusedLens& fl, const std::vector<WeightedWavelength>& wl) {
  SpectralLens s = monochromatic(fl, wl);
  if (!fl.lens->dispersive()) return s;
  // One system per wavelength, built once; the map's nodes keep their addresses.
  auto systems = std::make_shared<std::map<double, LensSystem>>();
  for (const WeightedWavelength& w : wl)
    if (w.nm != fl.lens->wavelength_nm() && !systems->count(w.nm))
      systems->emplace(w.nm, fl.lens->atWavelength(w.nm));
  const LensSystem* primary = fl.lens.get();
  s.lens_for = [systems, primary](double nm) -> const LensSystem& {
    auto it = systems->find(nm);
    if (it != systems->end()) return it->second;
    if (nm == primary->wavelength_nm()) return *primary;
    return systems->emplace(nm, primary->atWavelength(nm)).first->second;
  };
  return s;
}

std::vector<WeightedWavelength> parseWavelengths(const std::string& text,
                                                 const std::string& option) {
  std::vector<WeightedWavelength> out;
  size_t start = 0;
  auto bad = [&] {
    return Error(fmt::format(
        "{} '{}': expected wavelengths in nm (300 to 2000), each optionally :weight (> 0), "
        "separated by commas, e.g. 486.13:1,587.56:2,656.27:1",
        option, text));
  };
  while (start <= text.size()) {
    size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    const std::string item = text.substr(start, comma - start);
    const size_t colon = item.find(':');
    WeightedWavelength w;
    try {
      size_t used = 0;
      const std::string a = item.substr(0, colon);
      w.nm = std::stod(a, &used);
      if (used != a.size()) throw bad();
      if (colon != std::string::npos) {
        const std::string b = item.substr(colon + 1);
        w.weight = std::stod(b, &used);
        if (used != b.size()) throw bad();
      }
    } catch (const std::exception&) {
      throw bad();
    }
    if (!(w.nm >= 300 && w.nm <= 2000) || !(w.weight > 0) || !std::isfinite(w.weight)) throw bad();
    out.push_back(w);
    start = comma + 1;
  }
  return out;
}

std::optional<FieldBundle> FieldBundle::fromFilmHeight(const FocusedLens& fl,
                                                       const LensSystem& lens, double h) {
  const ParaxialData& p = fl.paraxial;
  auto chief = chiefRayFromFilm(lens, p, h);
  if (!chief) return std::nullopt;
  FieldBundle b;
  b.film_height_mm = h;
  b.field_angle_deg = chief->field_angle_deg;
  b.pupil_radius_mm = p.entrance_pupil_diameter_mm / 2;
  // The chief ray leaves toward the scene; the object lies on it at the focus distance (or at
  // infinity, where the bundle is parallel to it).
  const Ray& c = chief->scene_ray;
  const double t_ep = (p.entrance_pupil_z_mm - c.origin.z) / c.direction.z;
  b.pupil_centre = c.origin + c.direction * t_ep;
  b.chief_scene = {c.origin, -c.direction};
  if (!std::isinf(fl.focus_distance_m)) {
    const double z_obj = fl.lens->filmZ_mm() - fl.focus_distance_m * 1000;
    b.object = c.origin + c.direction * ((z_obj - c.origin.z) / c.direction.z);
  }
  return b;
}

Ray FieldBundle::sceneRay(Vec2 offset) const {
  const Vec3 aim = pupil_centre + Vec3{offset.x, offset.y, 0};
  if (object) return {*object, normalize(aim - *object)};
  const Vec3 d = chief_scene.direction;
  // Start well in front of the front vertex (z = 0).
  const double back = (aim.z + 10 * pupil_radius_mm + 10) / d.z;
  return {aim - d * back, d};
}

std::optional<Vec2> FieldBundle::hitPlane(const LensSystem& lens, const Ray& ray, double film_z,
                                          Vec3* direction) {
  TraceResult r = lens.tracer().traceFromScene(ray);
  if (!r.ok() || !(r.ray.direction.z > 0)) return std::nullopt;
  const double t = (film_z - r.ray.origin.z) / r.ray.direction.z;
  const Vec3 q = r.ray.origin + r.ray.direction * t;
  if (direction) *direction = r.ray.direction;
  return Vec2{q.x, q.y};
}

std::optional<std::pair<Vec2, double>> FieldBundle::pupilCircle(const LensSystem& lens) const {
  // The outer boundary of the beam: central obscurations (a catadioptric lens) would hide the
  // centre the search starts from; the rays traced through the region meet them.
  auto passes = [&](Vec2 o) {
    return lens.tracer().traceFromScene(sceneRay(o), kOuterBoundary).ok();
  };
  const double reach = 4 * pupil_radius_mm + 1e-3;
  // A passing point: the chief ray, else a search over a grid.
  std::optional<Vec2> c;
  if (passes({0, 0})) c = Vec2{0, 0};
  for (int grid : {16, 64}) {
    for (int iy = 0; iy < grid && !c; ++iy)
      for (int ix = 0; ix < grid && !c; ++ix) {
        const Vec2 o{reach * (2.0 * (ix + 0.5) / grid - 1), reach * (2.0 * (iy + 0.5) / grid - 1)};
        if (passes(o)) c = o;
      }
  }
  if (!c) return std::nullopt;
  constexpr int kDirs = 64;
  std::vector<Vec2> pts;
  for (int j = 0; j < kDirs; ++j) {
    const double a = 2 * std::numbers::pi * j / kDirs;
    const Vec2 u{std::cos(a), std::sin(a)};
    double lo = 0, hi = 1e-3 * reach;
    while (hi < 2 * reach && passes(*c + u * hi)) {
      lo = hi;
      hi *= 2;
    }
    for (int it = 0; it < 40; ++it) {
      const double mid = 0.5 * (lo + hi);
      (passes(*c + u * mid) ? lo : hi) = mid;
    }
    pts.push_back(*c + u * hi);
  }
  Vec2 lo_pt{1e300, 1e300}, hi_pt{-1e300, -1e300};
  for (const Vec2& q : pts) {
    lo_pt = {std::min(lo_pt.x, q.x), std::min(lo_pt.y, q.y)};
    hi_pt = {std::max(hi_pt.x, q.x), std::max(hi_pt.y, q.y)};
  }
  const Vec2 centre = (lo_pt + hi_pt) * 0.5;
  double r = 0;
  for (const Vec2& q : pts) r = std::max(r, std::hypot(q.x - centre.x, q.y - centre.y));
  return std::make_pair(centre, 1.03 * r);
}

double FieldBundle::PupilRegion::radiusAt(double phi) const {
  const int n = static_cast<int>(radius.size());
  double t = phi / (2 * std::numbers::pi) * n;
  t -= n * std::floor(t / n);
  const int i = std::min(static_cast<int>(t), n - 1);
  const double f = t - i;
  return radius[i] * (1 - f) + radius[(i + 1) % n] * f;
}

std::optional<FieldBundle::PupilRegion> FieldBundle::pupilRegion(const LensSystem& lens,
                                                                 int directions) const {
  auto circle = pupilCircle(lens);
  if (!circle) return std::nullopt;
  // The outer boundary of the beam: central obscurations (a catadioptric lens) would hide the
  // centre the search starts from; the rays traced through the region meet them.
  auto passes = [&](Vec2 o) {
    return lens.tracer().traceFromScene(sceneRay(o), kOuterBoundary).ok();
  };
  PupilRegion region;
  region.centre = circle->first;
  if (!passes(region.centre)) {
    // The circle's centre is outside a crescent-shaped region: start from a passing point.
    std::optional<Vec2> c;
    const double reach = circle->second;
    for (int grid : {16, 64})
      for (int iy = 0; iy < grid && !c; ++iy)
        for (int ix = 0; ix < grid && !c; ++ix) {
          const Vec2 o = circle->first + Vec2{reach * (2.0 * (ix + 0.5) / grid - 1),
                                              reach * (2.0 * (iy + 0.5) / grid - 1)};
          if (passes(o)) c = o;
        }
    if (!c) return std::nullopt;
    region.centre = *c;
  }
  const double span = 2.5 * circle->second;
  for (int j = 0; j < directions; ++j) {
    const double a = 2 * std::numbers::pi * j / directions;
    const Vec2 u{std::cos(a), std::sin(a)};
    // From the centre outward: the first blocked point, scanned, then bisected.
    double lo = 0, hi = span;
    constexpr int kScan = 32;
    for (int k = 1; k <= kScan; ++k) {
      const double r = span * k / kScan;
      if (!passes(region.centre + u * r)) {
        hi = r;
        break;
      }
      lo = r;
    }
    for (int it = 0; it < 40; ++it) {
      const double mid = 0.5 * (lo + hi);
      (passes(region.centre + u * mid) ? lo : hi) = mid;
    }
    region.radius.push_back(0.5 * (lo + hi));
  }
  return region;
}

namespace {

// Gauss-Legendre nodes and weights on [-1, 1] (Newton's iteration on P_n from the Chebyshev
// guesses; the textbook algorithm, a few lines, so not worth a dependency).
void gaussLegendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(n, 0);
  w.assign(n, 0);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5)), dp = 1;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1;
      dp = n * (z * p1 - p0) / (z * z - 1);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-15) break;
    }
    x[i] = z;
    w[i] = 2 / ((1 - z * z) * dp * dp);
  }
}

}  // namespace

std::vector<PupilPoint> hexapolarPupil(const FieldBundle::PupilRegion& region, int rings) {
  std::vector<double> gx, gw;
  gaussLegendre(rings, gx, gw);
  std::vector<PupilPoint> pts;
  for (int k = 1; k <= rings; ++k) {
    const int count = 6 * k;
    // Ring k of `rings`, innermost first: the Gauss-Legendre node on [0, 1] in radius, whose
    // weight times rho integrates the annulus (rho d rho d phi).
    const int g = rings - k;  // nodes come out largest first
    const double rho = 0.5 * (gx[g] + 1);
    const double share = 0.5 * gw[g] * rho * 2 * std::numbers::pi / count;
    for (int j = 0; j < count; ++j) {
      const double phi = 2 * std::numbers::pi * (j + 0.5 * (k % 2)) / count;
      const double R = region.radiusAt(phi);
      pts.push_back({region.centre + Vec2{rho * R * std::cos(phi), rho * R * std::sin(phi)},
                     share * R * R, k, j});
    }
  }
  return pts;
}

std::optional<Vec2> chiefImagePoint(const LensSystem& lens, const FieldBundle& b,
                                    double film_z_mm) {
  // Apertures ignored: the chief ray may be vignetted and still define the image point.
  TraceResult r = lens.tracer().traceFromScene(b.sceneRay({0, 0}), TraceOptions{false});
  if (!r.ok() || !(r.ray.direction.z > 0)) return std::nullopt;
  const double t = (film_z_mm - r.ray.origin.z) / r.ray.direction.z;
  const Vec3 q = r.ray.origin + r.ray.direction * t;
  return Vec2{q.x, q.y};
}

}  // namespace lensim::optics
