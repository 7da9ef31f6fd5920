#include "lensim/optics/pupil.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "lensim/optics/anamorphic.h"
#include "lensim/optics/chief_ray.h"

namespace lensim::optics {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Vec2 unit(double phi) {
  return {std::cos(phi), std::sin(phi)};
}
double cross2(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}
double dot2(Vec2 a, Vec2 b) {
  return a.x * b.x + a.y * b.y;
}

// The farthest crossing t > 0 of the ray from + t u with the edges of the closed polygon
// `verts` (0 where it crosses none).
double farthestCrossing(const std::vector<Vec2>& verts, Vec2 from, Vec2 u) {
  double reach = 0;
  const size_t n = verts.size();
  for (size_t k = 0; k < n; ++k) {
    const Vec2 a = verts[k] - from, e = verts[(k + 1) % n] - verts[k];
    const double den = cross2(u, e);
    if (den == 0) continue;
    const double t = cross2(a, e) / den, v = cross2(a, u) / den;
    if (t > 0 && v >= 0 && v <= 1) reach = std::max(reach, t);
  }
  return reach;
}

// One search for the distance from a point inside a region to the region's boundary along a
// direction, on the margin (see the sampler's constructor, boundary()): a state machine, so that
// many searches can run side by side with their traces batched. `x` is the distance to evaluate
// next; feed() takes the margin there and sets the next `x`, or `done` and `result`.
struct EdgeSearch {
  static constexpr double kTol = 1e-3;
  double rr, accept, slope_hint, accept_slope;
  double f, tol_end;
  double lo = 0, glo = kInf, hi = kInf, ghi = kInf;
  double s0 = 0, g0 = kInf, s1 = 0, g1 = kInf;  // the two latest evaluations
  double last_width = kInf;
  bool force_bisect = false, first = true;
  int it = 0;
  double x = 0;
  bool done = false;
  double result = 0;
  // Where the search ended on a bracket (not given up): the margin's slope across the bracket
  // (0: none), and the latest two traces' slope (0: none).
  bool bracketed = false;
  double bracket_slope = 0, last_slope = 0;

  // cover: the search of a check (a polygon's edge is the guess, and only a boundary beyond it
  // matters): a blocked first trace there ends it with result 0 (the region, star-shaped about
  // the search's origin, ends before the edge: nothing to widen).
  bool cover = false;

  EdgeSearch(double guess, double accept_, double rr_, double slope_hint_, double accept_slope_,
             bool cover_ = false)
      : rr(rr_),
        accept(accept_),
        slope_hint(slope_hint_),
        accept_slope(accept_slope_),
        cover(cover_) {
    x = std::max(guess, 1e-6 * rr);
    // With a good guess (accept > 0) the steps while one side is open start small, and a
    // bracket as narrow as `accept` ends the search too (where the margin jumps to infinity at
    // the boundary, a ray missing a surface, it has no slope to accept by).
    f = accept > 0 ? 2 * accept : 1.0 / 16;
    tol_end = std::max(kTol, accept);
  }
  void feed(double g) {
    if (cover && first && g > 1) {
      result = 0, done = true;
      return;
    }
    s0 = s1, g0 = g1, s1 = x, g1 = g;
    if (g <= 1) {
      if (x > lo) lo = x, glo = g;
    } else if (x < hi) {
      hi = x, ghi = g;
    }
    // A secant step that does not halve the bracket twice running gives way to bisection.
    if (!first && hi < kInf && lo > 0) {
      const double w = hi - lo;
      if (w > 0.5 * last_width) force_bisect = true;
      last_width = w;
    }
    first = false;
    advance();
  }

 private:
  void finish() {
    if (std::isfinite(glo) && std::isfinite(ghi) && hi > lo && ghi > glo)
      bracket_slope = (ghi - glo) / (hi - lo);
    last_slope = std::isfinite(g0) && std::isfinite(g1) && s0 != s1 && (g1 - g0) / (s1 - s0) > 0
                     ? (g1 - g0) / (s1 - s0)
                     : 0.0;
    bracketed = true;
    result = hi;
    done = true;
  }
  void advance() {
    if (it >= 80) return finish();
    if (hi < kInf && hi - lo <= tol_end * hi) return finish();
    if (accept > 0 && hi < kInf && s1 == hi && std::isfinite(ghi)) {
      // The slope from the two latest traces along u, else the one measured along u for
      // the neighbouring wavelength (accept_slope).
      const double sl = std::isfinite(g0) && s0 != s1 ? (g1 - g0) / (s1 - s0) : accept_slope;
      if (sl > 0 && std::isfinite(sl) && ghi - 1 <= sl * accept * hi) return finish();
    }
    if (hi == kInf && lo >= 4 * rr) {  // beyond any real region: give up there
      result = lo, done = true;
      return;
    }
    if (lo == 0 && hi <= 1e-9 * rr) {  // the region has no extent along u
      result = hi, done = true;
      return;
    }
    double xn = std::numeric_limits<double>::quiet_NaN();
    bool secant = false;  // xn from the latest two evaluations
    if (!force_bisect) {
      if (std::isfinite(g0) && std::isfinite(g1) && g1 != g0 && s1 != s0)
        xn = s1 + (1 - g1) * (s1 - s0) / (g1 - g0), secant = true;
      else if (std::isfinite(g1) && slope_hint > 0)
        xn = s1 + (1 - g1) / slope_hint;
      // Aim a hair toward the bracket's far end, so that the near one stays and the far one
      // moves to within the tolerance.
      if (std::isfinite(xn)) {
        if (accept > 0)  // aim at the blocked side, within reach of acceptance
          xn += 0.3 * accept * std::abs(xn);
        else
          xn += (hi - xn <= xn - lo ? -0.4 : 0.4) * kTol * std::abs(xn);
      }
    }
    force_bisect = false;
    if (hi < kInf && lo > 0) {
      if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);
    } else if (hi < kInf) {  // nothing passing found along u yet
      // With a good guess (accept > 0) a step from one point's slope goes at most f; a secant
      // step (the margin is smooth there, often nearly flat: the guess can be off by 10-20%)
      // at most half the way to the centre.
      const bool far = accept > 0 && xn < hi / (1 + f) && !(secant && xn >= 0.5 * hi);
      if (!(xn > 0 && xn < hi) || far) xn = hi / (1 + f), f *= 2;
    } else {  // nothing blocked yet
      const bool far = accept > 0 && xn > lo * (1 + f) && !(secant && xn <= 2 * lo);
      if (!(xn > lo) || far) xn = lo * (1 + f), f *= 2;
      xn = std::min(xn, 2 * lo + 1e-6 * rr);
    }
    x = xn;
    ++it;
  }
};

}  // namespace

