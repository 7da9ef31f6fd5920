// Warping functions and tabulated distributions: pdfs integrate to one and samples follow them.
#include <gtest/gtest.h>

#include <functional>
#include <random>
#include <set>
#include <vector>

#include "lensim/sampling/sampling.h"
#include "stats.h"

using namespace lensim;
using namespace lensim::sampling;
using lensim::test::RunningStats;

namespace {

// Estimates the integral of h over the sampled domain by importance sampling:
// mean of h(w) / pdf(w). Checks it against `exact` within 4.5 standard errors.
void checkEstimator(const std::function<Vec3(Vec2)>& sample, const std::function<double(Vec3)>& pdf,
                    const std::function<double(Vec3)>& h, double exact, const char* what) {
  Rng rng(17, 0);
  RunningStats s;
  for (int i = 0; i < 200000; ++i) {
    const Vec3 w = sample({rng.uniform(), rng.uniform()});
    ASSERT_NEAR(length(w), 1.0, 1e-9) << what;
    s.add(h(w) / pdf(w));
  }
  EXPECT_NEAR(s.mean, exact, 4.5 * s.stderror() + 1e-12) << what;
}

// Integral of a direction pdf over the sphere, by uniform sphere sampling.
double integrateOverSphere(const std::function<double(Vec3)>& pdf) {
  Rng rng(5, 0);
  RunningStats s;
  for (int i = 0; i < 200000; ++i)
    s.add(pdf(sampleUniformSphere({rng.uniform(), rng.uniform()})) / uniformSpherePdf());
  return s.mean;
}

}  // namespace

TEST(Warping, HemisphereSphereCosineConePdfsIntegrateToOne) {
  EXPECT_NEAR(integrateOverSphere([](Vec3 w) { return w.z > 0 ? uniformHemispherePdf() : 0.0; }),
              1.0, 0.01);
  EXPECT_NEAR(integrateOverSphere([](Vec3 w) { return w.z > 0 ? cosineHemispherePdf(w.z) : 0.0; }),
              1.0, 0.01);
  const double cmax = 0.8;
  EXPECT_NEAR(integrateOverSphere([&](Vec3 w) { return w.z > cmax ? uniformConePdf(cmax) : 0.0; }),
              1.0, 0.03);
}

TEST(Warping, SamplesFollowTheirPdfs) {
  // Integral of z^2 over the hemisphere is 2 pi / 3; over the sphere 4 pi / 3; over the cone of
  // cos theta_max = c: 2 pi (1 - c^3) / 3.
  auto z2 = [](Vec3 w) { return w.z * w.z; };
  checkEstimator(
      sampleUniformHemisphere, [](Vec3) { return uniformHemispherePdf(); }, z2, 2 * kPi / 3,
      "hemisphere");
  checkEstimator(
      sampleUniformSphere, [](Vec3) { return uniformSpherePdf(); }, z2, 4 * kPi / 3, "sphere");
  checkEstimator(
      sampleCosineHemisphere, [](Vec3 w) { return cosineHemispherePdf(w.z); }, z2, 2 * kPi / 3,
      "cosine");
  const double c = 0.6;
  checkEstimator([&](Vec2 u) { return sampleUniformCone(u, c); },
                 [&](Vec3) { return uniformConePdf(c); }, z2, 2 * kPi * (1 - c * c * c) / 3,
                 "cone");
  // Samples stay on their domains.
  Rng rng(3, 0);
  for (int i = 0; i < 10000; ++i) {
    const Vec2 u(rng.uniform(), rng.uniform());
    EXPECT_GE(sampleUniformHemisphere(u).z, 0.0);
    EXPECT_GE(sampleCosineHemisphere(u).z, 0.0);
    EXPECT_GE(sampleUniformCone(u, c).z, c - 1e-12);
  }
}

