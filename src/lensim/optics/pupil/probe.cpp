// The exit-pupil build's probe of the region at a film point: the margin of rear-plane points
// (batched traces), the searches for the region's boundary along directions, and the polygons
// made of their results. See optics/pupil.h for the algorithm.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

Probe::Probe(const Context& c, int sec) : ctx(c), cur{&c.lens} {
  cur.insert(cur.end(), c.opts.also_cover.begin(), c.opts.also_cover.end());
  if (!ctx.rotational) setAzimuth(sec * ctx.wedge);
}

// The margin of a rear-plane point: the ray from the film point toward it, traced without
// clipping, and the largest ratio of a hit's distance from the axis to that surface's clear
// semi-aperture (and of the point's to the rear disc's radius); infinite where the ray misses a
// surface or is totally reflected. The ray gets through (the clipped trace) exactly where the
// margin is <= 1, and the margin varies continuously across the rear plane, so that a boundary
// is found by the secant method and a sliver of region by minimising it.
// Over the lenses in `cur`: the first lens's margin; where it blocks, the least over all of them
// (the bound holds the union of their regions). An anamorphic lens's margin is the first passing
// azimuth's, tried from the one that passed last (neighbouring points usually pass there too),
// else the least over them. The traces of each lens are batched (LensTracer::marginSquaredBatch:
// the rays overlap in the processor).
void Probe::marginBatch(double h, const Vec2* a, int n, double* out) {
  constexpr int kB = LensTracer<double>::kBatch;
  const bool rotational = ctx.rotational;
  const int n_az = rotational ? 1 : static_cast<int>(az_.size());
  const int az0 = rotational ? 0 : last_az_;
  mb_val_.assign(size_t(n), kInf);
  mb_left_.resize(size_t(n));
  for (int j = 0; j < n; ++j) mb_left_[size_t(j)] = j, out[j] = kInf;
  for (int i = 0; i < n_az && !mb_left_.empty(); ++i) {
    const int kaz = (az0 + i) % n_az;
    double ca = 1, sa = 0;
    if (!rotational) ca = std::cos(az_[size_t(kaz)]), sa = std::sin(az_[size_t(kaz)]);
    const Vec2 film{h * ca, h * sa};
    mb_todo_ = mb_left_;
    for (size_t k = 0; k < cur.size() && !mb_todo_.empty(); ++k) {
      const LensSystem& L = *cur[k];
      // The first lens's margin, else the least of all lenses'.
      auto put = [&](int j, double v) {
        mb_val_[size_t(j)] = k == 0 ? v : std::min(mb_val_[size_t(j)], v);
      };
      Ray rays[kB];
      int lane[kB];
      double d2s[kB], m2[kB];
      int m = 0;
      auto flush = [&] {
        L.tracer().marginSquaredBatch(rays, m, m2);
        traces += m;
        for (int q = 0; q < m; ++q) put(lane[q], std::sqrt(std::max(d2s[q], m2[q])));
        m = 0;
      };
      for (int j : mb_todo_) {
        const Vec2 r =
            rotational ? a[j] : toFilmAzimuth(false, ctx.kappa_x, ctx.kappa_y, a[j], h, ca, sa);
        const double d2 = ctx.disc2 > 0 ? (r.x * r.x + r.y * r.y) / ctx.disc2 : 0.0;
        if (d2 > 1) {  // outside the rear disc: no trace needed
          put(j, std::sqrt(d2));
          continue;
        }
        rays[m] = L.filmPointRay(film, r), lane[m] = j, d2s[m] = d2;
        if (++m == kB) flush();
      }
      if (m > 0) flush();
      if (k == 0) std::erase_if(mb_todo_, [&](int j) { return mb_val_[size_t(j)] <= 1; });
    }
    // The first azimuth where a point passes, else the least over them.
    for (int j : mb_left_) {
      const double v = mb_val_[size_t(j)];
      if (v <= 1) {
        out[j] = v;
        if (!rotational) last_az_ = kaz;
      } else {
        out[j] = std::min(out[j], v);
      }
    }
    std::erase_if(mb_left_, [&](int j) { return out[j] <= 1; });
  }
}

double Probe::margin(double h, Vec2 a) {
  double m;
  marginBatch(h, &a, 1, &m);
  return m;
}

void Probe::settle(const EdgeSearch& e) {
  if (!e.bracketed) return;
  if (e.bracket_slope > 0) slope_hint_ = e.bracket_slope;
}