ExitPupilSampler::ExitPupilSampler(const LensSystem& lens, const ParaxialData& p,
                                   double film_radius_mm, const ExitPupilOptions& opts)
    : film_radius_mm_(film_radius_mm),
      rotational_(opts.rotational),
      z_rear_mm_(lens.rearVertexZ_mm()),
      directions_(std::max(8, opts.directions)) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int j = 0; j < directions_; ++j)
    dirs_.push_back(unit(2 * std::numbers::pi * j / directions_));
  const int ni = std::max(1, opts.radial_bins);
  const int nd = directions_;
  const double dphi = 2 * std::numbers::pi / nd;
  const double rr = 1.5 * lens.interfaces().back().semi_aperture_mm;

  const double disc2 = opts.rear_disc_radius_mm * opts.rear_disc_radius_mm;
  const bool obscured = lens.hasObscuration();
  // Anamorphic: the paraxial chief ray from film height h crosses the rear plane at kappa h
  // (aimed at the exit pupil's centre).
  if (!rotational_) {
    const double z_film = lens.filmZ_mm();
    auto kappa = [&](double z_xp) {
      return std::abs(z_xp - z_film) > 1e-9 ? (z_xp - z_rear_mm_) / (z_xp - z_film) : 0.0;
    };
    kappa_y_ = kappa(p.exit_pupil_z_mm);
    const AnamorphicData ad = anamorphicData(lens);
    kappa_x_ = ad.x ? kappa(ad.x->exit_pupil_z_mm) : kappa_y_;
  }
  // Anamorphic lenses are symmetric under x -> -x and y -> -y: bounds are built for film points
  // in the first quadrant, in `sectors` wedges, each covering the regions at `per` azimuths
  // across it (edges included) and checked at the azimuths half-way between those.
  // Anamorphic: a bound along each wedge edge ("sector" below), blended across the wedges.
  const int n_wedges = std::max(1, opts.sectors);
  const int n_sectors = rotational_ ? 1 : n_wedges + 1;
  const double wedge = (std::numbers::pi / 2) / n_wedges;
  // Where across a wedge its blended polygon is checked against the true region (checking at a
  // quarter and three quarters as well found nothing more in lentil:2004 at twice the traces).
  const std::vector<double> kWedgeChecks = {0.5};
  // Anamorphic on a film rectangle (ExitPupilOptions::film_half_extent_mm): each wedge edge's
  // nodes are the same film radii as over the whole film radius, up to the first at or past the
  // rectangle's farthest point at the azimuths of the edge's two wedges; each wedge's checks reach
  // the first past its own farthest point. A film point lies within both edges' reach.
  std::vector<int> sector_nodes(size_t(n_sectors), ni);  // intervals along each edge
  std::vector<double> wedge_reach(size_t(n_wedges), film_radius_mm);
  if (const Vec2 e = opts.film_half_extent_mm; !rotational_ && e.x > 0 && e.y > 0) {
    // The rectangle's farthest point at azimuths [lo, hi] (its distance grows up to the corner's
    // azimuth and falls after it).
    auto farthest = [&](double lo, double hi) {
      const double a = std::clamp(std::atan2(e.y, e.x), lo, hi);
      const double c = std::cos(a), s = std::sin(a);
      return std::min({film_radius_mm, c > 0 ? e.x / c : kInf, s > 0 ? e.y / s : kInf});
    };
    for (int sec = 0; sec < n_sectors; ++sec) {
      const double r = farthest(std::max(0, sec - 1) * wedge, std::min(n_wedges, sec + 1) * wedge);
      sector_nodes[size_t(sec)] = std::clamp(int(std::ceil(r / film_radius_mm * ni - 1e-9)), 1, ni);
    }
    for (int wdg = 0; wdg < n_wedges; ++wdg)
      wedge_reach[size_t(wdg)] = farthest(wdg * wedge, (wdg + 1) * wedge);
  }
  // Each wedge's bound is built on its own (its own azimuths); a rotational lens has one. The
  // build runs in stages whose pieces are independent, so that they run side by side (TBB; the
  // start-up budget is wall time on two cores): (0) the uniform nodes, each found from its
  // neighbour's polygon, one wedge a task; (1) each uniform interval's checks and refinement,
  // one interval a task; (2) the wavelength bands' vertex distances, a few nodes a task; (3) the
  // sampling tables (and an obscuration's hole), one wedge edge a task; (4) anamorphic: each
  // wedge's checks of its blended polygon, 8 film radii of a wedge a task. Each task starts from
  // the same state (no search hints carried over from another task), so that the bounds do not
  // depend on how the tasks are scheduled.
  struct Work {
    std::vector<Polygon> initial;               // stage 0
    std::vector<std::vector<Polygon>> refined;  // stage 1, per interval
    std::vector<std::vector<std::vector<double>>> refined_scales;
    std::vector<Polygon> done;                     // all nodes, by radius
    std::vector<std::vector<double>> scales;       // per interval
    std::vector<std::vector<Polygon>> band_nodes;  // stage 2
    std::vector<Sector> sets;                      // stage 3
  };
  std::vector<Work> work(static_cast<size_t>(n_sectors));
  // The narrowest radial interval refinement makes.
  const double min_width = film_radius_mm / (ni * 16.0);
  // Anamorphic, stage 4: per wedge, the film radii at which its blended polygon is checked (both
  // edges' nodes and interval middles), and the checks found, a task's share of the radii each.
  constexpr int kWedgeRadiiPerTask = 8;
  std::vector<std::vector<double>> wedge_radii;
  std::vector<std::vector<WedgeCheck>> wedge_parts;
  std::atomic<long> traces_total{0};
  // Past the image circle, as far as the uniform nodes tell (after stage 0): the least over the
  // wedge edges of the first empty node's radius after one that is not (the film radius if there
  // is none); film points there see nothing in that edge's direction.
  double r_ic = film_radius_mm;
  auto buildSector = [&](int sec, int stage, int k0, int k1) {
    Work& w = work[size_t(sec)];
    long traces = 0;
    std::vector<double> az;  // anamorphic: the film azimuth whose regions count
    // The margin of a rear-plane point: the ray from the film point toward it, traced without
    // clipping, and the largest ratio of a hit's distance from the axis to that surface's clear
    // semi-aperture (and of the point's to the rear disc's radius); infinite where the ray misses
    // a surface or is totally reflected. The ray gets through (the clipped trace) exactly where
    // the margin is <= 1, and the margin varies continuously across the rear plane, so that a
    // boundary is found by the secant method (a few traces) rather than by bisection (~9), and a
    // sliver of region by minimising it rather than by a blind grid.
    // The lens's margin; where it blocks, the least over the other wavelengths' lenses too (the
    // bound holds the union of their regions). <= 1 exactly where some lens lets the ray through.
    // The lenses whose regions count (the first traced first): the lens and also_cover while
    // building the lens's own bound; a band's lenses, or one of them, while re-solving a band's.
    std::vector<const LensSystem*> cur{&lens};
    cur.insert(cur.end(), opts.also_cover.begin(), opts.also_cover.end());
    // The checks of a polygon (below) use the azimuths half-way between the polygon's own, so
    // that the regions of film points between them are covered too: an anamorphic lens's margin
    // is the first passing azimuth's, tried from the one that passed last (neighbouring points
    // usually pass there too), else the least over them.
    int last_az = 0;
    // The margin at n rear-plane points for film radius h, the traces of each lens batched
    // (LensTracer::marginSquaredBatch: the rays overlap in the processor). Over several
    // azimuths all points try them from the one that passed last before the call.
    constexpr int kB = LensTracer<double>::kBatch;
    std::vector<int> mb_todo, mb_left;
    std::vector<double> mb_val;
    auto marginBatch = [&](double h, const Vec2* a, int n, double* out) {
      const int n_az = rotational_ ? 1 : static_cast<int>(az.size());
      const int az0 = rotational_ ? 0 : last_az;
      mb_val.assign(size_t(n), kInf);
      mb_left.resize(size_t(n));
      for (int j = 0; j < n; ++j) mb_left[size_t(j)] = j, out[j] = kInf;
      for (int i = 0; i < n_az && !mb_left.empty(); ++i) {
        const int kaz = (az0 + i) % n_az;
        double ca = 1, sa = 0;
        if (!rotational_) ca = std::cos(az[size_t(kaz)]), sa = std::sin(az[size_t(kaz)]);
        const Vec2 film{h * ca, h * sa};
        mb_todo = mb_left;
        for (size_t k = 0; k < cur.size() && !mb_todo.empty(); ++k) {
          const LensSystem& L = *cur[k];
          // The first lens's margin, else the least of all lenses'.
          auto put = [&](int j, double v) {
            mb_val[size_t(j)] = k == 0 ? v : std::min(mb_val[size_t(j)], v);
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
          for (int j : mb_todo) {
            const Vec2 r = rotational_ ? a[j] : toFilmAzimuth(a[j], h, ca, sa);
            const double d2 = disc2 > 0 ? (r.x * r.x + r.y * r.y) / disc2 : 0.0;
            if (d2 > 1) {  // outside the rear disc: no trace needed
              put(j, std::sqrt(d2));
              continue;
            }
            rays[m] = L.filmPointRay(film, r), lane[m] = j, d2s[m] = d2;
            if (++m == kB) flush();
          }
          if (m > 0) flush();
          if (k == 0) std::erase_if(mb_todo, [&](int j) { return mb_val[size_t(j)] <= 1; });
        }
        // The first azimuth where a point passes, else the least over them.
        for (int j : mb_left) {
          const double v = mb_val[size_t(j)];
          if (v <= 1) {
            out[j] = v;
            if (!rotational_) last_az = kaz;
          } else {
            out[j] = std::min(out[j], v);
          }
        }
        std::erase_if(mb_left, [&](int j) { return out[j] <= 1; });
      }
    };
    auto margin = [&](double h, Vec2 a) {
      double m;
      marginBatch(h, &a, 1, &m);
      return m;
    };
    auto passes = [&](double h, Vec2 a) { return margin(h, a) <= 1; };
    // Distance from c (inside the region) to the region's boundary along u: the first blocked
    // point, with a passing point within 1e-3 relative before it. From a guess (usually the
    // neighbouring direction's distance, within a few percent), secant steps on the margin
    // (started with the slope found at the last boundary) aim a hair past the root on the side
    // not yet pinned, so that two or three traces usually close the bracket; bisection (or
    // geometric steps while one side is open) where a secant step falls outside the bracket or
    // fails to halve it.
    // accept > 0: a blocked point whose margin says that the boundary lies within `accept`
    // (relative) before it ends the search without a passing point next to it (one or two traces
    // where the guess is good, as in the wavelength bands, whose boundaries are near the lens's
    // own). It is still a blocked point, so that the region (star-shaped about c, as everywhere
    // here) ends before it: the bound holds it as before, only the overshoot grows (up to
    // `accept`, estimated from the margin's slope; an underestimate costs waste, not rays).
    double slope_hint = 0;    // d(margin)/ds at the last boundary
    double accept_slope = 0;  // accept > 0: d(margin)/ds along u measured before, or 0
    double last_slope = 0;    // the last search's latest two traces' slope (0: none)
    auto settle = [&](const EdgeSearch& e) {
      if (!e.bracketed) return;
      if (e.bracket_slope > 0) slope_hint = e.bracket_slope;
      last_slope = e.last_slope;
    };
    auto boundary = [&](double h, Vec2 c, Vec2 u, double guess, double accept = 0,
                        bool cover = false) {
      EdgeSearch e(guess, accept, rr, slope_hint, accept_slope, cover);
      while (!e.done) e.feed(margin(h, c + u * e.x));
      settle(e);
      return e.result;
    };
    // boundary() along `count` directions u[j] from c at once (guesses guess[j]): the searches
    // run side by side, each round's traces batched. accept_slopes: per direction (nullptr: 0;
    // where > 0 also the search's slope hint). The shared hints end as after the searches one
    // after another; last_slopes (if given) gets each search's last_slope where it ended on a
    // bracket.
    std::vector<EdgeSearch> es;
    std::vector<Vec2> es_pts;
    std::vector<int> es_lane;
    std::vector<double> es_g;
    auto boundaries = [&](double h, Vec2 c, const Vec2* u, const double* guess, int count,
                          double accept, const double* accept_slopes, double* out,
                          double* last_slopes, bool cover = false) {
      es.clear();
      for (int j = 0; j < count; ++j) {
        const double as = accept_slopes ? accept_slopes[j] : 0.0;
        es.emplace_back(guess[j], accept, rr, as > 0 ? as : slope_hint, as, cover);
      }
      for (;;) {
        es_pts.clear(), es_lane.clear();
        for (int j = 0; j < count; ++j)
          if (!es[size_t(j)].done)
            es_pts.push_back(c + u[j] * es[size_t(j)].x), es_lane.push_back(j);
        if (es_pts.empty()) break;
        es_g.resize(es_pts.size());
        marginBatch(h, es_pts.data(), int(es_pts.size()), es_g.data());
        for (size_t i = 0; i < es_lane.size(); ++i) es[size_t(es_lane[i])].feed(es_g[i]);
      }
      for (int j = 0; j < count; ++j) {
        const EdgeSearch& e = es[size_t(j)];
        out[j] = e.result;
        settle(e);
        if (last_slopes && e.bracketed) last_slopes[j] = e.last_slope;
      }
    };
    // Boundary points of the region at film radius h, seen from a point inside it, in `count`
    // directions starting at angle `offset`. Empty if the film point sees nothing.
    // A point inside the region at film radius h: the neighbour's centre or the real chief ray,
    // else (near the edge of the image circle, where the region is tiny) the least margin around
    // a neighbour's polygon: the best point of a coarse grid, then a pattern search.
    auto findInside = [&](double h, const Polygon* hint) -> std::optional<Vec2> {
      // The neighbouring polygon's centre usually lies inside; the real chief ray's search costs
      // many traces.
      if (hint && !hint->empty && passes(h, hint->centre)) return hint->centre;
      // passingRearAim (the real chief ray, then grids over the whole exit pupil and rear
      // element: up to ~2,600 traces of the lens's own, at film azimuth 0): for an anamorphic
      // lens only without a neighbouring polygon to search about (below), since it solves for
      // azimuth 0. A rotationally symmetric lens keeps it: without it the bound's edge at the
      // image circle moves out a little (lentil:0014 on the 36x24 film: 4.7% -> 5.2% of its
      // samples wasted) for ~20% of its start-up.
      const bool near = hint && !hint->empty;
      std::optional<Vec2> c;
      if (rotational_ || !near) c = passingRearAim(lens, p, h);
      if (c && passes(h, *c)) return c;
      if (!near) return std::nullopt;
      const double reach = 1.5 * *std::max_element(hint->radius.begin(), hint->radius.end());
      // The margin on a coarse grid; then pattern searches from its three least points (the
      // region can be a thin crescent whose least margin lies off one search's path).
      // The grids' points are traced a batch at a time, in order; the first passing point found
      // is returned.
      auto grid = [&](int n, std::vector<std::pair<double, Vec2>>* margins) -> std::optional<Vec2> {
        Vec2 pts[kB];
        double g[kB];
        for (int k0 = 0; k0 < n * n; k0 += kB) {
          const int m = std::min(kB, n * n - k0);
          for (int i = 0; i < m; ++i) {
            const int ix = (k0 + i) % n, iy = (k0 + i) / n;
            pts[i] = hint->centre +
                     Vec2{reach * (2.0 * (ix + 0.5) / n - 1), reach * (2.0 * (iy + 0.5) / n - 1)};
          }
          marginBatch(h, pts, m, g);
          for (int i = 0; i < m; ++i) {
            if (g[i] <= 1) return pts[i];
            if (margins) margins->push_back({g[i], pts[i]});
          }
        }
        return std::nullopt;
      };
      constexpr int kGrid = 9;
      std::vector<std::pair<double, Vec2>> starts;
      if (std::optional<Vec2> a = grid(kGrid, &starts)) return a;
      std::partial_sort(starts.begin(), starts.begin() + 3, starts.end(),
                        [](const auto& x, const auto& y) { return x.first < y.first; });
      double g_least = kInf;
      for (int st = 0; st < 3 && std::isfinite(starts[size_t(st)].first); ++st) {
        auto [g_best, best] = starts[size_t(st)];
        // The margin is the largest of a few smooth functions (one per limiting surface): its
        // minimum often lies on a ridge where two of them are equal, so the search tries 16
        // directions before halving its step.
        constexpr int kDirs = 16, kGroup = 8;
        double step = reach / kGrid;
        for (int it = 0; it < 400 && step > 1e-4 * reach; ++it) {
          bool moved = false;
          double rise = 0;  // the most the margin rose over the probes around `best`
          // The probes are traced kGroup at a time (batched); taken in order as one at a time
          // (the first passing probe, else the first that goes down), so that the traces past
          // it are the price of the batch.
          for (int k0 = 0; k0 < kDirs && !moved; k0 += kGroup) {
            Vec2 qs[kGroup];
            double gs[kGroup];
            for (int i = 0; i < kGroup; ++i)
              qs[i] = best + unit(2 * std::numbers::pi * (k0 + i) / kDirs) * step;
            marginBatch(h, qs, kGroup, gs);
            for (int i = 0; i < kGroup; ++i) {
              const double g = gs[i];
              if (g <= 1) return qs[i];
              if (g < g_best) {
                // A descent too slow to reach 1 within the iterations left (even at twice the
                // pace) ends the search where it would have ended anyway.
                const double fell = g_best - g;
                best = qs[i], g_best = g, moved = true;
                if (g_best - 1 > 2 * (400 - it) * fell) it = 400;
                break;
              }
              rise = std::max(rise, g - g_best);
            }
          }
          if (moved) continue;
          // No probe went down: the least margin near `best` lies within a step of it, and the
          // margin changes by about `rise` over a step; where that cannot bring it down to 1 (by
          // twice over), smaller steps cannot either: this start has no passing point near it.
          if (step < reach / (4 * kGrid) && g_best - 1 > 2 * rise) break;
          step *= 0.5;
        }
        g_least = std::min(g_least, g_best);
      }
      // Against the rear disc's hard edge the crescent can be thinner still: where the margin
      // came within 2% of passing, a fine grid as well (fine enough to find slivers a hundredth of
      // the neighbour's size), as the bounds of the CS348B set-ups need (tests/optics_pupil_test).
      if (disc2 == 0 || g_least > 1.02) return std::nullopt;
      for (int n : {24, 96})
        if (std::optional<Vec2> a = grid(n, nullptr)) return a;
      return std::nullopt;
    };
    auto boundaryPoints = [&](double h, int count, double offset, Vec2* centre_out,
                              const Polygon* hint) {
      std::vector<Vec2> pts;
      std::optional<Vec2> c = findInside(h, hint);
      if (!c) return pts;
      // Move toward the middle of the region (the found point may lie near its edge, where the
      // chief ray is vignetted): the centre of a coarse ring of boundary points, twice. Not for
      // the check points of a polygon whose own centre lies inside the region: they are measured
      // from that centre, at the directions half-way between the polygon's (a third of a check's
      // traces saved).
      const bool from_hint =
          !centre_out && hint && !hint->empty && c->x == hint->centre.x && c->y == hint->centre.y;
      // The ring's searches start at the neighbouring polygon's mean size (a tenth of the rear
      // element's radius without one), the second ring's at the first ring's points.
      double guess = 0.1 * rr;
      if (hint && !hint->empty) {
        guess = 0;
        for (double v : hint->radius) guess += v / nd;
      }
      constexpr int kRing = 12;
      std::vector<Vec2> ring_u, ring;  // the last ring's boundary points
      for (int j = 0; j < kRing; ++j) ring_u.push_back(unit(2 * std::numbers::pi * j / kRing));
      std::vector<double> ring_g(kRing, guess), ring_d(kRing);
      for (int it = 0; it < (from_hint ? 0 : 2); ++it) {
        if (!ring.empty())
          for (int j = 0; j < kRing; ++j)
            ring_g[size_t(j)] = std::max(1e-6 * rr, dot2(ring[size_t(j)] - *c, ring_u[size_t(j)]));
        boundaries(h, *c, ring_u.data(), ring_g.data(), kRing, 0.0, nullptr, ring_d.data(),
                   nullptr);
        ring.clear();
        Vec2 lo_pt{1e300, 1e300}, hi_pt{-1e300, -1e300};
        for (int j = 0; j < kRing; ++j) {
          const Vec2 q = *c + ring_u[size_t(j)] * ring_d[size_t(j)];
          ring.push_back(q);
          lo_pt = {std::min(lo_pt.x, q.x), std::min(lo_pt.y, q.y)};
          hi_pt = {std::max(hi_pt.x, q.x), std::max(hi_pt.y, q.y)};
        }
        const Vec2 mid = (lo_pt + hi_pt) * 0.5;
        if (!passes(h, mid)) break;
        c = mid;
      }
      if (centre_out) *centre_out = *c;
      // Each search starts at an edge along its direction u (seen from c), and all run side by
      // side: the checks of a neighbouring polygon from its centre at that polygon's edge (the
      // region's boundary is usually within a percent of it; a blocked point the margin puts
      // within kHintAccept of the boundary ends the search), a new polygon's searches at its
      // last ring's edge. Where an edge is not crossed, one after another instead, each from
      // the last one's distance (the checks from their edge where it is crossed).
      // A check's search starts just inside the polygon's edge (by kHintAccept), and where that
      // is blocked it ends there (EdgeSearch::cover): the region ends inside the polygon along
      // that direction, and the check needs no more (one trace instead of a search for the
      // boundary: an interval's or a wedge's polygon is widened past the region by the safety
      // margin, so most of its checks end so). A boundary closer to the edge than that is still
      // found, and may widen the polygon by the margin as one beyond it does, as the searches
      // from just past the edge did before (the region touches the polygon there, and may reach
      // past it between the directions: starting half as far inside, the toroidal anamorphic
      // lost a ray at 0.62 of its farthest film radius instead of 0.70).
      constexpr double kHintAccept = 1e-3;
      const double accept = from_hint ? kHintAccept : 0.0;
      const bool cover = from_hint;
      std::vector<Vec2> edge;  // the polygon whose edges the searches start at
      if (from_hint)
        for (int k = 0; k < nd; ++k)
          edge.push_back(hint->centre + dirs_[size_t(k)] * hint->radius[size_t(k)]);
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
        boundaries(h, *c, us.data(), starts.data(), count, accept, nullptr, d.data(), nullptr,
                   cover);
        // (A covered direction's point is the centre, which widens nothing.)
        for (int j = 0; j < count; ++j) pts.push_back(*c + us[size_t(j)] * d[size_t(j)]);
        return pts;
      }
      for (int j = 0; j < count; ++j) {
        const Vec2 u = us[size_t(j)];
        if (from_hint && starts[size_t(j)] > 0) {
          accept_slope = 0;
          const double d = boundary(h, *c, u, starts[size_t(j)], kHintAccept, cover);
          pts.push_back(*c + u * d);
          if (d > 0) guess = d;
          continue;
        }
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

    // Boundary points that check a polygon (at the film azimuth being built).
    auto checkPoints = [&](double h, double offset, const Polygon* hint) {
      return boundaryPoints(h, nd, offset, nullptr, hint);
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
      const std::vector<double> f = coverFactors(poly, checkPoints(h, 0.5 * dphi, &poly));
      poly.raw = poly.radius;
      poly.node_f = f;
      for (int j = 0; j < nd; ++j) poly.radius[j] *= f[j];
      return poly;
    };
    auto area = [&](const Polygon& poly) {
      if (poly.empty) return 0.0;
      double sum = 0;
      for (int j = 0; j < nd; ++j) sum += poly.radius[j] * poly.radius[(j + 1) % nd];
      return 0.5 * sum * std::sin(dphi);
    };

    // Uniform nodes first; then each interval is checked half-way: the interpolated polygon must
    // contain the true region there. Where it would have to grow by more than a few percent, or
    // the region changes fast (at the edge of the image circle), the interval is split.
    if (!rotational_) {
      // The wedge edge's azimuth (a wedge's checks, stage 4, set their own).
      az = {sec * wedge};
      last_az = 0;
    }
    if (stage == 0) {
      // Past the edge of the image circle (two nodes in a row found empty after one that was
      // not), the nodes farther out are empty without a search: film points beyond the image
      // circle see nothing (as fieldOfView's image circle and the empty intervals between empty
      // nodes assume), and the search for a region about no neighbouring polygon
      // (passingRearAim's grids, thousands of traces a node) cost lentil:2001 (a 3.9 mm image
      // circle) more on the 36x24 film than the rest of its bound.
      bool seen = false;
      int empty_run = 0;
      for (int k = 0; k <= sector_nodes[size_t(sec)]; ++k) {
        const double h = film_radius_mm * k / ni;
        if (seen && empty_run >= 2) {
          Polygon none;
          none.r = h;
          w.initial.push_back(none);
          continue;
        }
        w.initial.push_back(makeNode(h, k > 0 ? &w.initial.back() : nullptr));
        seen = seen || !w.initial.back().empty;
        empty_run = w.initial.back().empty ? empty_run + 1 : 0;
      }
      traces_total += traces;
      return;
    }
    if (stage == 1) {
      // The uniform interval k0: its nodes after its left end, and each sub-interval's scales.
      std::vector<Polygon>& done = w.refined[size_t(k0)];
      std::vector<std::vector<double>>& scales = w.refined_scales[size_t(k0)];
      std::vector<Polygon> stack{
          w.initial[size_t(k0) + 1]};  // right ends still to process, nearest last
      Polygon left = w.initial[size_t(k0)];
      while (!stack.empty()) {
        Polygon right = stack.back();
        const double h = 0.5 * (left.r + right.r);
        Polygon interp;
        const bool any = interpolateBetween(left, right, h, interp);
        std::vector<double> f(nd, 1.0);
        bool split = false;
        if (any) {
          f = coverFactors(interp, checkPoints(h, 0.25 * dphi, &interp));
          const double worst = *std::max_element(f.begin(), f.end());
          const double a0 = area(left), a1 = area(right);
          // Where the region's area changes fast, interpolation wastes samples: split. Not
          // beyond the image circle, whose samples the waste budget leaves out, and where the
          // region shrinks to nothing at the edge (the splits there cost the toroidal anamorphic
          // on 36x24 an eighth of its traces for 11.37% of the film's samples wasted instead of
          // 11.35%); an interval the checks would widen by over 3%, or the one where the
          // region vanishes, is split all the same.
          const bool fast = left.empty != right.empty ||
                            (left.r < r_ic && std::max(a0, a1) > 1.25 * std::min(a0, a1));
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
            const std::vector<double> g = coverFactors(at, checkPoints(ht, 0.25 * dphi, &at));
            for (int j = 0; j < nd; ++j) f[j] = std::max(f[j], g[j]);
          }
        }
        // Where the region vanishes (the edge of the image circle) it changes shape fastest: triple
        // the margin there.
        // Anamorphic bounds cover several azimuths' regions at once and change shape faster: a
        // wider margin.
        const double base_margin = opts.margin;
        const double margin = left.empty != right.empty ? 3 * base_margin : base_margin;
        for (double& v : f) v *= 1 + margin;
        scales.push_back(std::move(f));
        done.push_back(right);
        stack.pop_back();
        left = right;
      }
      traces_total += traces;
      return;
    }  // stage 1
    if (stage == 4) {
      // Anamorphic: wedge `sec`'s blended polygon checked against the true region at its middle
      // azimuth, at both edges' nodes and interval middles; the factors that widen it to hold the
      // boundary points found, with the safety margin.
      // Radii k0 .. k1 - 1 of the wedge's (each check is independent of the others).
      // Filled on the side: blended() must give the unwidened polygon while checking.
      WedgeCheck wc;
      std::vector<double> R(static_cast<size_t>(nd));
      for (int k = k0; k < k1; ++k) {
        const double h = wedge_radii[size_t(sec)][size_t(k)];
        Polygon poly;
        poly.r = h;
        std::vector<double> f(size_t(nd), 1.0);
        for (double sw : kWedgeChecks) {
          if (!blended(0, sec, h, sw, poly.centre, R.data())) continue;
          az = {(sec + sw) * wedge};
          last_az = 0;
          poly.empty = false;
          poly.radius = R;
          // At a quarter and three quarters of the way between the polygon's directions: one
          // search for a point inside the region (not one per set of directions).
          const std::vector<double> g =
              coverFactors(poly, boundaryPoints(h, 2 * nd, 0.25 * dphi, nullptr, &poly));
          for (int j = 0; j < nd; ++j) f[size_t(j)] = std::max(f[size_t(j)], g[size_t(j)]);
        }
        for (double& v : f)
          if (v > 1) v *= 1 + opts.margin;
        wc.r.push_back(h);
        wc.f.push_back(std::move(f));
      }
      wedge_parts[size_t(sec)][size_t(k0 / kWedgeRadiiPerTask)] = std::move(wc);
      traces_total += traces;
      return;
    }
    const std::vector<Polygon>& done = w.done;
    auto makeSector = [&](const std::vector<Polygon>& nodes) {
      Sector out;
      out.intervals = buildIntervals(nodes, w.scales);
      // Central obscurations: a hole in each interval's polygon (rotationally symmetric lenses).
      if (obscured && rotational_) {
        auto passesAll = [&](double h, Vec2 a) {  // with obscurations, at any wavelength covered
          ++traces;
          if (lens.traceFromFilmPoint({h, 0}, a).ok()) return true;
          for (const LensSystem* other : opts.also_cover) {
            ++traces;
            if (other->traceFromFilmPoint({h, 0}, a).ok()) return true;
          }
          return false;
        };
        // Along each direction of the polygon (centre c, vertex distances R): the distance from
        // the centre to the first passing point (the edge of the blocked middle), a 16th of the
        // vertex distance at a time, then bisected to a 1024th. All zero where the centre itself
        // passes (no blocked middle there).
        auto holeDistances = [&](double h, Vec2 c, const std::vector<double>& R) {
          std::vector<double> d(size_t(nd), 0.0);
          if (passesAll(h, c)) return d;
          for (int j = 0; j < nd; ++j) {
            constexpr int kSteps = 16;
            double lo = 0, hi = 1;
            for (int s = 1; s <= kSteps; ++s) {
              const double f = double(s) / kSteps;
              if (passesAll(h, c + dirs_[size_t(j)] * (R[size_t(j)] * f))) {
                hi = f;
                break;
              }
              lo = f;
            }
            for (int it = 0; it < 6 && hi < 1; ++it) {
              const double mid = 0.5 * (lo + hi);
              (passesAll(h, c + dirs_[size_t(j)] * (R[size_t(j)] * mid)) ? hi : lo) = mid;
            }
            d[size_t(j)] = lo * R[size_t(j)];
          }
          return d;
        };
        for (Interval& iv : out.intervals) {
          if (iv.empty) continue;
          auto at = [&](double t, Vec2& c, std::vector<double>& R) {
            c = iv.c0 * (1 - t) + iv.c1 * t;
            R.resize(size_t(nd));
            for (int j = 0; j < nd; ++j)
              R[size_t(j)] = iv.A[size_t(j)] * (1 - t) + iv.B[size_t(j)] * t;
            return iv.r0 + t * (iv.r1 - iv.r0);
          };
          Vec2 c;
          std::vector<double> R;
          std::vector<double> d[3];
          bool any = true;
          for (int e = 0; e < 3 && any; ++e) {
            d[e] = holeDistances(at(0.5 * e, c, R), c, R);
            any = *std::max_element(d[e].begin(), d[e].end()) > 0;
          }
          if (!any) continue;
          // The hole's vertex distances at the ends: each no farther than the blocked middle's edge
          // at its end and (so that the interpolated hole lies inside at the middle too) at the
          // middle; pulled in by the safety margin.
          const double pull = 1 - opts.margin;
          std::vector<double> HA(static_cast<size_t>(nd)), HB(static_cast<size_t>(nd));
          for (int j = 0; j < nd; ++j) {
            HA[size_t(j)] = std::min(d[0][size_t(j)], d[1][size_t(j)]) * pull;
            HB[size_t(j)] = std::min(d[2][size_t(j)], d[1][size_t(j)]) * pull;
          }
          // Check the hole between the ends: every vertex of the hole and the middle of every edge
          // blocked; else shrink it.
          double k = 1;
          for (int tries = 0; tries < 4; ++tries) {
            bool ok = true;
            for (double t : {0.25, 0.75}) {
              const double h = at(t, c, R);
              for (int j = 0; j < nd && ok; ++j) {
                const int j1 = (j + 1) % nd;
                const Vec2 a =
                    dirs_[size_t(j)] * (k * (HA[size_t(j)] * (1 - t) + HB[size_t(j)] * t));
                const Vec2 b =
                    dirs_[size_t(j1)] * (k * (HA[size_t(j1)] * (1 - t) + HB[size_t(j1)] * t));
                ok = !passesAll(h, c + a) && !passesAll(h, c + (a + b) * 0.5);
              }
            }
            if (ok) break;
            k = tries < 3 ? k * 0.8 : 0.0;
          }
          if (!(k > 0)) continue;
          for (int j = 0; j < nd; ++j) HA[size_t(j)] *= k, HB[size_t(j)] *= k;
          // The fan's prefix sums count the polygon minus the hole.
          for (int j = 0; j < nd; ++j) {
            const int j1 = (j + 1) % nd;
            double* p = &iv.P[3 * size_t(j)];
            p[3] = p[0] + iv.A[size_t(j)] * iv.A[size_t(j1)] - HA[size_t(j)] * HA[size_t(j1)];
            p[4] = p[1] + iv.A[size_t(j)] * iv.B[size_t(j1)] + iv.B[size_t(j)] * iv.A[size_t(j1)] -
                   HA[size_t(j)] * HB[size_t(j1)] - HB[size_t(j)] * HA[size_t(j1)];
            p[5] = p[2] + iv.B[size_t(j)] * iv.B[size_t(j1)] - HB[size_t(j)] * HB[size_t(j1)];
          }
          iv.HA = std::move(HA);
          iv.HB = std::move(HB);
        }
      }
      // A table from film radius to the first interval that can hold it, so that a lookup is a
      // table read and a step or two instead of a binary search.
      if (!out.intervals.empty() && film_radius_mm_ > 0) {
        constexpr int kLut = 512;
        std::vector<int> lut(kLut + 1);
        for (int k = 0; k <= kLut; ++k)
          lut[size_t(k)] = intervalIn(out.intervals, {}, 0, film_radius_mm_ * k / kLut);
        out.lut_scale = kLut / film_radius_mm_;
        out.lut = std::move(lut);
      }
      return out;
    };
    if (stage == 3) {
      w.sets.push_back(makeSector(done));
      for (const std::vector<Polygon>& nodes : w.band_nodes) w.sets.push_back(makeSector(nodes));
      traces_total += traces;
      return;
    }
    // Stage 2: the bands' nodes k0 .. k1 - 1.
    // Wavelength bands: the same nodes, each vertex distance the farthest of the band's lenses'
    // boundaries along the vertex's direction from the node's centre (each lens's region is
    // star-shaped about it, so that this is the union's), each from the lens's own distance (two
    // or three traces), times the node's own check factors; the intervals keep their widening.
    // Where the centre lies outside one of the band's regions, or where the lens's region is
    // empty next to one that is not (the edge of the image circle moves with the wavelength),
    // the union's polygon is traced from scratch.
    // Each lens's distances once per node (neighbouring bands share their edge's lens), each
    // started from the last lens's (the bands' lenses come in order of wavelength).
    std::vector<const LensSystem*> band_lens;
    for (const std::vector<const LensSystem*>& band : opts.bands)
      for (const LensSystem* L : band)
        if (std::find(band_lens.begin(), band_lens.end(), L) == band_lens.end())
          band_lens.push_back(L);
    std::vector<std::vector<double>> dist(band_lens.size());
    std::vector<char> inside(band_lens.size());
    // The band lenses found to see nothing at a node of this task: at its farther nodes they see
    // nothing either (past the edge of their image circle, as stage 0 takes the lens's own), so
    // that the search that finds a region empty (a grid and pattern searches, ~400 traces) runs
    // once per lens and task rather than at every node of the zone where the edge of the image
    // circle moves with the wavelength (the toroidal anamorphic on 36x24: up to 16 nodes).
    std::vector<char> seen_empty(band_lens.size(), 0);
    for (size_t k = size_t(k0); k < size_t(k1) && !opts.bands.empty(); ++k) {
      const Polygon& base = done[k];
      const double h = base.r;
      if (!base.empty) {
        // Each vertex distance is predicted from the distances already known at this node (the
        // lens's own, and the band lenses' solved before), linearly in 1/lambda^2 through the two
        // nearest wavelengths, and accepted from one blocked trace where the margin puts the
        // boundary within kBandAccept before it (boundary(): still a blocked point, so that no
        // passing ray falls outside; the overshoot is at most ~0.2% of the distance).
        constexpr double kBandAccept = 2e-3;
        auto x_of = [](const LensSystem& L) { return 1 / (L.wavelength_nm() * L.wavelength_nm()); };
        std::vector<std::pair<double, const std::vector<double>*>> known{{x_of(lens), &base.raw}};
        std::vector<double> slopes(size_t(nd), 0.0), pred(size_t(nd), 0.0);
        // Nearest the lens's own wavelength first, so that each prediction is a short step.
        std::vector<size_t> order(band_lens.size());
        for (size_t i = 0; i < order.size(); ++i) order[i] = i;
        std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
          return std::abs(x_of(*band_lens[a]) - x_of(lens)) <
                 std::abs(x_of(*band_lens[b]) - x_of(lens));
        });
        for (size_t i : order) {
          cur = {band_lens[i]};
          inside[i] = passes(h, base.centre);
          dist[i].assign(size_t(nd), 0.0);
          if (!inside[i]) continue;
          const double xi = x_of(*band_lens[i]);
          std::sort(known.begin(), known.end(), [&](const auto& a, const auto& b) {
            return std::abs(a.first - xi) < std::abs(b.first - xi);
          });
          for (int j = 0; j < nd; ++j) {
            const double da = (*known[0].second)[size_t(j)];
            double d = da;
            if (known.size() > 1 && known[1].first != known[0].first) {
              const double db = (*known[1].second)[size_t(j)];
              d = da + (db - da) * (xi - known[0].first) / (known[1].first - known[0].first);
              d = std::clamp(d, 0.5 * da, 2 * da);
            }
            pred[size_t(j)] = d;
          }
          for (double& v : pred) v *= 1 + 0.5 * kBandAccept;
          std::vector<double> ls = slopes;
          boundaries(h, base.centre, dirs_.data(), pred.data(), nd, kBandAccept, slopes.data(),
                     dist[i].data(), ls.data());
          for (int j = 0; j < nd; ++j)
            if (ls[size_t(j)] > 0) slopes[size_t(j)] = ls[size_t(j)];
          known.push_back({xi, &dist[i]});
        }
      }
      // Where a band's lens has no distances about the node's centre (the centre lies outside
      // its region, or the lens's own region is empty here: near the edge of the image circle,
      // which moves with the wavelength), that lens's polygon is traced from scratch, once per
      // node (neighbouring bands share their edge's lens), or found empty. A band is then the
      // union of its lenses' polygons: empty, the one polygon that is not, or the farthest of
      // the distances about the node's centre; only a band whose lenses' regions lie about
      // different centres is traced from scratch as a union.
      const Polygon* hint = !base.empty                                 ? &base
                            : k > 0 && !done[k - 1].empty               ? &done[k - 1]
                            : k + 1 < done.size() && !done[k + 1].empty ? &done[k + 1]
                                                                        : nullptr;
      // Per band lens: 0 not yet traced, 1 distances about the node's centre (dist), 2 empty,
      // 3 a polygon of its own (own[i]).
      std::vector<char> state(band_lens.size(), 0);
      std::vector<Polygon> own(band_lens.size());
      // The node's check factors, which every band polygon traced here takes over.
      auto nodeF = [&](int j) { return base.empty ? 1.0 : base.node_f[size_t(j)]; };
      // The polygon of the union of the band lenses `lenses` (indices), from `from`.
      auto scratch = [&](const std::vector<size_t>& lenses, const Polygon* from) {
        Polygon np;
        np.r = h;
        if (!from) return np;
        cur.clear();
        for (size_t i : lenses) cur.push_back(band_lens[i]);
        const std::vector<Vec2> pts = boundaryPoints(h, nd, 0.0, &np.centre, from);
        if (pts.empty()) return np;
        np.empty = false;
        for (int j = 0; j < nd; ++j) {
          const Vec2 q = pts[size_t(j)];
          np.radius.push_back(std::hypot(q.x - np.centre.x, q.y - np.centre.y) * nodeF(j));
        }
        return np;
      };
      auto lensState = [&](size_t i) {
        if (state[i] == 0) {
          if (!base.empty && inside[i]) {
            state[i] = 1;
          } else {
            // From the nearest wavelength's polygon of its own where there is one (its centre
            // usually lies inside this lens's region too).
            const Polygon* from = hint;
            for (size_t d = 1; d < band_lens.size() && from == hint; ++d)
              for (size_t n : {i - d, i + d})
                if (n < band_lens.size() && state[n] == 3) {
                  from = &own[n];
                  break;
                }
            if (!seen_empty[i]) own[i] = scratch(std::vector<size_t>{i}, from);
            state[i] = seen_empty[i] || own[i].empty ? 2 : 3;
            seen_empty[i] = state[i] == 2;
          }
        }
        return state[i];
      };
      for (size_t b = 0; b < opts.bands.size(); ++b) {
        const std::vector<const LensSystem*>& band = opts.bands[b];
        Polygon& node = w.band_nodes[b][k];
        if (band.empty()) continue;
        std::vector<size_t> about_centre, own_poly, seeing;  // indices into band_lens
        for (const LensSystem* L : band) {
          const size_t i =
              size_t(std::find(band_lens.begin(), band_lens.end(), L) - band_lens.begin());
          const char st = lensState(i);
          if (st == 1) about_centre.push_back(i);
          if (st == 3) own_poly.push_back(i);
          if (st != 2) seeing.push_back(i);
        }
        if (seeing.empty()) {
          node = Polygon{};
          node.r = h;
        } else if (own_poly.empty()) {
          node = base;
          for (int j = 0; j < nd; ++j) {
            double d = 0;
            for (size_t i : about_centre) d = std::max(d, dist[i][size_t(j)]);
            node.radius[size_t(j)] = d * base.node_f[size_t(j)];
          }
        } else if (seeing.size() == 1) {
          node = own[own_poly[0]];
        } else {
          // Lenses that see something about different centres: about the centre of one's own
          // polygon, where the others' regions hold it too (the union is star-shaped about it),
          // the farthest of their distances; else the union traced from scratch.
          bool done_union = false;
          for (size_t a : own_poly) {
            const Polygon& pa = own[a];
            std::vector<double> far = pa.radius;
            bool ok = true;
            for (size_t i : seeing) {
              if (i == a) continue;
              cur = {band_lens[i]};
              if (!passes(h, pa.centre)) {
                ok = false;
                break;
              }
              // From this polygon's own distances (the other lens's region is much like it).
              std::vector<double> g(static_cast<size_t>(nd)), d(static_cast<size_t>(nd));
              for (int j = 0; j < nd; ++j) g[size_t(j)] = pa.radius[size_t(j)] / nodeF(j);
              boundaries(h, pa.centre, dirs_.data(), g.data(), nd, 0.0, nullptr, d.data(), nullptr);
              for (int j = 0; j < nd; ++j)
                far[size_t(j)] = std::max(far[size_t(j)], d[size_t(j)] * nodeF(j));
            }
            if (!ok) continue;
            node = pa;
            node.radius = far;
            done_union = true;
            break;
          }
          if (!done_union) node = scratch(seeing, hint);
        }
      }
    }
    traces_total += traces;
  };  // buildSector
  // The stages: each a list of (wedge, stage, k0, k1) tasks.
  auto runStage = [&](const std::vector<std::array<int, 4>>& tasks) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tasks.size(), 1),
                      [&](const tbb::blocked_range<size_t>& range) {
                        for (size_t i = range.begin(); i != range.end(); ++i)
                          buildSector(tasks[i][0], tasks[i][1], tasks[i][2], tasks[i][3]);
                      });
  };
  std::vector<std::array<int, 4>> tasks;
  for (int sec = 0; sec < n_sectors; ++sec) tasks.push_back({sec, 0, 0, 0});
  runStage(tasks);
  tasks.clear();
  for (const Work& w : work)
    for (size_t k = 1; k < w.initial.size(); ++k)
      if (w.initial[k].empty && !w.initial[k - 1].empty) {
        r_ic = std::min(r_ic, w.initial[k].r);
        break;
      }
  for (int sec = 0; sec < n_sectors; ++sec) {
    const int nk = sector_nodes[size_t(sec)];
    work[size_t(sec)].refined.assign(size_t(nk), {});
    work[size_t(sec)].refined_scales.assign(size_t(nk), {});
    for (int k = 0; k < nk; ++k) tasks.push_back({sec, 1, k, k + 1});
  }
  runStage(tasks);
  tasks.clear();
  constexpr int kBandNodesPerTask = 8;
  for (int sec = 0; sec < n_sectors; ++sec) {
    Work& w = work[size_t(sec)];
    w.done = {w.initial[0]};
    for (int k = 0; k < sector_nodes[size_t(sec)]; ++k) {
      w.done.insert(w.done.end(), w.refined[size_t(k)].begin(), w.refined[size_t(k)].end());
      w.scales.insert(w.scales.end(), w.refined_scales[size_t(k)].begin(),
                      w.refined_scales[size_t(k)].end());
    }
    w.band_nodes.assign(opts.bands.size(), w.done);
    const int n = static_cast<int>(w.done.size());
    if (!opts.bands.empty())
      for (int k = 0; k < n; k += kBandNodesPerTask)
        tasks.push_back({sec, 2, k, std::min(n, k + kBandNodesPerTask)});
  }
  runStage(tasks);
  tasks.clear();
  for (int sec = 0; sec < n_sectors; ++sec) tasks.push_back({sec, 3, 0, 0});
  runStage(tasks);
  tasks.clear();
  sets_.assign(work[0].sets.size(), {});
  for (Work& w : work)
    for (size_t set = 0; set < w.sets.size(); ++set) sets_[set].push_back(std::move(w.sets[set]));
  if (!rotational_) {
    wedges_.assign(size_t(n_wedges), {});
    wedge_radii.assign(size_t(n_wedges), {});
    wedge_parts.assign(size_t(n_wedges), {});
    for (int wdg = 0; wdg < n_wedges; ++wdg) {
      std::vector<double> rs;
      for (int l : {wdg, wdg + 1})
        for (const Interval& iv : sets_[0][size_t(l)].intervals)
          rs.insert(rs.end(), {iv.r0, 0.5 * (iv.r0 + iv.r1), iv.r1});
      std::sort(rs.begin(), rs.end());
      std::vector<double>& kept = wedge_radii[size_t(wdg)];
      for (double r : rs) {
        if (!kept.empty() && kept.back() >= wedge_reach[size_t(wdg)]) break;
        if (kept.empty() || r - kept.back() > 0.25 * min_width) kept.push_back(r);
      }
      const int n = static_cast<int>(kept.size());
      wedge_parts[size_t(wdg)].resize(size_t((n + kWedgeRadiiPerTask - 1) / kWedgeRadiiPerTask));
      for (int k = 0; k < n; k += kWedgeRadiiPerTask)
        tasks.push_back({wdg, 4, k, std::min(n, k + kWedgeRadiiPerTask)});
    }
    runStage(tasks);
    tasks.clear();
    for (int wdg = 0; wdg < n_wedges; ++wdg)
      for (WedgeCheck& part : wedge_parts[size_t(wdg)]) {
        WedgeCheck& wc = wedges_[size_t(wdg)];
        wc.r.insert(wc.r.end(), part.r.begin(), part.r.end());
        wc.f.insert(wc.f.end(), std::make_move_iterator(part.f.begin()),
                    std::make_move_iterator(part.f.end()));
      }
  }
  traces_ = traces_total;
  intervals_ = sets_[0].front().intervals;
  radius_lut_ = sets_[0].front().lut;
  lut_scale_ = sets_[0].front().lut_scale;
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