TEST(Warping, ConcentricDiskIsUniform) {
  // Uniform on the unit disk: E[r^2] = 1/2, E[x] = 0, all points inside.
  Rng rng(4, 0);
  RunningStats r2, x;
  for (int i = 0; i < 100000; ++i) {
    const Vec2 p = sampleUniformDiskConcentric({rng.uniform(), rng.uniform()});
    ASSERT_LE(p.x * p.x + p.y * p.y, 1.0 + 1e-12);
    r2.add(p.x * p.x + p.y * p.y);
    x.add(p.x);
  }
  EXPECT_NEAR(r2.mean, 0.5, 4.5 * r2.stderror());
  EXPECT_NEAR(x.mean, 0.0, 4.5 * x.stderror());
}

TEST(Warping, TentMatchesItsPdf) {
  const double r = 1.7;
  double integral = 0;
  const int n = 34000;
  for (int i = 0; i < n; ++i) integral += tentPdf(-r + (i + 0.5) * 2 * r / n, r) * 2 * r / n;
  EXPECT_NEAR(integral, 1.0, 1e-6);
  Rng rng(6, 0);
  RunningStats absx;
  for (int i = 0; i < 100000; ++i) {
    const double x = sampleTent(rng.uniform(), r);
    ASSERT_LE(std::abs(x), r);
    absx.add(std::abs(x));
  }
  EXPECT_NEAR(absx.mean, r / 3, 4.5 * absx.stderror());  // E|x| = r/3 for the tent
}

TEST(PiecewiseConstant1D, SamplesCellsInProportionAndPdfIntegratesToOne) {
  const std::vector<double> f = {1, 2, 0, 3, -4};  // |f| is used
  const PiecewiseConstant1D d(f, -1.0, 4.0);
  EXPECT_DOUBLE_EQ(d.integral(), 10.0);
  double integral = 0;
  for (int i = 0; i < 5000; ++i) integral += d.pdf(-1 + (i + 0.5) * 1e-3) * 1e-3;
  EXPECT_NEAR(integral, 1.0, 1e-9);
  std::vector<int> counts(5, 0);
  Rng rng(7, 0);
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const auto s = d.sample(rng.uniform());
    ASSERT_GE(s.x, -1.0);
    ASSERT_LT(s.x, 4.0);
    ASSERT_DOUBLE_EQ(s.pdf, d.pdf(s.x));
    ++counts[s.offset];
  }
  EXPECT_EQ(counts[2], 0);
  for (int c = 0; c < 5; ++c) {
    const double p = std::abs(f[c]) / 10.0;
    EXPECT_NEAR(counts[c], n * p, 4.5 * std::sqrt(n * p * (1 - p)) + 1) << "cell " << c;
  }
}

TEST(PiecewiseConstant2D, PdfIntegratesToOneAndMatchesSamples) {
  const std::vector<double> f = {1, 0, 2, 5, 1, 1, 0, 0, 3, 4, 1, 2};  // 4 x 3
  const PiecewiseConstant2D d(f, 4, 3, {0, 0}, {2, 1});
  double integral = 0;
  // Midpoint rule on a grid aligned with the cells (0.5 x 1/3).
  const double hx = 1.0 / 200, hy = 1.0 / 300;
  for (int j = 0; j < 300; ++j)
    for (int i = 0; i < 400; ++i) integral += d.pdf({(i + 0.5) * hx, (j + 0.5) * hy}) * hx * hy;
  EXPECT_NEAR(integral, 1.0, 1e-9);
  Rng rng(8, 0);
  std::vector<int> counts(12, 0);
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const auto s = d.sample({rng.uniform(), rng.uniform()});
    ASSERT_NEAR(s.pdf, d.pdf(s.p), 1e-9);
    ++counts[std::min(2, int(s.p.y * 3)) * 4 + std::min(3, int(s.p.x * 2))];
  }
  for (int c = 0; c < 12; ++c) {
    const double p = f[c] / 20.0;
    EXPECT_NEAR(counts[c], n * p, 4.5 * std::sqrt(n * p * (1 - p)) + 1) << "cell " << c;
  }
}

