#include "lensim/optics/pupil.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "lensim/optics/chief_ray.h"

namespace lensim::optics {

namespace {

Vec2 unit(double phi) {
  return {std::cos(phi), std::sin(phi)};
}
double cross2(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}

}  // namespace

ExitPupilSampler::ExitPupilSampler(const LensSystem& lens, const ParaxialData& p,
                                   double film_radius_mm, const ExitPupilOptions& opts)
    : film_radius_mm_(film_radius_mm),
      z_rear_mm_(lens.rearVertexZ_mm()),
      directions_(std::max(8, opts.directions)) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int j = 0; j < directions_; ++j)
    dirs_.push_back(unit(2 * std::numbers::pi * j / directions_));
  const int ni = std::max(1, opts.radial_bins);
  const int nd = directions_;
  const double dphi = 2 * std::numbers::pi / nd;
  const double rr = 1.5 * lens.interfaces().back().semi_aperture_mm;

  auto passes = [&](double h, Vec2 a) {
    ++traces_;
    return lens.traceFromFilmPoint({h, 0}, a).ok();
  };
  // Distance from c (inside the region) to the region's boundary along u: the first blocked
  // point, bisected to 1e-3 relative; starts from a guess and grows or shrinks geometrically.
  auto boundary = [&](double h, Vec2 c, Vec2 u, double guess) {
    double lo = 0, hi = std::max(guess, 1e-6 * rr);
    if (passes(h, c + u * hi)) {
      lo = hi;
      while (hi < 4 * rr && passes(h, c + u * (2 * hi))) lo = hi *= 2;
      hi *= 2;
    } else {
      while (hi > 1e-9 * rr && !passes(h, c + u * (0.5 * hi))) hi *= 0.5;
      lo = 0.5 * hi;
    }
    while (hi - lo > 1e-3 * hi) {
      const double mid = 0.5 * (lo + hi);
      (passes(h, c + u * mid) ? lo : hi) = mid;
    }
    return hi;
  };
  // Boundary points of the region at film radius h, seen from a point inside it, in `count`
  // directions starting at angle `offset`. Empty if the film point sees nothing.
  // A point inside the region at film radius h: the chief ray or pupil grids, else (near the
  // edge of the image circle, where the region is tiny) a fine grid around a neighbour's polygon.
  auto findInside = [&](double h, const Polygon* hint) -> std::optional<Vec2> {
    std::optional<Vec2> c = passingRearAim(lens, p, h);
    if (c && passes(h, *c)) return c;
    if (!hint || hint->empty) return std::nullopt;
    const double reach = 1.5 * *std::max_element(hint->radius.begin(), hint->radius.end());
    // Coarse first; then fine enough to find slivers a hundredth of the neighbour's size.
    for (int grid : {24, 96}) {
      for (int iy = 0; iy < grid; ++iy)
        for (int ix = 0; ix < grid; ++ix) {
          const Vec2 a = hint->centre + Vec2{reach * (2.0 * (ix + 0.5) / grid - 1),
                                             reach * (2.0 * (iy + 0.5) / grid - 1)};
          if (passes(h, a)) return a;
        }
    }
    return std::nullopt;
  };
  auto boundaryPoints = [&](double h, int count, double offset, Vec2* centre_out,
                            const Polygon* hint) {
    std::vector<Vec2> pts;
    std::optional<Vec2> c = findInside(h, hint);
    if (!c) return pts;
    // Move toward the middle of the region (the found point may lie near its edge, where the
    // chief ray is vignetted): the centre of a coarse ring of boundary points, twice.
    for (int it = 0; it < 2; ++it) {
      Vec2 lo_pt{1e300, 1e300}, hi_pt{-1e300, -1e300};
      for (int j = 0; j < 12; ++j) {
        const Vec2 u = unit(2 * std::numbers::pi * j / 12);
        const Vec2 q = *c + u * boundary(h, *c, u, 0.1 * rr);
        lo_pt = {std::min(lo_pt.x, q.x), std::min(lo_pt.y, q.y)};
        hi_pt = {std::max(hi_pt.x, q.x), std::max(hi_pt.y, q.y)};
      }
      const Vec2 mid = (lo_pt + hi_pt) * 0.5;
      if (!passes(h, mid)) break;
      c = mid;
    }
    if (centre_out) *centre_out = *c;
    double guess = 0.1 * rr;
    for (int j = 0; j < count; ++j) {
      const Vec2 u = unit(offset + 2 * std::numbers::pi * j / count);
      guess = boundary(h, *c, u, guess);
      pts.push_back(*c + u * guess);
    }
    return pts;
  };
  // Widens the polygon until it contains the points: a point beyond the edge between vertices j
  // and j+1 scales both vertices by the ratio, which scales that edge about the centre. Returns
  // the per-vertex factors (1 where nothing reaches beyond).
  auto coverFactors = [&](const Polygon& poly, const std::vector<Vec2>& pts) {
    std::vector<double> f(nd, 1.0);
    for (const Vec2& q : pts) {
      const Vec2 d = q - poly.centre;
      const double dist = std::hypot(d.x, d.y);
      if (dist == 0) continue;
      double ang = std::atan2(d.y, d.x);
      if (ang < 0) ang += 2 * std::numbers::pi;
      const int j = std::min(static_cast<int>(ang / dphi), nd - 1);
      const int j1 = (j + 1) % nd;
      const Vec2 a = unit(j * dphi) * poly.radius[j];
      const Vec2 b = unit((j + 1) * dphi) * poly.radius[j1];
      // Where the ray from the centre along d meets the edge a-b.
      const Vec2 w = d * (1 / dist);
      const double denom = cross2(b - a, w);
      const double reach = denom != 0 ? cross2(b - a, a) / denom : 0;
      const double need = reach > 0 ? dist / reach : 4.0;  // degenerate edge: be generous
      f[j] = std::max(f[j], need);
      f[j1] = std::max(f[j1], need);
    }
    return f;
  };

  // A node: the region's polygon at radius h, checked at the half-way directions.
  auto makeNode = [&](double h, const Polygon* hint) {
    Polygon poly;
    poly.r = h;
    std::vector<Vec2> pts = boundaryPoints(h, nd, 0.0, &poly.centre, hint);
    if (pts.empty()) return poly;
    poly.empty = false;
    for (const Vec2& q : pts)
      poly.radius.push_back(std::hypot(q.x - poly.centre.x, q.y - poly.centre.y));
    const std::vector<double> f =
        coverFactors(poly, boundaryPoints(h, nd, 0.5 * dphi, nullptr, &poly));
    for (int j = 0; j < nd; ++j) poly.radius[j] *= f[j];
    return poly;
  };
  auto area = [&](const Polygon& poly) { return poly.empty ? 0.0 : polygonArea(poly); };

  // Uniform nodes first; then each interval is checked half-way: the interpolated polygon must
  // contain the true region there. Where it would have to grow by more than a few percent, or
  // the region changes fast (at the edge of the image circle), the interval is split.
  const double min_width = film_radius_mm / (ni * 16.0);
  std::vector<Polygon> done;
  std::vector<std::vector<double>> scales;
  std::vector<Polygon> stack;  // right ends still to process, nearest last
  std::vector<Polygon> initial;
  for (int k = 0; k <= ni; ++k)
    initial.push_back(makeNode(film_radius_mm * k / ni, k > 0 ? &initial.back() : nullptr));
  for (int k = ni; k >= 1; --k) stack.push_back(initial[k]);
  Polygon left = initial[0];
  done.push_back(left);
  while (!stack.empty()) {
    Polygon right = stack.back();
    const double h = 0.5 * (left.r + right.r);
    Polygon interp;
    const bool any = interpolateBetween(left, right, h, interp);
    std::vector<double> f(nd, 1.0);
    bool split = false;
    if (any) {
      f = coverFactors(interp, boundaryPoints(h, nd, 0.25 * dphi, nullptr, &interp));
      const double worst = *std::max_element(f.begin(), f.end());
      const double a0 = area(left), a1 = area(right);
      const bool fast = left.empty != right.empty || std::max(a0, a1) > 1.25 * std::min(a0, a1);
      split = (worst > 1.03 || fast) && right.r - left.r > 2 * min_width;
    }
    if (split) {
      stack.push_back(makeNode(h, left.empty ? &right : &left));
      continue;
    }
    if (any && left.empty != right.empty) {
      // At the edge of the image circle the region moves and vanishes within the interval:
      // check it all across.
      for (double t : {0.1, 0.3, 0.7, 0.9, 0.99}) {
        const double ht = left.r + t * (right.r - left.r);
        Polygon at;
        interpolateBetween(left, right, ht, at);
        const std::vector<double> g =
            coverFactors(at, boundaryPoints(ht, nd, 0.25 * dphi, nullptr, &at));
        for (int j = 0; j < nd; ++j) f[j] = std::max(f[j], g[j]);
      }
    }
    // Where the region vanishes (the edge of the image circle) it changes shape fastest: triple
    // the margin there.
    const double margin = left.empty != right.empty ? 3 * opts.margin : opts.margin;
    for (double& v : f) v *= 1 + margin;
    scales.push_back(std::move(f));
    done.push_back(right);
    stack.pop_back();
    left = right;
  }
  nodes_ = std::move(done);
  scale_ = std::move(scales);
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool ExitPupilSampler::interpolateBetween(const Polygon& a, const Polygon& b, double r,
                                          Polygon& poly) const {
  if (a.empty && b.empty) return false;
  if (a.empty || b.empty) {
    poly = a.empty ? b : a;
    poly.r = r;
    return true;
  }
  const double t = std::clamp((r - a.r) / (b.r - a.r), 0.0, 1.0);
  poly.empty = false;
  poly.r = r;
  poly.centre = a.centre * (1 - t) + b.centre * t;
  poly.radius.resize(a.radius.size());
  for (size_t j = 0; j < a.radius.size(); ++j)
    poly.radius[j] = a.radius[j] * (1 - t) + b.radius[j] * t;
  return true;
}