int ExitPupilSampler::intervalIn(const std::vector<Interval>& intervals,
                                 const std::vector<int>& radius_lut, double lut_scale, double r) {
  // Intervals are sorted by radius; the first whose upper end reaches r.
  const int last = static_cast<int>(intervals.size()) - 1;
  if (!radius_lut.empty()) {
    // The table's entry for the radius below r is the first interval reaching that radius, at
    // or before the answer.
    const double x = std::max(0.0, r * lut_scale);
    int k = radius_lut[std::min(size_t(x), radius_lut.size() - 1)];
    while (k < last && intervals[size_t(k)].r1 < r) ++k;
    return k;
  }
  auto it = std::lower_bound(intervals.begin(), intervals.end(), r,
                             [](const Interval& iv, double v) { return iv.r1 < v; });
  const int k = static_cast<int>(it - intervals.begin());
  return std::clamp(k, 0, static_cast<int>(intervals.size()) - 1);
}

std::vector<ExitPupilSampler::Interval> ExitPupilSampler::buildIntervals(
    const std::vector<Polygon>& nodes, const std::vector<std::vector<double>>& scales) const {
  const int nd = directions_;
  std::vector<Interval> intervals;
  for (size_t k = 0; k + 1 < nodes.size(); ++k) {
    const Polygon& a = nodes[k];
    const Polygon& b = nodes[k + 1];
    Interval iv;
    iv.r0 = a.r;
    iv.r1 = b.r;
    iv.empty = a.empty && b.empty;
    if (!iv.empty) {
      const Polygon& pa = a.empty ? b : a;
      const Polygon& pb = b.empty ? a : b;
      iv.c0 = pa.centre;
      iv.c1 = pb.centre;
      iv.A.resize(nd);
      iv.B.resize(nd);
      for (int j = 0; j < nd; ++j) {
        iv.A[j] = pa.radius[j] * scales[k][j];
        iv.B[j] = pb.radius[j] * scales[k][j];
      }
      iv.P.assign(3 * size_t(nd + 1), 0.0);
      for (int j = 0; j < nd; ++j) {
        const int j1 = (j + 1) % nd;
        double* p = &iv.P[3 * size_t(j)];
        p[3] = p[0] + iv.A[j] * iv.A[j1];
        p[4] = p[1] + iv.A[j] * iv.B[j1] + iv.B[j] * iv.A[j1];
        p[5] = p[2] + iv.B[j] * iv.B[j1];
      }
    }
    intervals.push_back(std::move(iv));
  }
  return intervals;
}

