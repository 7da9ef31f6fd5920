// The exit-pupil build's pieces on their own (optics/pupil/): the boundary search against closed
// forms and against bisection with real clipped traces, the polygon helpers against geometry,
// and the interval lookup and wedge blending against direct computation.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "lensim/optics/focus.h"
#include "lensim/optics/pupil/build.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using namespace lensim::optics::pupil;

namespace {

// Runs one search to its end on the margin function g(s).
template <class G>
EdgeSearch runSearch(EdgeSearch e, const G& g, int* evals = nullptr) {
  int n = 0;
  while (!e.done) e.feed(g(e.x)), ++n;
  if (evals) *evals = n;
  return e;
}

TEST(PupilStages, EdgeSearchEndsOnABlockedPointWithinTheTolerance) {
  // Margins whose boundary (margin 1) is at d: linear, quadratic, and one that jumps to infinity
  // there (a ray missing a surface: no slope, bisection only).
  const double d = 3.7;
  const auto linear = [&](double s) { return s / d; };
  const auto quadratic = [&](double s) { return 0.5 + 0.5 * (s / d) * (s / d); };
  const auto jump = [&](double s) { return s <= d ? 0.9 : kInf; };
  for (double guess : {0.5, 3.0, 3.7, 9.0}) {
    for (int which = 0; which < 3; ++which) {
      int evals = 0;
      const EdgeSearch e = which == 0 ? runSearch(EdgeSearch(guess, 0, 10.0, 0, 0), linear, &evals)
                           : which == 1
                               ? runSearch(EdgeSearch(guess, 0, 10.0, 0, 0), quadratic, &evals)
                               : runSearch(EdgeSearch(guess, 0, 10.0, 0, 0), jump, &evals);
      SCOPED_TRACE(testing::Message() << "guess " << guess << " margin " << which);
      // Blocked (past d) and within the relative tolerance of the passing point before it.
      EXPECT_GT(e.result, d);
      EXPECT_LE(e.result, d / (1 - EdgeSearch::kTol));
      EXPECT_TRUE(e.bracketed);
      EXPECT_LE(evals, 80);
    }
  }
}

TEST(PupilStages, EdgeSearchAcceptsAGoodGuessWithinItsOvershoot) {
  // With accept > 0 a blocked point the slope puts within `accept` of the boundary ends it.
  const double d = 2.0, accept = 2e-3;
  int evals = 0;
  const EdgeSearch e = runSearch(
      EdgeSearch(d * (1 + 0.5 * accept), accept, 10.0, 0.5, 0), [&](double s) { return s / d; },
      &evals);
  EXPECT_GT(e.result, d);
  EXPECT_LE(e.result, d * (1 + accept));
  EXPECT_LE(evals, 3);
  // A covering search whose first point is blocked ends there with 0 (nothing to widen).
  const EdgeSearch c =
      runSearch(EdgeSearch(3.0, 1e-3, 10.0, 0, 0, true), [&](double s) { return s / d; });
  EXPECT_EQ(c.result, 0.0);
}

TEST(PupilStages, FarthestCrossingOfASquare) {
  const std::vector<Vec2> square = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  EXPECT_NEAR(farthestCrossing(square, {0, 0}, {1, 0}), 1.0, 1e-12);
  EXPECT_NEAR(farthestCrossing(square, {0, 0}, unit(std::numbers::pi / 4)), std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(farthestCrossing(square, {0.5, 0}, {-1, 0}), 1.5, 1e-12);
  EXPECT_EQ(farthestCrossing(square, {3, 0}, {1, 0}), 0.0);  // pointing away: no crossing
}

// A context for the double Gauss at 35 mm film (the polygon helpers use only its directions).
struct Dgauss {
  FocusedLens fl = focusLens(readLensFile(test::lensPath("dgauss.50mm.dat")), {});
  ExitPupilOptions opts;
  Context ctx{*fl.lens, fl.paraxial, 17.5, opts};
};

TEST(PupilStages, PolygonAreaAndCoverFactors) {
  Dgauss g;
  const Context& ctx = g.ctx;
  Polygon poly;
  poly.empty = false;
  poly.centre = {0.3, -0.2};
  poly.radius.assign(size_t(ctx.nd), 2.0);
  // A regular n-gon of circumradius 2.
  EXPECT_NEAR(polygonArea(ctx, poly), 0.5 * ctx.nd * 4 * std::sin(2 * std::numbers::pi / ctx.nd),
              1e-12);
  // A point at 3 from the centre half-way between the directions of vertices 5 and 6, where the
  // edge between them is 2 cos(dphi / 2) away: both scaled by 3 / (2 cos(dphi / 2)); a point
  // inside the polygon widens nothing.
  const double half = 5.5 * ctx.dphi, need = 3 / (2 * std::cos(0.5 * ctx.dphi));
  const Vec2 out = poly.centre + unit(half) * 3.0, in = poly.centre + ctx.dirs[9] * 1.0;
  const std::vector<double> f = coverFactors(ctx, poly, {out, in});
  for (int j = 0; j < ctx.nd; ++j) {
    SCOPED_TRACE(j);
    if (j == 5 || j == 6)
      EXPECT_NEAR(f[size_t(j)], need, 1e-9);
    else
      EXPECT_EQ(f[size_t(j)], 1.0);
  }
  // Widened by the factors, the polygon contains the point: on the centre's side of the edge.
  Polygon wide = poly;
  for (int j = 0; j < ctx.nd; ++j) wide.radius[size_t(j)] *= f[size_t(j)];
  const Vec2 a = ctx.dirs[5] * wide.radius[5], b = ctx.dirs[6] * wide.radius[6];
  EXPECT_GE(cross2(b - a, (out - wide.centre) - a), -1e-9);
}

TEST(PupilStages, ProbeBoundaryAgreesWithBisectionOnRealTraces) {
  // The boundary the probe finds on the margin against bisection on the clipped trace's
  // pass/fail, from the same point inside the region, on axis and off axis.
  Dgauss g;
  const LensSystem& lens = *g.fl.lens;
  for (double h : {0.0, 8.0, 15.0}) {
    Probe probe(g.ctx, 0);
    const std::optional<Vec2> c = probe.findInside(h, nullptr);
    ASSERT_TRUE(c) << h;
    ASSERT_TRUE(lens.traceFromFilmPoint({h, 0}, *c).ok()) << h;
    for (int k = 0; k < 8; ++k) {
      const Vec2 u = unit(2 * std::numbers::pi * k / 8 + 0.1);
      double lo = 0, hi = 4 * g.ctx.rr;
      ASSERT_FALSE(lens.traceFromFilmPoint({h, 0}, *c + u * hi).ok());
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (lens.traceFromFilmPoint({h, 0}, *c + u * mid).ok() ? lo : hi) = mid;
      }
      const double d = probe.boundary(h, *c, u, 0.5 * g.ctx.rr);
      SCOPED_TRACE(testing::Message() << "h " << h << " direction " << k);
      EXPECT_FALSE(lens.traceFromFilmPoint({h, 0}, *c + u * d).ok());
      EXPECT_GE(d, lo);
      EXPECT_LE(d, hi * (1 + 1.01e-3));
    }
    EXPECT_GT(probe.traces, 0);
  }
}

TEST(PupilStages, IntervalLookupMatchesALinearScan) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(0.01, 1.0);
  std::vector<Interval> ivs;
  double r = 0;
  for (int k = 0; k < 37; ++k) {
    Interval iv;
    iv.r0 = r;
    r += U(rng);
    iv.r1 = r;
    ivs.push_back(iv);
  }
  constexpr int kLut = 64;
  std::vector<int> lut(kLut + 1);
  for (int k = 0; k <= kLut; ++k) lut[size_t(k)] = intervalIn(ivs, {}, 0, r * k / kLut);
  for (int q = 0; q < 2000; ++q) {
    const double x = std::uniform_real_distribution<double>(0, r)(rng);
    int expect = 0;
    while (expect < int(ivs.size()) - 1 && ivs[size_t(expect)].r1 < x) ++expect;
    EXPECT_EQ(intervalIn(ivs, {}, 0, x), expect) << x;
    EXPECT_EQ(intervalIn(ivs, lut, kLut / r, x), expect) << x;
  }
}

