// The exit-pupil build's search for a point inside the region at a film point: the neighbouring
// polygon's centre or the real chief ray, else (near the edge of the image circle, where the
// region is tiny) the least margin around the neighbour's polygon: the best points of a coarse
// grid, then pattern searches from them.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

namespace {
constexpr int kGrid = 9;  // the coarse grid's points a side
}  // namespace

std::optional<Vec2> Probe::findInside(double h, const Polygon* hint) {
  // The neighbouring polygon's centre usually lies inside; the real chief ray's search costs
  // many traces.
  if (hint && !hint->empty && passes(h, hint->centre)) return hint->centre;
  // passingRearAim (the real chief ray, then grids over the whole exit pupil and rear element:
  // up to ~2,600 traces of the lens's own, at film azimuth 0): for an anamorphic lens only
  // without a neighbouring polygon to search about (below), since it solves for azimuth 0. A
  // rotationally symmetric lens keeps it: without it the bound's edge at the image circle moves
  // out a little (lentil:0014 on the 36x24 film: 4.7% -> 5.2% of its samples wasted) for ~20% of
  // its start-up.
  const bool near = hint && !hint->empty;
  std::optional<Vec2> c;
  if (ctx.rotational || !near) c = passingRearAim(ctx.lens, ctx.p, h);
  if (c && passes(h, *c)) return c;
  if (!near) return std::nullopt;
  const double reach = 1.5 * *std::max_element(hint->radius.begin(), hint->radius.end());
  // The margin on a coarse grid; then pattern searches from its three least points (the region
  // can be a thin crescent whose least margin lies off one search's path).
  std::vector<std::pair<double, Vec2>> starts;
  if (std::optional<Vec2> a = grid(h, hint->centre, reach, kGrid, &starts)) return a;
  std::partial_sort(starts.begin(), starts.begin() + 3, starts.end(),
                    [](const auto& x, const auto& y) { return x.first < y.first; });
  double g_least = kInf;
  for (int st = 0; st < 3 && std::isfinite(starts[size_t(st)].first); ++st) {
    double g_end;
    if (std::optional<Vec2> a =
            patternSearch(h, starts[size_t(st)].second, starts[size_t(st)].first, reach, g_end))
      return a;
    g_least = std::min(g_least, g_end);
  }
  // Against the rear disc's hard edge the crescent can be thinner still: where the margin came
  // within 2% of passing, a fine grid as well (fine enough to find slivers a hundredth of the
  // neighbour's size), as the bounds of the CS348B set-ups need (tests/optics_pupil_test).
  if (ctx.disc2 == 0 || g_least > 1.02) return std::nullopt;
  for (int n : {24, 96})
    if (std::optional<Vec2> a = grid(h, hint->centre, reach, n, nullptr)) return a;
  return std::nullopt;
}

// The margin on an n x n grid over the square of half side `reach` about `centre`, traced a batch
// at a time, in order: the first passing point, else nullopt with every point's margin appended
// to `margins` (if given).
std::optional<Vec2> Probe::grid(double h, Vec2 centre, double reach, int n,
                                std::vector<std::pair<double, Vec2>>* margins) {
  constexpr int kB = LensTracer<double>::kBatch;
  Vec2 pts[kB];
  double g[kB];
  for (int k0 = 0; k0 < n * n; k0 += kB) {
    const int m = std::min(kB, n * n - k0);
    for (int i = 0; i < m; ++i) {
      const int ix = (k0 + i) % n, iy = (k0 + i) / n;
      pts[i] =
          centre + Vec2{reach * (2.0 * (ix + 0.5) / n - 1), reach * (2.0 * (iy + 0.5) / n - 1)};
    }
    marginBatch(h, pts, m, g);
    for (int i = 0; i < m; ++i) {
      if (g[i] <= 1) return pts[i];
      if (margins) margins->push_back({g[i], pts[i]});
    }
  }
  return std::nullopt;
}

// A pattern search for a passing point from `best` (margin g_best): the first passing probe, else
// nullopt with the least margin reached in g_end. The margin is the largest of a few smooth
// functions (one per limiting surface): its minimum often lies on a ridge where two of them are
// equal, so the search tries 16 directions before halving its step.
std::optional<Vec2> Probe::patternSearch(double h, Vec2 best, double g_best, double reach,
                                         double& g_end) {
  constexpr int kDirs = 16, kGroup = 8;
  double step = reach / kGrid;
  for (int it = 0; it < 400 && step > 1e-4 * reach; ++it) {
    bool moved = false;
    double rise = 0;  // the most the margin rose over the probes around `best`
    // The probes are traced kGroup at a time (batched); taken in order as one at a time (the
    // first passing probe, else the first that goes down), so that the traces past it are the
    // price of the batch.
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
          // A descent too slow to reach 1 within the iterations left (even at twice the pace)
          // ends the search where it would have ended anyway.
          const double fell = g_best - g;
          best = qs[i], g_best = g, moved = true;
          if (g_best - 1 > 2 * (400 - it) * fell) it = 400;
          break;
        }
        rise = std::max(rise, g - g_best);
      }
    }
    if (moved) continue;
    // No probe went down: the least margin near `best` lies within a step of it, and the margin
    // changes by about `rise` over a step; where that cannot bring it down to 1 (by twice over),
    // smaller steps cannot either: this start has no passing point near it.
    if (step < reach / (4 * kGrid) && g_best - 1 > 2 * rise) break;
    step *= 0.5;
  }
  g_end = g_best;
  return std::nullopt;
}

}  // namespace lensim::optics::pupil