const ExitPupilSampler::Interval* ExitPupilSampler::locate(Vec2 film_mm, double& t, double& cos_a,
                                                           double& sin_a, int set) const {
  // Film coordinates are millimetres: no overflow for hypot to guard against.
  const double r = std::sqrt(film_mm.x * film_mm.x + film_mm.y * film_mm.y);
  if (set < 0 || set >= static_cast<int>(sets_.size())) return nullptr;
  const std::vector<Sector>& sectors = sets_[size_t(set)];
  if (r > film_radius_mm_ * (1 + 1e-9) || sectors.empty()) return nullptr;
  // Rotationally symmetric lenses only (anamorphic ones: blended()).
  const Sector* sec = &sectors.front();
  if (sec->intervals.empty()) return nullptr;
  const Interval& iv =
      sec->intervals[size_t(intervalIn(sec->intervals, sec->lut, sec->lut_scale, r))];
  if (iv.empty) return nullptr;
  t = iv.r1 > iv.r0 ? std::clamp((r - iv.r0) / (iv.r1 - iv.r0), 0.0, 1.0) : 0.0;
  const double inv_r = r > 0 ? 1 / r : 0.0;
  cos_a = r > 0 ? film_mm.x * inv_r : 1.0;
  sin_a = r > 0 ? film_mm.y * inv_r : 0.0;
  return &iv;
}

