// The padded Sobol and stratified samplers and the Sobol building blocks (sampling/sampler)
// against a plain transcription of their definitions written here: the MurmurHash3 finaliser,
// the hash chain of (pixel, dimension, seed), the cycle-walking index permutation, the Sobol
// generator matrices column by column, bit reversal bit by bit, the Laine-Karras/Burley
// scrambling, and PCG32 with a jump ahead by recursive halving.
// The sampler keeps per-(pixel, dimension) work between calls; the values are compared in
// orders that reuse and defeat that.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "lensim/sampling/sampler.h"
#include "lensim/sampling/sampling.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

// ---- the reference ------------------------------------------------------------------------

// MurmurHash3's 64-bit finaliser (Appleby).
uint64_t refFmix64(uint64_t k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdULL;
  k ^= k >> 33;
  k *= 0xc4ceb9fe1a85ec53ULL;
  k ^= k >> 33;
  return k;
}

uint64_t refHashValues(const std::vector<uint64_t>& values) {
  uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (uint64_t v : values) h = refFmix64(h ^ refFmix64(v + 0x632be59bd9b4e019ULL));
  return h;
}

// The element at index i of the permutation of [0, n) keyed by seed: three rounds of
// (xor key, odd multiply, xorshift, multiply-add, xorshift) on the power-of-two domain, repeated
// until the value falls below n.
uint32_t refPermutation(uint32_t i, uint32_t n, uint64_t seed) {
  uint32_t w = 1;
  while (w < n) w *= 2;
  const uint32_t mask = w - 1;
  uint32_t x = i;
  do {
    for (uint64_t round = 0; round < 3; ++round) {
      const uint64_t key = refFmix64(seed + round);
      x = (x ^ uint32_t(key)) & mask;
      x = (x * (uint32_t(key >> 32) | 1u)) & mask;
      x = (x ^ (x >> 3)) & mask;
      x = (x * 0x2c1b3c6dU + uint32_t(key >> 17)) & mask;
      x = (x ^ (x >> 7)) & mask;
    }
  } while (x >= n);
  return x;
}

// Sobol dimensions 0 and 1 from their generator matrices' columns (Joe & Kuo: dimension 0 the
// identity; dimension 1 from the polynomial x + 1, m_k = m_{k-1} xor 2 m_{k-1}).
uint32_t refSobol(uint32_t a, int dim) {
  uint32_t v = 0, m = 1;
  for (int k = 0; k < 32; ++k, m ^= m << 1)
    if ((a >> k) & 1) v ^= dim == 0 ? (1u << (31 - k)) : (m << (31 - k));
  return v;
}

uint32_t refReverse(uint32_t v) {
  uint32_t r = 0;
  for (int b = 0; b < 32; ++b) r |= ((v >> b) & 1u) << (31 - b);
  return r;
}

// Laine-Karras hash with Burley's constants on the reversed value, seed mixed first.
uint32_t refOwen(uint32_t v, uint64_t seed) {
  const uint32_t s = uint32_t(refFmix64(seed));
  uint32_t x = refReverse(v);
  x ^= x * 0x3d20adeaU;
  x += s;
  x *= (s >> 16) | 1U;
  x ^= x * 0x05526c56U;
  x ^= x * 0x53a22864U;
  return refReverse(x);
}

double refUnit(uint32_t v) { return std::min(v * 0x1p-32, 1 - 0x1p-53); }

struct RefPaddedSobol {
  int spp, seed;
  uint64_t hash(int x, int y, int dim) const {
    const uint64_t pixel = (uint64_t(uint32_t(x)) << 32) | uint32_t(y);
    return refHashValues({pixel, uint64_t(dim), uint64_t(seed), 3});
  }
  double get1D(int x, int y, int i, int dim) const {
    const uint64_t h = hash(x, y, dim);
    const uint32_t j = refPermutation(uint32_t(i % spp), uint32_t(spp), h);
    return refUnit(refOwen(refSobol(j, 0), refFmix64(h + 1)));
  }
  Vec2 get2D(int x, int y, int i, int dim) const {
    const uint64_t h = hash(x, y, dim);
    const uint32_t j = refPermutation(uint32_t(i % spp), uint32_t(spp), h);
    return {refUnit(refOwen(refSobol(j, 0), refFmix64(h + 1))),
            refUnit(refOwen(refSobol(j, 1), refFmix64(h + 2)))};
  }
};