int ExitPupilSampler::intervalFor(double r) const {
  // Nodes are sorted by radius; the interval k spans nodes k and k + 1.
  auto it = std::upper_bound(nodes_.begin(), nodes_.end(), r,
                             [](double v, const Polygon& n) { return v < n.r; });
  const int k = static_cast<int>(it - nodes_.begin()) - 1;
  return std::clamp(k, 0, static_cast<int>(scale_.size()) - 1);
}

bool ExitPupilSampler::boundFor(Vec2 film_mm, Polygon& poly, double& cos_a, double& sin_a) const {
  const double r = std::hypot(film_mm.x, film_mm.y);
  if (r > film_radius_mm_ * (1 + 1e-9) || scale_.empty()) return false;
  const int k = intervalFor(r);
  if (!interpolateBetween(nodes_[k], nodes_[k + 1], r, poly)) return false;
  for (size_t j = 0; j < poly.radius.size(); ++j) poly.radius[j] *= scale_[k][j];
  cos_a = r > 0 ? film_mm.x / r : 1.0;
  sin_a = r > 0 ? film_mm.y / r : 0.0;
  return true;
}

double ExitPupilSampler::polygonArea(const Polygon& poly) const {
  const int nd = directions_;
  const double sin_d = std::sin(2 * std::numbers::pi / nd);
  double sum = 0;
  for (int j = 0; j < nd; ++j) sum += 0.5 * poly.radius[j] * poly.radius[(j + 1) % nd] * sin_d;
  return sum;
}