std::optional<PupilSample> ExitPupilSampler::sample(Vec2 film_mm, Vec2 u, int band) const {
  std::optional<PupilSample> out;
  sampleBatch(&film_mm, &u, 1, &out, band);
  return out;
}

void ExitPupilSampler::wedgeOf(Vec2 film_mm, int& wedge, double& s, double& r) const {
  const double fx = std::abs(film_mm.x), fy = std::abs(film_mm.y);
  r = std::sqrt(fx * fx + fy * fy);
  const int n = static_cast<int>(wedges_.size());
  const double q = std::atan2(fy, fx) / (std::numbers::pi / 2) * n;
  wedge = std::clamp(static_cast<int>(q), 0, n - 1);
  s = std::clamp(q - wedge, 0.0, 1.0);
}

bool ExitPupilSampler::blended(int set, int wedge, double r, double s, Vec2& c, double* R) const {
  const int nd = directions_;
  if (set < 0 || set >= static_cast<int>(sets_.size())) return false;
  if (r > film_radius_mm_ * (1 + 1e-9)) return false;
  const std::vector<Sector>& lines = sets_[size_t(set)];
  // Beyond an edge's reach (a film rectangle's, ExitPupilOptions::film_half_extent_mm): no bound.
  for (int l : {wedge, wedge + 1}) {
    const std::vector<Interval>& ivs = lines[size_t(l)].intervals;
    if (!ivs.empty() && r > ivs.back().r1 * (1 + 1e-9)) return false;
  }
  auto lineAt = [&](const Sector& L, Vec2& cc, double* RR) {
    if (L.intervals.empty()) return false;
    const Interval& iv = L.intervals[size_t(intervalIn(L.intervals, L.lut, L.lut_scale, r))];
    if (iv.empty) return false;
    const double t = iv.r1 > iv.r0 ? std::clamp((r - iv.r0) / (iv.r1 - iv.r0), 0.0, 1.0) : 0.0;
    cc = iv.c0 * (1 - t) + iv.c1 * t;
    for (int j = 0; j < nd; ++j) RR[j] = iv.A[size_t(j)] * (1 - t) + iv.B[size_t(j)] * t;
    return true;
  };
  thread_local std::vector<double> other;
  other.resize(size_t(nd));
  Vec2 cb;
  const bool a = lineAt(lines[size_t(wedge)], c, R);
  const bool b = lineAt(lines[size_t(wedge) + 1], cb, other.data());
  if (!a && !b) return false;
  if (a && b) {
    c = c * (1 - s) + cb * s;
    for (int j = 0; j < nd; ++j) R[j] = R[j] * (1 - s) + other[size_t(j)] * s;
  } else if (b) {  // one edge's region is empty at r (beyond its image circle): the other's
    c = cb;
    std::copy(other.begin(), other.end(), R);
  }
  const WedgeCheck& wc = wedges_[size_t(wedge)];
  if (!wc.r.empty()) {
    // The checks at the film radii around r; beyond the last, the last's.
    const size_t m = size_t(std::upper_bound(wc.r.begin(), wc.r.end(), r) - wc.r.begin());
    const std::vector<double>& f0 = wc.f[m > 0 ? m - 1 : 0];
    const std::vector<double>& f1 = wc.f[std::min(m, wc.r.size() - 1)];
    for (int j = 0; j < nd; ++j) R[j] *= std::max(f0[size_t(j)], f1[size_t(j)]);
  }
  return true;
}