// PCG32 (O'Neill 2014; XSH RR output, pcg32_srandom's initialisation) with a jump of n steps
// composed from the affine step x -> a x + c by recursive halving.
struct RefPcg {
  static constexpr uint64_t kMul = 6364136223846793005ULL;
  uint64_t state = 0, inc = 1;
  RefPcg(uint64_t sequence, uint64_t seed) : inc((sequence << 1) | 1) {
    next();
    state += seed;
    next();
  }
  uint32_t next() {
    const uint64_t old = state;
    state = old * kMul + inc;
    const uint32_t xorshifted = uint32_t(((old >> 18) ^ old) >> 27);
    const uint32_t rot = uint32_t(old >> 59);
    return (xorshifted >> rot) | (xorshifted << ((32 - rot) & 31));
  }
  // (a, c) of n steps: x -> a x + c.
  std::pair<uint64_t, uint64_t> jump(uint64_t n) const {
    if (n == 0) return {1, 0};
    auto [a, c] = jump(n / 2);
    uint64_t a2 = a * a, c2 = a * c + c;  // twice the half
    if (n % 2) c2 = kMul * c2 + inc, a2 = kMul * a2;  // one more step
    return {a2, c2};
  }
  void advance(uint64_t n) {
    auto [a, c] = jump(n);
    state = a * state + c;
  }
  double uniform() {
    const uint64_t hi = next(), lo = next();
    return double(((hi << 32) | lo) >> 11) * 0x1p-53;
  }
};

// Stratified: the sample's stratum is the permuted sample index (per pixel and dimension), the
// jitter two PCG32 outputs per coordinate from the pixel's stream at index * 2^17 + 2 dim.
struct RefStratified {
  int xs, ys, seed;
  bool jitter;
  uint64_t pixelKey(int x, int y) const { return (uint64_t(uint32_t(x)) << 32) | uint32_t(y); }
  uint32_t stratum(int x, int y, int i, int dim) const {
    const uint32_t n = uint32_t(xs * ys);
    return refPermutation(uint32_t(i) % n, n,
                          refHashValues({pixelKey(x, y), uint64_t(dim), uint64_t(seed)}));
  }
  RefPcg rng(int x, int y, int i, int dim) const {
    RefPcg r(refHashValues({pixelKey(x, y), uint64_t(seed), 2}), 0);
    r.advance((uint64_t(i) << 17) + 2 * uint64_t(dim));
    return r;
  }
  double get1D(int x, int y, int i, int dim) const {
    const int n = xs * ys;
    RefPcg r = rng(x, y, i, dim);
    const double delta = jitter ? r.uniform() : 0.5;
    return std::min((stratum(x, y, i, dim) + delta) / n, 1 - 0x1p-53);
  }
  Vec2 get2D(int x, int y, int i, int dim) const {
    const uint32_t s = stratum(x, y, i, dim);
    RefPcg r = rng(x, y, i, dim);
    const double dx = jitter ? r.uniform() : 0.5;
    const double dy = jitter ? r.uniform() : 0.5;
    return {std::min((int(s) % xs + dx) / xs, 1 - 0x1p-53),
            std::min((int(s) / xs + dy) / ys, 1 - 0x1p-53)};
  }
};

// A small deterministic generator for the access order and inputs (not the code under test).
struct Lcg {
  uint64_t s;
  uint32_t next(uint32_t n) {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    return uint32_t((s >> 33) % n);
  }
};

// ---- the building blocks ------------------------------------------------------------------

TEST(SobolBlocks, MatchTheirDefinitions) {
  Lcg rng{1};
  for (int k = 0; k < 200000; ++k) {
    const uint32_t a = k < 70000 ? uint32_t(k) : rng.next(0xffffffffu) ^ (rng.next(4) << 30);
    ASSERT_EQ(sobolDimension0(a), refSobol(a, 0)) << a;
    ASSERT_EQ(sobolDimension1(a), refSobol(a, 1)) << a;
    const uint64_t seed = (uint64_t(rng.next(0xffffffffu)) << 32) | rng.next(0xffffffffu);
    ASSERT_EQ(owenScramble(a, seed), refOwen(a, seed)) << a << " seed " << seed;
  }
  EXPECT_EQ(sobolDimension1(0xffffffffu), refSobol(0xffffffffu, 1));
}

TEST(PermutationElement, KeysMatchTheDefinition) {
  Lcg rng{2};
  for (uint32_t n : {1u, 2u, 3u, 5u, 16u, 24u, 100u, 256u, 1000u, 4097u})
    for (int t = 0; t < 40; ++t) {
      const uint64_t seed = (uint64_t(rng.next(0xffffffffu)) << 32) | rng.next(0xffffffffu);
      const PermutationKeys keys(seed);
      for (uint32_t i = 0; i < n; i += 1 + n / 64) {
        const uint32_t want = refPermutation(i, n, seed);
        ASSERT_EQ(uint32_t(permutationElement(i, n, seed)), want) << i << " of " << n;
        ASSERT_EQ(uint32_t(permutationElement(i, n, keys)), want) << i << " of " << n;
      }
    }
}