TEST(PowerHeuristic, WeightsSumToOne) {
  EXPECT_DOUBLE_EQ(powerHeuristic(1, 2.0, 1, 1.0), 0.8);
  EXPECT_DOUBLE_EQ(powerHeuristic(1, 2.0, 1, 1.0) + powerHeuristic(1, 1.0, 1, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(powerHeuristic(1, INFINITY, 1, 1.0), 1.0);
}

TEST(PermutationElement, IsAPermutation) {
  for (uint32_t n : {1u, 2u, 3u, 7u, 16u, 100u, 1000u}) {
    for (uint64_t seed : {0ull, 12345ull}) {
      std::set<int> seen;
      for (uint32_t i = 0; i < n; ++i) {
        const int e = permutationElement(i, n, seed);
        ASSERT_GE(e, 0);
        ASSERT_LT(e, int(n));
        seen.insert(e);
      }
      EXPECT_EQ(seen.size(), n);
    }
  }
  // Different seeds give different permutations.
  int same = 0;
  for (uint32_t i = 0; i < 100; ++i)
    same += permutationElement(i, 100, 1) == permutationElement(i, 100, 2);
  EXPECT_LT(same, 20);
}

TEST(Rng, AdvanceSkipsOutputs) {
  Rng a(42, 7), b(42, 7);
  for (int i = 0; i < 1000; ++i) a.uniformU32();
  b.advance(1000);
  EXPECT_EQ(a.uniformU32(), b.uniformU32());
  b.advance(0);
  EXPECT_EQ(a.uniformU32(), b.uniformU32());
}

TEST(PiecewiseConstant1D, GuideTableFindsTheCellOfALinearScan) {
  // Against the CDF inverted by a linear scan written here: the cell whose [cdf_o, cdf_o+1)
  // holds u, skipping cells of zero probability. Functions with runs of zeros, a single cell,
  // sizes that are and are not powers of two, a zero function (uniform).
  std::mt19937 rng(2929);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::vector<std::vector<double>> fs = {{1.0}, {0.0, 0.0, 3.0}, {0.0, 0.0, 0.0, 0.0}};
  for (int n : {2, 7, 64, 96, 1000}) {
    std::vector<double> f(static_cast<size_t>(n));
    for (auto& v : f) v = uni(rng) < 0.3 ? 0.0 : uni(rng) * (uni(rng) < 0.1 ? 1000.0 : 1.0);
    fs.push_back(f);
  }
  for (const auto& f : fs) {
    const PiecewiseConstant1D d(f, -2.0, 3.0);
    const size_t n = f.size();
    std::vector<double> cdf(n + 1, 0.0);
    for (size_t i = 1; i <= n; ++i) cdf[i] = cdf[i - 1] + std::abs(f[i - 1]) * 5.0 / n;
    const double total = cdf[n];
    for (size_t i = 1; i <= n; ++i) cdf[i] = total > 0 ? cdf[i] / total : double(i) / n;
    std::vector<double> us;
    for (int i = 0; i < 3000; ++i) us.push_back(uni(rng));
    for (double c : cdf) {  // exactly on and just around each CDF entry
      if (c < 1) us.push_back(c);
      us.push_back(std::nextafter(c, 0.0));
    }
    us.push_back(0.0);
    us.push_back(std::nextafter(1.0, 0.0));
    for (double u : us) {
      size_t o = 0;
      for (size_t i = 0; i <= n; ++i)
        if (cdf[i] <= u) o = i;
      o = std::min(o, n - 1);
      const auto s = d.sample(u);
      ASSERT_EQ(s.offset, static_cast<int>(o)) << "n " << n << " u " << u;
      EXPECT_GE(s.x, -2.0);
      EXPECT_LE(s.x, 3.0);
      EXPECT_GT(s.pdf, 0.0);
    }
  }
}