// The first blocked point along u from c, with a passing point within 1e-3 relative before it.
// From a guess (usually the neighbouring direction's distance, within a few percent), secant
// steps on the margin (started with the slope found at the last boundary) aim a hair past the
// root on the side not yet pinned, so that two or three traces usually close the bracket;
// bisection (or geometric steps while one side is open) where a secant step falls outside the
// bracket or fails to halve it.
// accept > 0: a blocked point whose margin says that the boundary lies within `accept`
// (relative) before it ends the search without a passing point next to it (one or two traces
// where the guess is good, as in the wavelength bands, whose boundaries are near the lens's
// own). It is still a blocked point, so that the region (star-shaped about c, as everywhere
// here) ends before it: the bound holds it, only the overshoot grows (up to `accept`, estimated
// from the margin's slope; an underestimate costs waste, not rays).
double Probe::boundary(double h, Vec2 c, Vec2 u, double guess, double accept, bool cover) {
  EdgeSearch e(guess, accept, ctx.rr, slope_hint_, 0.0, cover);
  while (!e.done) e.feed(margin(h, c + u * e.x));
  settle(e);
  return e.result;
}

// accept_slopes: per direction (nullptr: 0; where > 0 also the search's slope hint). The shared
// hint ends as after the searches one after another; last_slopes (if given) gets each search's
// last_slope where it ended on a bracket.
void Probe::boundaries(double h, Vec2 c, const Vec2* u, const double* guess, int count,
                       double accept, const double* accept_slopes, double* out, double* last_slopes,
                       bool cover) {
  es_.clear();
  for (int j = 0; j < count; ++j) {
    const double as = accept_slopes ? accept_slopes[j] : 0.0;
    es_.emplace_back(guess[j], accept, ctx.rr, as > 0 ? as : slope_hint_, as, cover);
  }
  for (;;) {
    es_pts_.clear(), es_lane_.clear();
    for (int j = 0; j < count; ++j)
      if (!es_[size_t(j)].done)
        es_pts_.push_back(c + u[j] * es_[size_t(j)].x), es_lane_.push_back(j);
    if (es_pts_.empty()) break;
    es_g_.resize(es_pts_.size());
    marginBatch(h, es_pts_.data(), int(es_pts_.size()), es_g_.data());
    for (size_t i = 0; i < es_lane_.size(); ++i) es_[size_t(es_lane_[i])].feed(es_g_[i]);
  }
  for (int j = 0; j < count; ++j) {
    const EdgeSearch& e = es_[size_t(j)];
    out[j] = e.result;
    settle(e);
    if (last_slopes && e.bracketed) last_slopes[j] = e.last_slope;
  }
}

// Moves c toward the middle of the region (the found point may lie near its edge, where the
// chief ray is vignetted): the centre of a coarse ring of boundary points, twice, the first
// ring's searches started at `guess`, the second's at the first ring's points. Returns the last
// ring.
std::vector<Vec2> Probe::centreRing(double h, Vec2& c, double guess) {
  constexpr int kRing = 12;
  std::vector<Vec2> ring_u, ring;
  for (int j = 0; j < kRing; ++j) ring_u.push_back(unit(2 * std::numbers::pi * j / kRing));
  std::vector<double> ring_g(kRing, guess), ring_d(kRing);
  for (int it = 0; it < 2; ++it) {
    if (!ring.empty())
      for (int j = 0; j < kRing; ++j)
        ring_g[size_t(j)] = std::max(1e-6 * ctx.rr, dot2(ring[size_t(j)] - c, ring_u[size_t(j)]));
    boundaries(h, c, ring_u.data(), ring_g.data(), kRing, 0.0, nullptr, ring_d.data(), nullptr);
    ring.clear();
    Vec2 lo_pt{1e300, 1e300}, hi_pt{-1e300, -1e300};
    for (int j = 0; j < kRing; ++j) {
      const Vec2 q = c + ring_u[size_t(j)] * ring_d[size_t(j)];
      ring.push_back(q);
      lo_pt = {std::min(lo_pt.x, q.x), std::min(lo_pt.y, q.y)};
      hi_pt = {std::max(hi_pt.x, q.x), std::max(hi_pt.y, q.y)};
    }
    const Vec2 mid = (lo_pt + hi_pt) * 0.5;
    if (!passes(h, mid)) break;
    c = mid;
  }
  return ring;
}