// ---- the sampler --------------------------------------------------------------------------

TEST(PaddedSobolSampler, MatchesItsDefinitionInAnyAccessOrder) {
  for (int spp_asked : {1, 2, 16, 24, 64})
    for (int seed : {0, 5}) {
      SCOPED_TRACE(testing::Message() << spp_asked << " spp seed " << seed);
      PaddedSobolSampler s(spp_asked, seed);
      RefPaddedSobol ref{s.samplesPerPixel(), seed};
      Lcg rng{uint64_t(spp_asked * 31 + seed)};
      const int px[3] = {0, 117, -3}, py[3] = {0, 40, 7};
      for (int q = 0; q < 3000; ++q) {
        // First a pixel's samples in order, pixels in turn; then anything.
        const int k = q < 1000 ? (q / s.samplesPerPixel()) % 3 : int(rng.next(3));
        const int i = q < 1000 ? q % s.samplesPerPixel() : int(rng.next(3 * 64));
        const int starts[4] = {0, int(rng.next(12)), 250 + int(rng.next(8)), int(rng.next(300))};
        int dim = starts[rng.next(4)];
        s.startPixelSample({px[k], py[k]}, i, dim);
        for (int draw = 0; draw < 8; ++draw) {
          ASSERT_EQ(s.dimension(), dim);
          if (rng.next(2) == 0) {
            ASSERT_EQ(s.get1D(), ref.get1D(px[k], py[k], i, dim))
                << "pixel " << px[k] << "," << py[k] << " sample " << i << " dimension " << dim;
            dim += 1;
          } else {
            ASSERT_EQ(s.get2D(), ref.get2D(px[k], py[k], i, dim))
                << "pixel " << px[k] << "," << py[k] << " sample " << i << " dimension " << dim;
            dim += 2;
          }
        }
      }
    }
}

// A clone draws what the original draws, whatever the original drew before.
TEST(PaddedSobolSampler, CloneMatchesItsDefinition) {
  PaddedSobolSampler s(16, 3);
  s.startPixelSample({4, 4}, 2);
  for (int k = 0; k < 5; ++k) s.get2D();
  auto c = s.clone();
  RefPaddedSobol ref{16, 3};
  c->startPixelSample({4, 4}, 5, 2);
  EXPECT_EQ(c->get2D(), ref.get2D(4, 4, 5, 2));
  c->startPixelSample({5, 4}, 5, 2);
  EXPECT_EQ(c->get1D(), ref.get1D(5, 4, 5, 2));
}

TEST(StratifiedSampler, MatchesItsDefinitionInAnyAccessOrder) {
  struct Case {
    int xs, ys;
    bool jitter;
    int seed;
  };
  for (Case c : {Case{4, 4, true, 0}, Case{5, 3, true, 2}, Case{8, 8, false, 1}, Case{1, 1, true, 0},
                 Case{7, 1, true, 3}}) {
    SCOPED_TRACE(testing::Message() << c.xs << "x" << c.ys << " jitter " << c.jitter);
    StratifiedSampler s(c.xs, c.ys, c.jitter, c.seed);
    RefStratified ref{c.xs, c.ys, c.seed, c.jitter};
    const int n = c.xs * c.ys;
    Lcg rng{uint64_t(n * 13 + c.seed)};
    const int px[3] = {0, 63, -2}, py[3] = {0, 9, 5};
    for (int q = 0; q < 1500; ++q) {
      const int k = q < 500 ? (q / n) % 3 : int(rng.next(3));
      const int i = q < 500 ? q % n : int(rng.next(uint32_t(3 * n)));
      const int starts[4] = {0, int(rng.next(12)), 250 + int(rng.next(8)), int(rng.next(300))};
      int dim = starts[rng.next(4)];
      s.startPixelSample({px[k], py[k]}, i, dim);
      for (int draw = 0; draw < 6; ++draw) {
        ASSERT_EQ(s.dimension(), dim);
        if (rng.next(2) == 0) {
          ASSERT_EQ(s.get1D(), ref.get1D(px[k], py[k], i, dim))
              << "pixel " << px[k] << "," << py[k] << " sample " << i << " dimension " << dim;
          dim += 1;
        } else {
          ASSERT_EQ(s.get2D(), ref.get2D(px[k], py[k], i, dim))
              << "pixel " << px[k] << "," << py[k] << " sample " << i << " dimension " << dim;
          dim += 2;
        }
      }
    }
  }
}

}  // namespace
}  // namespace lensim::render
