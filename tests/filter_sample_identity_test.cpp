// Filter sampling cost (issue 29, docs/performance.md): PiecewiseConstant1D::sample (guide table,
// densities divided at construction) gives bit for bit what a plain binary search over the whole
// CDF gives, and the filters' sample() (profile called without virtual dispatch) gives weights
// bit-equal to eval(p) / pdf(p).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "lensim/sampling/filter.h"
#include "lensim/sampling/sampling.h"

using namespace lensim;
using namespace lensim::sampling;

namespace {

// The inversion as a plain transcription: the CDF of |f| (the same sums in the same order),
// std::upper_bound over all of it, then the offset within the cell.
struct PlainPiecewiseConstant {
  std::vector<double> f, cdf;
  double min, max, integral;
  PlainPiecewiseConstant(const std::vector<double>& values, double lo, double hi)
      : f(values), min(lo), max(hi) {
    const size_t n = f.size();
    for (double& v : f) v = std::abs(v);
    cdf.assign(n + 1, 0.0);
    for (size_t i = 1; i <= n; ++i) cdf[i] = cdf[i - 1] + f[i - 1] * (max - min) / n;
    integral = cdf[n];
    for (size_t i = 1; i <= n; ++i) cdf[i] = integral > 0 ? cdf[i] / integral : double(i) / n;
  }
  PiecewiseConstant1D::Sample sample(double u) const {
    const int n = static_cast<int>(f.size());
    int o = static_cast<int>(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()) - 1;
    o = std::clamp(o, 0, n - 1);
    double du = u - cdf[size_t(o)];
    const double width = cdf[size_t(o) + 1] - cdf[size_t(o)];
    if (width > 0) du /= width;
    du = std::clamp(du, 0.0, 0x1.fffffffffffffp-1);
    const double pdf = integral > 0 ? f[size_t(o)] / integral : 1.0 / (max - min);
    const double x = min + (o + du) / n * (max - min);
    return {std::min(x, max), pdf, o};
  }
  double pdf(double x) const {
    if (x < min || x > max) return 0.0;
    const int n = static_cast<int>(f.size());
    const int o = std::clamp(static_cast<int>((x - min) / (max - min) * n), 0, n - 1);
    return integral > 0 ? f[size_t(o)] / integral : 1.0 / (max - min);
  }
};

TEST(PiecewiseConstant1DIdentity, SameAsPlainBinarySearchBitForBit) {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::vector<std::vector<double>> fs = {{1.0}, {0.0, 0.0, 0.0}, {0.0, 2.0, 0.0, -3.0}};
  // The Gaussian filter's table shape (96 cells on [-1.5, 1.5]), with its zero ends.
  std::vector<double> g(96);
  for (size_t i = 0; i < g.size(); ++i) {
    const double x = -1.5 + (double(i) + 0.5) * 3.0 / 96;
    g[i] = std::max(0.0, std::exp(-2 * x * x) - std::exp(-2 * 2.25));
  }
  fs.push_back(g);
  // Random sizes with runs of zeros and spikes.
  for (int n : {2, 5, 64, 100, 1000, 4097}) {
    std::vector<double> f(static_cast<size_t>(n));
    for (auto& v : f) v = uni(rng) < 0.3 ? 0.0 : uni(rng) * (uni(rng) < 0.05 ? 1e4 : 1.0);
    fs.push_back(f);
  }
  // One huge cell and then hundreds of narrow ones: many CDF entries inside one guide step (the
  // binary-searched branch), and many guide steps inside one cell.
  std::vector<double> spike(600, 1.0);
  spike[0] = 1e6;
  fs.push_back(spike);
  std::vector<double> spike_end(600, 1.0);
  spike_end[599] = 1e6;
  fs.push_back(spike_end);

  int64_t compared = 0;
  for (const auto& f : fs) {
    const PiecewiseConstant1D d(f, -1.25, 3.5);
    const PlainPiecewiseConstant ref(f, -1.25, 3.5);
    std::vector<double> us = {0.0, std::nextafter(1.0, 0.0), 1.0, -0.25, 1.5,
                              std::numeric_limits<double>::denorm_min(), -0.0};
    for (int i = 0; i < 20000; ++i) us.push_back(uni(rng));
    for (double c : ref.cdf) {  // on and around each cell edge
      us.push_back(c);
      us.push_back(std::nextafter(c, 0.0));
      us.push_back(std::nextafter(c, 2.0));
    }
    const size_t steps = std::bit_ceil(f.size());  // on and below each guide step of 2^k >= n
    for (size_t k = 0; k <= 4 * steps; ++k) {
      const double u = double(k) / double(4 * steps);
      us.push_back(u);
      us.push_back(std::nextafter(u, 0.0));
    }
    for (double u : us) {
      const auto a = d.sample(u), b = ref.sample(u);
      ASSERT_EQ(a.offset, b.offset) << "n " << f.size() << " u " << u;
      ASSERT_EQ(std::bit_cast<uint64_t>(a.x), std::bit_cast<uint64_t>(b.x)) << "u " << u;
      ASSERT_EQ(std::bit_cast<uint64_t>(a.pdf), std::bit_cast<uint64_t>(b.pdf)) << "u " << u;
      ++compared;
    }
    for (int i = 0; i <= 1000; ++i) {  // pdf(x) also divides the same way
      const double x = -1.5 + 5.25 * i / 1000;
      ASSERT_EQ(std::bit_cast<uint64_t>(d.pdf(x)), std::bit_cast<uint64_t>(ref.pdf(x)))
          << "x " << x;
    }
  }
  EXPECT_GT(compared, 200000);
}

TEST(FilterSampleIdentity, WeightIsEvalOverPdfBitForBit) {
  // Radii differing per axis, so that an axis' table used for the other would show.
  const GaussianFilter gauss(Vec2(1.5, 2.25), 0.6);
  const GaussianFilter gauss_default;
  const MitchellFilter mitchell(Vec2(2.0, 1.25), 0.4, 0.3);
  const LanczosSincFilter sinc(Vec2(3.0, 4.0), 2.5);
  std::mt19937_64 rng(2929);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const std::vector<const Filter*> filters = {&gauss, &gauss_default, &mitchell, &sinc};
  for (const Filter* f : filters) {
    const Vec2 r = f->radius();
    const int nx = static_cast<int>(std::ceil(32 * r.x)) * 2;
    const int ny = static_cast<int>(std::ceil(32 * r.y)) * 2;
    // A point within 1e-9 of a sampling cell's edge may be given the neighbour's density by
    // pdf(p); those are skipped (and counted).
    auto nearEdge = [](double x, double rr, int n) {
      const double c = (x + rr) / (2 * rr) * n;
      return std::abs(c - std::round(c)) < 1e-9;
    };
    int checked = 0, skipped = 0, negative = 0;
    for (int i = 0; i < 20000; ++i) {
      const Vec2 u(uni(rng), uni(rng));
      const FilterSample s = f->sample(u);
      if (nearEdge(s.p.x, r.x, nx) || nearEdge(s.p.y, r.y, ny)) {
        ++skipped;
        continue;
      }
      const double expected = f->eval(s.p) / f->pdf(s.p);
      ASSERT_EQ(std::bit_cast<uint64_t>(s.weight), std::bit_cast<uint64_t>(expected))
          << "u (" << u.x << ", " << u.y << ") weight " << s.weight << " expected " << expected;
      negative += s.weight < 0;
      ++checked;
    }
    EXPECT_LT(skipped, 20);
    EXPECT_GT(checked, 19900);
    if (f == &mitchell || f == &sinc) {
      EXPECT_GT(negative, 0);  // the negative lobes are drawn
    }
  }
}

}  // namespace