// Boundary points of the region at film radius h, seen from a point inside it, in `count`
// directions starting at angle `offset` (and the point, in centre_out); empty if the film point
// sees nothing. With centre_out null and a hint whose centre lies inside the region, these are
// the checks of the hint polygon, measured from its centre.
std::vector<Vec2> Probe::boundaryPoints(double h, int count, double offset, Vec2* centre_out,
                                        const Polygon* hint) {
  const int nd = ctx.nd;
  std::vector<Vec2> pts;
  std::optional<Vec2> c = findInside(h, hint);
  if (!c) return pts;
  // The checks of a polygon whose own centre lies inside the region are measured from that
  // centre, at the directions half-way between the polygon's (no ring: a third of a check's
  // traces saved).
  const bool from_hint =
      !centre_out && hint && !hint->empty && c->x == hint->centre.x && c->y == hint->centre.y;
  // The ring's searches start at the neighbouring polygon's mean size (a tenth of the rear
  // element's radius without one).
  double guess = 0.1 * ctx.rr;
  if (hint && !hint->empty) {
    guess = 0;
    for (double v : hint->radius) guess += v / nd;
  }
  std::vector<Vec2> ring;  // the last ring's boundary points
  if (!from_hint) ring = centreRing(h, *c, guess);
  if (centre_out) *centre_out = *c;
  // Each search starts at an edge along its direction u (seen from c), and all run side by
  // side: a check's at the polygon's edge, a new polygon's at its last ring's. Where an edge is
  // not crossed, one after another instead, each from the last one's distance (the checks from
  // their edge where it is crossed).
  // A check's search starts just inside the polygon's edge (by kHintAccept), and where that is
  // blocked it ends there (EdgeSearch::cover): the region ends inside the polygon along that
  // direction, and the check needs no more (an interval's or a wedge's polygon is widened past
  // the region by the safety margin, so most of its checks end so). A boundary closer to the
  // edge than that is still found, and may widen the polygon by the margin as one beyond it
  // does (the region touches the polygon there, and may reach past it between the directions).
  // Elsewhere a blocked point the margin puts within kHintAccept of the boundary ends it.
  constexpr double kHintAccept = 1e-3;
  const double accept = from_hint ? kHintAccept : 0.0;
  const bool cover = from_hint;
  std::vector<Vec2> edge;  // the polygon whose edges the searches start at
  if (from_hint)
    for (int k = 0; k < nd; ++k)
      edge.push_back(hint->centre + ctx.dirs[size_t(k)] * hint->radius[size_t(k)]);
  else
    edge = ring;
  std::vector<Vec2> us(static_cast<size_t>(count));
  std::vector<double> starts(static_cast<size_t>(count), 0.0);
  bool all = !edge.empty();
  for (int j = 0; j < count; ++j) {
    us[size_t(j)] = unit(offset + 2 * std::numbers::pi * j / count);
    if (!edge.empty())
      starts[size_t(j)] =
          farthestCrossing(edge, *c, us[size_t(j)]) * (1 + (cover ? -1.0 : 0.5) * accept);
    all = all && starts[size_t(j)] > 0;
  }
  if (all) {
    std::vector<double> d(static_cast<size_t>(count));
    boundaries(h, *c, us.data(), starts.data(), count, accept, nullptr, d.data(), nullptr, cover);
    // (A covered direction's point is the centre, which widens nothing.)
    for (int j = 0; j < count; ++j) pts.push_back(*c + us[size_t(j)] * d[size_t(j)]);
    return pts;
  }
  for (int j = 0; j < count; ++j) {
    const Vec2 u = us[size_t(j)];
    if (from_hint && starts[size_t(j)] > 0) {
      const double d = boundary(h, *c, u, starts[size_t(j)], kHintAccept, cover);
      pts.push_back(*c + u * d);
      if (d > 0) guess = d;
      continue;
    }
    guess = boundary(h, *c, u, guess);
    pts.push_back(*c + u * guess);
  }
  return pts;
}

Polygon Probe::makeNode(double h, const Polygon* hint) {
  const int nd = ctx.nd;
  Polygon poly;
  poly.r = h;
  std::vector<Vec2> pts = boundaryPoints(h, nd, 0.0, &poly.centre, hint);
  if (pts.empty()) return poly;
  poly.empty = false;
  for (const Vec2& q : pts)
    poly.radius.push_back(std::hypot(q.x - poly.centre.x, q.y - poly.centre.y));
  const std::vector<double> f =
      coverFactors(ctx, poly, boundaryPoints(h, nd, 0.5 * ctx.dphi, nullptr, &poly));
  poly.raw = poly.radius;
  poly.node_f = f;
  for (int j = 0; j < nd; ++j) poly.radius[j] *= f[j];
  return poly;
}

std::vector<double> coverFactors(const Context& ctx, const Polygon& poly,
                                 const std::vector<Vec2>& pts) {
  const int nd = ctx.nd;
  const double dphi = ctx.dphi;
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
}

double polygonArea(const Context& ctx, const Polygon& poly) {
  const int nd = ctx.nd;
  if (poly.empty) return 0.0;
  double sum = 0;
  for (int j = 0; j < nd; ++j) sum += poly.radius[j] * poly.radius[(j + 1) % nd];
  return 0.5 * sum * std::sin(ctx.dphi);
}

bool interpolateBetween(const Polygon& a, const Polygon& b, double r, Polygon& poly) {
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

}  // namespace lensim::optics::pupil