std::optional<PupilSample> ExitPupilSampler::sample(Vec2 film_mm, Vec2 u) const {
  thread_local Polygon poly;
  double ca, sa;
  if (!boundFor(film_mm, poly, ca, sa)) return std::nullopt;
  const int nd = directions_;
  const double sin_d = dirs_[1].y;
  // Pick a triangle of the fan by area, reusing u.x for the position inside it.
  double total = 0;
  for (int j = 0; j < nd; ++j) total += poly.radius[j] * poly.radius[(j + 1) % nd];
  double target = u.x * total, acc = 0;
  int j = 0;
  double tri = 0;
  for (; j < nd; ++j) {
    tri = poly.radius[j] * poly.radius[(j + 1) % nd];
    if (acc + tri > target || j == nd - 1) break;
    acc += tri;
  }
  const double ux = tri > 0 ? std::clamp((target - acc) / tri, 0.0, 1.0) : 0.0;
  const double s = std::sqrt(ux);
  const int j1 = (j + 1) % nd;
  const Vec2 a = dirs_[j] * poly.radius[j];
  const Vec2 b = dirs_[j1] * poly.radius[j1];
  const Vec2 local = poly.centre + (a * (1 - u.y) + b * u.y) * s;
  // Rotate from the +x film frame to the film point's azimuth.
  return PupilSample{{ca * local.x - sa * local.y, sa * local.x + ca * local.y, z_rear_mm_},
                     0.5 * total * sin_d};
}

bool ExitPupilSampler::contains(Vec2 film_mm, Vec2 rear_mm) const {
  Polygon poly;
  double ca, sa;
  if (!boundFor(film_mm, poly, ca, sa)) return false;
  // Into the +x frame, relative to the centre.
  const Vec2 q{ca * rear_mm.x + sa * rear_mm.y - poly.centre.x,
               -sa * rear_mm.x + ca * rear_mm.y - poly.centre.y};
  const int nd = directions_;
  const double dphi = 2 * std::numbers::pi / nd;
  double ang = std::atan2(q.y, q.x);
  if (ang < 0) ang += 2 * std::numbers::pi;
  const int j = std::min(static_cast<int>(ang / dphi), nd - 1);
  const Vec2 a = unit(j * dphi) * poly.radius[j];
  const Vec2 b = unit((j + 1) * dphi) * poly.radius[(j + 1) % nd];
  // Inside the fan triangle (0, a, b): on the origin's side of the edge a-b.
  return cross2(b - a, q - a) >= 0;
}

double ExitPupilSampler::area_mm2(Vec2 film_mm) const {
  Polygon poly;
  double ca, sa;
  return boundFor(film_mm, poly, ca, sa) ? polygonArea(poly) : 0.0;
}

}  // namespace lensim::optics
