// Samplers: determinism per (pixel, sample index), stratification, uniformity.
#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <vector>

#include "lensim/sampling/sampler.h"
#include "stats.h"

using namespace lensim;
using namespace lensim::sampling;

namespace {

std::vector<std::unique_ptr<Sampler>> allSamplers(int spp) {
  std::vector<std::unique_ptr<Sampler>> s;
  s.push_back(std::make_unique<IndependentSampler>(spp, 3));
  s.push_back(std::make_unique<StratifiedSampler>(4, spp / 4, true, 3));
  s.push_back(std::make_unique<PaddedSobolSampler>(spp, 3));
  return s;
}

std::vector<double> draw(Sampler& s, Point2i p, int index) {
  s.startPixelSample(p, index);
  std::vector<double> v;
  const Vec2 a = s.getPixel2D();
  v.insert(v.end(), {a.x, a.y, s.get1D()});
  const Vec2 b = s.get2D();
  v.insert(v.end(), {b.x, b.y, s.get1D(), s.get1D()});
  return v;
}

// Number of points of a 2-D set falling in each cell of a cx x cy grid.
std::vector<int> cellCounts(const std::vector<Vec2>& pts, int cx, int cy) {
  std::vector<int> c(cx * cy, 0);
  for (const Vec2& p : pts) ++c[int(p.y * cy) * cx + int(p.x * cx)];
  return c;
}

}  // namespace

TEST(Sampler, ValuesDependOnlyOnPixelAndSampleIndex) {
  for (auto& s : allSamplers(16)) {
    // Draw pixel samples in two different orders, and from a clone: same values.
    std::vector<std::vector<double>> forward, backward(16);
    for (int i = 0; i < 16; ++i) forward.push_back(draw(*s, {5, 9}, i));
    auto other = s->clone();
    draw(*other, {100, 3}, 7);  // unrelated work in between
    for (int i = 15; i >= 0; --i) backward[i] = draw(*other, {5, 9}, i);
    EXPECT_EQ(forward, backward);
    // Different pixels differ.
    EXPECT_NE(draw(*s, {5, 9}, 0), draw(*s, {6, 9}, 0));
    for (const auto& v : forward)
      for (double x : v) {
        EXPECT_GE(x, 0.0);
        EXPECT_LT(x, 1.0);
      }
  }
}

TEST(Sampler, StartingAtADimensionMatchesDrawingUpToIt) {
  for (auto& s : allSamplers(16)) {
    s->startPixelSample({1, 2}, 3);
    s->get2D();
    s->get1D();
    const Vec2 a = s->get2D();
    s->startPixelSample({1, 2}, 3, 3);
    EXPECT_EQ(s->get2D(), a);
  }
}

// dimension() says where a restart continues: the renderer draws a batch of samples' camera
// values, then restarts each sample there for its path.
TEST(Sampler, RestartingAtTheReportedDimensionContinuesTheSample) {
  for (auto& s : allSamplers(16)) {
    s->startPixelSample({4, 7}, 5);
    EXPECT_EQ(s->dimension(), 0);
    s->get1D();
    s->getPixel2D();
    s->get2D();
    s->get1D();
    const int d = s->dimension();
    EXPECT_EQ(d, 6);
    const double a = s->get1D();
    const Vec2 b = s->get2D();
    s->startPixelSample({0, 0}, 1);  // other work in between
    s->get2D();
    s->startPixelSample({4, 7}, 5, d);
    EXPECT_EQ(s->get1D(), a);
    EXPECT_EQ(s->get2D(), b);
  }
}

TEST(StratifiedSampler, OneSamplePerStratumInEveryDimension) {
  StratifiedSampler s(4, 4, true, 0);
  for (Point2i p : {Point2i(0, 0), Point2i(13, 7)}) {
    std::vector<Vec2> d0, d3;
    std::vector<double> d2;
    for (int i = 0; i < 16; ++i) {
      s.startPixelSample(p, i);
      d0.push_back(s.getPixel2D());
      d2.push_back(s.get1D());
      d3.push_back(s.get2D());
    }
    for (int c : cellCounts(d0, 4, 4)) EXPECT_EQ(c, 1);
    for (int c : cellCounts(d3, 4, 4)) EXPECT_EQ(c, 1);
    std::set<int> strata;
    for (double x : d2) strata.insert(int(x * 16));
    EXPECT_EQ(strata.size(), 16u);
  }
}