TEST(PupilStages, BlendedPolygonInterpolatesBetweenTheWedgeEdges) {
  // Two wedge edges, each one interval with constant polygons; the wedge's checks widen vertex 1.
  const int nd = 4;
  auto edge = [&](Vec2 c, double R) {
    Sector s;
    Interval iv;
    iv.r0 = 0, iv.r1 = 10, iv.empty = false, iv.c0 = iv.c1 = c;
    iv.A.assign(nd, R), iv.B.assign(nd, R);
    s.intervals = {iv};
    return s;
  };
  const std::vector<Sector> lines = {edge({1, 0}, 2), edge({0, 1}, 4)};
  WedgeCheck wc;
  wc.r = {0, 10};
  wc.f = {{1, 1.5, 1, 1}, {1, 1.5, 1, 1}};
  Vec2 c;
  double R[nd];
  ASSERT_TRUE(blendedPolygon(lines, &wc, nd, 10, 0, 5, 0.25, c, R));
  EXPECT_DOUBLE_EQ(c.x, 0.75);
  EXPECT_DOUBLE_EQ(c.y, 0.25);
  EXPECT_DOUBLE_EQ(R[0], 2.5);
  EXPECT_DOUBLE_EQ(R[1], 3.75);
  ASSERT_TRUE(blendedPolygon(lines, nullptr, nd, 10, 0, 5, 0.25, c, R));
  EXPECT_DOUBLE_EQ(R[1], 2.5);
  // Beyond the film radius: nothing.
  EXPECT_FALSE(blendedPolygon(lines, &wc, nd, 10, 0, 10.5, 0.25, c, R));
}

}  // namespace