std::optional<PupilSample> ExitPupilSampler::sampleAnamorphic(Vec2 film_mm, Vec2 u, int set) const {
  const int nd = directions_;
  int wedge;
  double s, r;
  wedgeOf(film_mm, wedge, s, r);
  thread_local std::vector<double> R, P;
  R.resize(size_t(nd));
  P.resize(size_t(nd) + 1);
  Vec2 c;
  if (!blended(set, wedge, r, s, c, R.data())) return std::nullopt;
  P[0] = 0;
  for (int j = 0; j < nd; ++j)
    P[size_t(j) + 1] = P[size_t(j)] + R[size_t(j)] * R[size_t((j + 1) % nd)];
  const double total = P[size_t(nd)];
  if (!(total > 0)) return std::nullopt;
  // A fan triangle by area, then uniform in it (as sampleBatch).
  const double target = u.x * total;
  const int j = std::min(
      static_cast<int>(std::upper_bound(P.begin() + 1, P.end(), target) - (P.begin() + 1)), nd - 1);
  const int j1 = (j + 1) % nd;
  const double tri = P[size_t(j) + 1] - P[size_t(j)];
  const double ux = tri > 0 ? std::clamp((target - P[size_t(j)]) / tri, 0.0, 1.0) : 0.0;
  const Vec2 local = c + (dirs_[size_t(j)] * (R[size_t(j)] * (1 - u.y)) +
                          dirs_[size_t(j1)] * (R[size_t(j1)] * u.y)) *
                             std::sqrt(ux);
  const double fx = std::abs(film_mm.x), fy = std::abs(film_mm.y);
  const double ca = r > 0 ? fx / r : 1.0, sa = r > 0 ? fy / r : 0.0;
  Vec2 rear = toFilmAzimuth(local, r, ca, sa);
  rear = {film_mm.x < 0 ? -rear.x : rear.x, film_mm.y < 0 ? -rear.y : rear.y};
  return PupilSample{{rear.x, rear.y, z_rear_mm_}, 0.5 * total * dirs_[1].y};
}