TEST(PaddedSobolSampler, EveryDimensionPairIsA02Net) {
  // 64 samples of a (0,2)-sequence: each elementary interval of area 1/64 holds one point.
  PaddedSobolSampler s(64, 1);
  for (Point2i p : {Point2i(0, 0), Point2i(31, 17)}) {
    std::vector<Vec2> pairs[3];
    for (int i = 0; i < 64; ++i) {
      s.startPixelSample(p, i);
      for (auto& pair : pairs) pair.push_back(s.get2D());
    }
    for (const auto& pts : pairs)
      for (int k = 0; k <= 6; ++k)
        for (int c : cellCounts(pts, 1 << k, 1 << (6 - k))) EXPECT_EQ(c, 1) << "k=" << k;
  }
  EXPECT_EQ(PaddedSobolSampler(100).samplesPerPixel(), 128);
}

TEST(PaddedSobolSampler, DimensionPairsAreDecorrelated) {
  // Pairs (dimension 0 of pair A, dimension 0 of pair B) must not be identical or correlated.
  PaddedSobolSampler s(256, 2);
  lensim::test::RunningStats prod;
  for (int i = 0; i < 256; ++i) {
    s.startPixelSample({4, 4}, i);
    const double a = s.get2D().x;
    const double b = s.get2D().x;
    prod.add((a - 0.5) * (b - 0.5));
  }
  // Covariance of independent uniforms is 0 with standard error ~ (1/12)/sqrt(n).
  EXPECT_NEAR(prod.mean, 0.0, 4.5 * prod.stderror());
}

TEST(IndependentSampler, IsUniform) {
  IndependentSampler s(1);
  lensim::test::RunningStats m, v;
  for (int px = 0; px < 200; ++px)
    for (int i = 0; i < 100; ++i) {
      s.startPixelSample({px, 0}, i);
      const double x = s.get1D();
      m.add(x);
      v.add((x - 0.5) * (x - 0.5));
    }
  EXPECT_NEAR(m.mean, 0.5, 4.5 * m.stderror());
  EXPECT_NEAR(v.mean, 1.0 / 12, 4.5 * v.stderror());
}

TEST(SobolDimensions, FirstValuesMatchTheSequence) {
  // Dimension 0 (van der Corput): 0, 1/2, 1/4, 3/4; dimension 1: 0, 1/2, 3/4, 1/4.
  const double d0[] = {0, 0.5, 0.25, 0.75}, d1[] = {0, 0.5, 0.75, 0.25};
  for (uint32_t i = 0; i < 4; ++i) {
    EXPECT_EQ(sobolDimension0(i) * 0x1p-32, d0[i]);
    EXPECT_EQ(sobolDimension1(i) * 0x1p-32, d1[i]);
  }
}

// The samplers' per-pixel key cache: each dimension's value is made once per pixel below
// kSamplerCachedDimensions, at every lookup from there on, and again after a new pixel.
TEST(DimensionCache, MakesOncePerPixelBelowTheCachedDimensions) {
  DimensionCache<int> cache;
  int made = 0;
  auto value = [&](int dim, int pixel) {
    return cache.get(dim, [&] {
      ++made;
      return dim * 1000 + pixel;
    });
  };
  const int last = kSamplerCachedDimensions + 10;
  for (int pixel = 0; pixel < 3; ++pixel) {
    cache.newPixel();
    made = 0;
    for (int round = 0; round < 2; ++round)
      for (int dim = 0; dim < last; ++dim) EXPECT_EQ(value(dim, pixel), dim * 1000 + pixel);
    EXPECT_EQ(made, kSamplerCachedDimensions + 2 * 10) << pixel;
  }
}

// The cache is invisible in the values: a sample's values at dimensions below and beyond the
// cached ones, drawn after other pixels' samples, equal those of a newly made sampler (empty
// cache) started right at that dimension.
TEST(Sampler, CachedKeysGiveTheValuesOfANewSampler) {
  auto samplers = allSamplers(16);
  for (size_t k = 0; k < samplers.size(); ++k) {
    Sampler& s = *samplers[k];
    const int dims[] = {0, 8, kSamplerCachedDimensions - 2, kSamplerCachedDimensions,
                        kSamplerCachedDimensions + 42};
    for (Point2i p : {Point2i{3, 4}, Point2i{9, 1}, Point2i{3, 4}})
      for (int index : {0, 5, 15})
        for (int dim : dims) {
          s.startPixelSample(p, index);
          for (int d = 0; d < dim; d += 2) s.get2D();  // the dimensions before, cached
          const Vec2 a = s.get2D();
          const double b = s.get1D();
          auto fresh = std::move(allSamplers(16)[k]);
          fresh->startPixelSample(p, index, dim);
          EXPECT_EQ(fresh->get2D(), a) << k << " " << dim;
          EXPECT_EQ(fresh->get1D(), b) << k << " " << dim;
        }
  }
}
