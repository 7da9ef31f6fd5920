// Pixel filters: pbrt-v4 defaults and shapes, and importance sampling against evaluation.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "lensim/sampling/filter.h"
#include "stats.h"

using namespace lensim;
using namespace lensim::sampling;
using lensim::test::RunningStats;

namespace {

std::vector<std::pair<const char*, std::shared_ptr<Filter>>> allFilters() {
  return {{"box", std::make_shared<BoxFilter>()},
          {"gaussian", std::make_shared<GaussianFilter>()},
          {"mitchell", std::make_shared<MitchellFilter>()},
          {"sinc", std::make_shared<LanczosSincFilter>()},
          {"triangle", std::make_shared<TriangleFilter>()},
          {"gaussian-aniso", std::make_shared<GaussianFilter>(Vec2(2.0, 1.0), 0.7)},
          {"mitchell-B1C0", std::make_shared<MitchellFilter>(Vec2(1.5, 2.5), 1.0, 0.0)}};
}

// Integral of f * h over the support by the midpoint rule.
double quadrature(const Filter& f, const std::function<double(Vec2)>& h) {
  const int n = 800;
  const Vec2 r = f.radius();
  const double dx = 2 * r.x / n, dy = 2 * r.y / n;
  double s = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec2 p(-r.x + (i + 0.5) * dx, -r.y + (j + 0.5) * dy);
      s += f.eval(p) * h(p);
    }
  return s * dx * dy;
}

}  // namespace

TEST(Filter, DefaultsArePbrtV4s) {
  EXPECT_EQ(BoxFilter().radius(), Vec2(0.5, 0.5));
  EXPECT_EQ(GaussianFilter().radius(), Vec2(1.5, 1.5));
  EXPECT_EQ(MitchellFilter().radius(), Vec2(2, 2));
  EXPECT_EQ(LanczosSincFilter().radius(), Vec2(4, 4));
  EXPECT_EQ(TriangleFilter().radius(), Vec2(2, 2));
  // Shapes: Mitchell(1/3, 1/3) at 0 is (6 - 2B)/6 = 8/9; Gaussian reaches 0 at the radius;
  // Lanczos is 1 at the centre and 0 at integers; triangle is r at the centre.
  EXPECT_NEAR(MitchellFilter().eval({0, 0}), (8.0 / 9) * (8.0 / 9), 1e-12);
  EXPECT_NEAR(GaussianFilter().eval({1.5, 0}), 0.0, 1e-12);
  EXPECT_NEAR(LanczosSincFilter().eval({0, 0}), 1.0, 1e-12);
  EXPECT_NEAR(LanczosSincFilter().eval({1, 0}), 0.0, 1e-12);
  EXPECT_NEAR(TriangleFilter().eval({0, 0}), 4.0, 1e-12);
  EXPECT_EQ(BoxFilter().eval({0.6, 0}), 0.0);
}

TEST(Filter, IntegralMatchesQuadrature) {
  for (const auto& [name, f] : allFilters())
    EXPECT_NEAR(f->integral(), quadrature(*f, [](Vec2) { return 1.0; }), 1e-4) << name;
  EXPECT_NEAR(BoxFilter().integral(), 1.0, 1e-12);
  EXPECT_NEAR(TriangleFilter().integral(), 16.0, 1e-9);
}

TEST(Filter, SamplingIsUnbiasedForFilterWeightedIntegrals) {
  // E[weight h(p)] = integral of f h, for a smooth test function h; and the sampling pdf
  // integrates to one.
  auto h = [](Vec2 p) { return 1.0 + 0.3 * p.x + 0.2 * p.x * p.y + 0.1 * p.y * p.y; };
  for (const auto& [name, f] : allFilters()) {
    const double exact = quadrature(*f, h);
    Rng rng(11, 0);
    RunningStats est;
    for (int i = 0; i < 100000; ++i) {
      const FilterSample s = f->sample({rng.uniform(), rng.uniform()});
      ASSERT_LE(std::abs(s.p.x), f->radius().x) << name;
      ASSERT_LE(std::abs(s.p.y), f->radius().y) << name;
      ASSERT_NEAR(s.weight, f->eval(s.p) / f->pdf(s.p), 1e-9 * std::abs(s.weight) + 1e-12) << name;
      est.add(s.weight * h(s.p));
    }
    EXPECT_NEAR(est.mean, exact, 4.5 * est.stderror() + 1e-9) << name;
    const double pdf_integral =
        quadrature(BoxFilter(f->radius()), [&](Vec2 p) { return f->pdf(p); });
    EXPECT_NEAR(pdf_integral, 1.0, 1e-3) << name;
  }
}

TEST(GaussianFilter, TableWithinInterpolationBoundOfClosedForm) {
  // The profile is tabulated with cells no wider than 1/256 pixel: linear interpolation is off
  // by at most h^2/8 max|g''|, max|g''| = 1/(sqrt(2 pi) sigma^3) (at 0). Reference: the closed
  // form written here, at off-grid offsets, for radii that are and are not multiples of 1/256.
  for (auto [r, sigma] : {std::pair{1.5, 0.5}, std::pair{1.37, 0.3}, std::pair{2.0, 1.0}}) {
    const GaussianFilter f({r, r * 0.8}, sigma);
    for (double rr : {r, r * 0.8}) {
      const double kPiD = 3.14159265358979323846;
      auto g = [&](double x) {
        return std::exp(-x * x / (2 * sigma * sigma)) / std::sqrt(2 * kPiD * sigma * sigma);
      };
      const double h = rr / std::ceil(rr * 256);
      const double bound = h * h / 8 / (std::sqrt(2 * kPiD) * sigma * sigma * sigma);
      double max_err = 0;
      for (int i = 0; i <= 10000; ++i) {
        const double x = -rr + 2 * rr * (i + 0.3183) / 10001;
        const double want = std::abs(x) <= rr ? std::max(0.0, g(x) - g(rr)) : 0.0;
        // eval is separable: probe one axis with the other at 0, whose table node is exact.
        const double got = rr == r ? f.eval({x, 0}) / (g(0) - g(r * 0.8))
                                   : f.eval({0, x}) / (g(0) - g(r));
        max_err = std::max(max_err, std::abs(got - want));
      }
      EXPECT_LT(max_err, bound * 1.0001 + 1e-15) << r << " " << sigma << " axis " << rr;
      EXPECT_GT(max_err, 0.0);
      EXPECT_EQ(f.eval({rr == r ? rr * 1.0001 : 0.0, rr == r ? 0.0 : rr * 1.0001}), 0.0);
    }
  }
}