void ExitPupilSampler::sampleBatch(const Vec2* film_mm, const Vec2* u, int n,
                                   std::optional<PupilSample>* out, int band) const {
  if (!rotational_) {
    for (int i = 0; i < std::min(n, kBatch); ++i)
      out[i] = sampleAnamorphic(film_mm[i], u[i], band + 1);
    return;
  }
  const int nd = directions_;
  const Interval* iv[kBatch];
  double t[kBatch], ca[kBatch], sa[kBatch], w0[kBatch], w1[kBatch], w2[kBatch], target[kBatch],
      total[kBatch];
  int lo[kBatch], lane[kBatch];
  int m = 0;
  auto cum = [&](int k, int j) {
    const double* P = iv[k]->P.data() + 3 * j;
    return w0[k] * P[0] + w1[k] * P[1] + w2[k] * P[2];
  };
  for (int i = 0; i < std::min(n, kBatch); ++i) {
    out[i].reset();
    const Interval* v = locate(film_mm[i], t[m], ca[m], sa[m], band + 1);
    if (!v) continue;
    iv[m] = v;
    const double tt = t[m];
    w0[m] = (1 - tt) * (1 - tt), w1[m] = tt * (1 - tt), w2[m] = tt * tt;
    total[m] = cum(m, nd);
    target[m] = u[i].x * total[m];
    lo[m] = 0;
    lane[m++] = i;
  }
  // Pick a triangle of the fan by area, reusing u.x for the position inside it: j is the first
  // triangle whose cumulative area cum(j + 1) exceeds the target (the last if none does), found
  // by a branch-free binary search over cum(1 .. nd - 1) (its comparisons are unpredictable), the
  // same number of steps for every point.
  for (int len = nd - 1; len > 1;) {
    const int half = len / 2;
    for (int k = 0; k < m; ++k)
      lo[k] = cum(k, lo[k] + half + 1) <= target[k] ? lo[k] + half : lo[k];
    len -= half;
  }
  for (int k = 0; k < m; ++k) {
    const int j = std::min(lo[k] + (cum(k, lo[k] + 1) <= target[k] ? 1 : 0), nd - 1);
    const int j1 = (j + 1) % nd;
    const double c_lo = cum(k, j), tri = cum(k, j + 1) - c_lo;
    const double ux = tri > 0 ? std::clamp((target[k] - c_lo) / tri, 0.0, 1.0) : 0.0;
    const Interval& v = *iv[k];
    const double tt = t[k];
    const Vec2 a = dirs_[j] * (v.A[j] * (1 - tt) + v.B[j] * tt);
    const Vec2 b = dirs_[j1] * (v.A[j1] * (1 - tt) + v.B[j1] * tt);
    const Vec2 centre = v.c0 * (1 - tt) + v.c1 * tt;
    const double uy = u[lane[k]].y;
    Vec2 local;
    if (!v.hasHole()) {
      // Uniform in the fan triangle (centre, a, b): the fraction of the way out, s, has s^2
      // uniform.
      local = centre + (a * (1 - uy) + b * uy) * std::sqrt(ux);
    } else {
      // Uniform in the fan triangle minus the hole's (centre, ha, hb): the quadrilateral
      // (ha, a, b, hb), split along a diagonal that lies inside it into two triangles, one picked
      // by area (reusing ux), then uniform in it.
      const Vec2 ha = dirs_[j] * (v.HA[j] * (1 - tt) + v.HB[j] * tt);
      const Vec2 hb = dirs_[j1] * (v.HA[j1] * (1 - tt) + v.HB[j1] * tt);
      Vec2 p0 = ha, p1 = a, p2 = b, q0 = ha, q1 = b, q2 = hb;
      double s1 = cross2(a - ha, b - ha), s2 = cross2(b - ha, hb - ha);
      if (s1 < 0 || s2 < 0) {  // the other diagonal
        p0 = a, p1 = b, p2 = hb, q0 = a, q1 = hb, q2 = ha;
        s1 = cross2(b - a, hb - a), s2 = cross2(hb - a, ha - a);
      }
      s1 = std::max(s1, 0.0), s2 = std::max(s2, 0.0);
      const double f1 = s1 + s2 > 0 ? s1 / (s1 + s2) : 1.0;
      double w = ux;
      if (w < f1) {
        w = f1 > 0 ? w / f1 : 0.0;
      } else {
        w = (w - f1) / (1 - f1);
        p0 = q0, p1 = q1, p2 = q2;
      }
      const double sw = std::sqrt(std::clamp(w, 0.0, 1.0));
      local = centre + p0 * (1 - sw) + (p1 * (1 - uy) + p2 * uy) * sw;
    }
    // From the +x film frame to the film point's azimuth.
    const Vec2 f = film_mm[lane[k]];
    const Vec2 rear = toFilmAzimuth(local, std::hypot(f.x, f.y), ca[k], sa[k]);
    out[lane[k]] = PupilSample{{rear.x, rear.y, z_rear_mm_}, 0.5 * total[k] * dirs_[1].y};
  }
}

