// One search along a direction for the region's boundary on the margin, a state machine so
// that many searches run side by side with their traces batched (Probe::boundaries); and the
// farthest crossing of a ray with a polygon, where a search starts. Internal to the exit-pupil
// build (optics/pupil/build.h).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "lensim/optics/pupil/bound.h"

namespace lensim::optics::pupil {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The farthest crossing t > 0 of the ray from + t u with the edges of the closed polygon
// `verts` (0 where it crosses none).
inline double farthestCrossing(const std::vector<Vec2>& verts, Vec2 from, Vec2 u) {
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
// direction, on the margin (Probe::boundary): a state machine, so that
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

}  // namespace lensim::optics::pupil