bool ExitPupilSampler::contains(Vec2 film_mm, Vec2 rear_mm, int band) const {
  if (!rotational_) {
    // Into the first quadrant's frame, then relative to the blended polygon's centre.
    const int nd = directions_;
    int wedge;
    double s, r;
    wedgeOf(film_mm, wedge, s, r);
    thread_local std::vector<double> R;
    R.resize(size_t(nd));
    Vec2 c;
    if (!blended(band + 1, wedge, r, s, c, R.data())) return false;
    const double fx = std::abs(film_mm.x), fy = std::abs(film_mm.y);
    const double ca = r > 0 ? fx / r : 1.0, sa = r > 0 ? fy / r : 0.0;
    const Vec2 rq{film_mm.x < 0 ? -rear_mm.x : rear_mm.x, film_mm.y < 0 ? -rear_mm.y : rear_mm.y};
    const Vec2 q{rq.x - (kappa_x_ * ca - kappa_x_) * r - c.x, rq.y - kappa_y_ * sa * r - c.y};
    const double dphi = 2 * std::numbers::pi / nd;
    double ang = std::atan2(q.y, q.x);
    if (ang < 0) ang += 2 * std::numbers::pi;
    const int j = std::min(static_cast<int>(ang / dphi), nd - 1), j1 = (j + 1) % nd;
    const Vec2 a = dirs_[size_t(j)] * R[size_t(j)], b = dirs_[size_t(j1)] * R[size_t(j1)];
    return cross2(b - a, q - a) >= 0;
  }
  double t, ca, sa;
  const Interval* iv = locate(film_mm, t, ca, sa, band + 1);
  if (!iv) return false;
  const Vec2 centre = iv->c0 * (1 - t) + iv->c1 * t;
  // Into the +x frame, relative to the centre.
  const Vec2 q{ca * rear_mm.x + sa * rear_mm.y - centre.x,
               -sa * rear_mm.x + ca * rear_mm.y - centre.y};
  const int nd = directions_;
  const double dphi = 2 * std::numbers::pi / nd;
  double ang = std::atan2(q.y, q.x);
  if (ang < 0) ang += 2 * std::numbers::pi;
  const int j = std::min(static_cast<int>(ang / dphi), nd - 1), j1 = (j + 1) % nd;
  const Vec2 a = dirs_[j] * (iv->A[j] * (1 - t) + iv->B[j] * t);
  const Vec2 b = dirs_[j1] * (iv->A[j1] * (1 - t) + iv->B[j1] * t);
  // Inside the fan triangle (0, a, b): on the origin's side of the edge a-b; and not inside the
  // hole's triangle (0, ha, hb).
  if (iv->hasHole()) {
    const Vec2 ha = dirs_[j] * (iv->HA[j] * (1 - t) + iv->HB[j] * t);
    const Vec2 hb = dirs_[j1] * (iv->HA[j1] * (1 - t) + iv->HB[j1] * t);
    if (cross2(hb - ha, q - ha) > 0) return false;
  }
  return cross2(b - a, q - a) >= 0;
}

double ExitPupilSampler::area_mm2(Vec2 film_mm, int band) const {
  if (!rotational_) {
    const int nd = directions_;
    int wedge;
    double s, r;
    wedgeOf(film_mm, wedge, s, r);
    thread_local std::vector<double> R;
    R.resize(size_t(nd));
    Vec2 c;
    if (!blended(band + 1, wedge, r, s, c, R.data())) return 0.0;
    double total = 0;
    for (int j = 0; j < nd; ++j) total += R[size_t(j)] * R[size_t((j + 1) % nd)];
    return 0.5 * total * dirs_[1].y;
  }
  double t, ca, sa;
  const Interval* iv = locate(film_mm, t, ca, sa, band + 1);
  if (!iv) return 0.0;
  const int nd = directions_;
  const double total = (1 - t) * (1 - t) * iv->P[3 * nd] + t * (1 - t) * iv->P[3 * nd + 1] +
                       t * t * iv->P[3 * nd + 2];
  return 0.5 * total * dirs_[1].y;
}

}  // namespace lensim::optics
