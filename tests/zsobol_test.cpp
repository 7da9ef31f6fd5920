// pbrt-v4's ZSobolSampler (sampling/sampler): values against an independent transcription of
// pbrt-v4's published algorithm (src/pbrt/samplers.h ZSobolSampler, util/lowdiscrepancy.h
// SobolSample and the scramblers, util/hash.h MurmurHash64A and MixBits, util/vecmath.h
// EncodeMorton2), written here bit by bit; and the stratification the construction promises.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <vector>

#include "lensim/sampling/sampler.h"
#include "lensim/util/error.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

// ---- the reference ------------------------------------------------------------------------

uint64_t refMixBits(uint64_t v) {
  v ^= (v >> 31);
  v *= 0x7fb5d329728ea185ULL;
  v ^= (v >> 27);
  v *= 0x81dadef4bc2dd44dULL;
  v ^= (v >> 33);
  return v;
}

// MurmurHash64A over a byte buffer, as util/hash.h has it (any length).
uint64_t refMurmur64A(const unsigned char* key, size_t len, uint64_t seed) {
  const uint64_t m = 0xc6a4a7935bd1e995ull;
  const int r = 47;
  uint64_t h = seed ^ (len * m);
  const unsigned char* end = key + 8 * (len / 8);
  while (key != end) {
    uint64_t k;
    std::memcpy(&k, key, sizeof(uint64_t));
    key += 8;
    k *= m;
    k ^= k >> r;
    k *= m;
    h ^= k;
    h *= m;
  }
  switch (len & 7) {
    case 7:
      h ^= uint64_t(key[6]) << 48;
      [[fallthrough]];
    case 6:
      h ^= uint64_t(key[5]) << 40;
      [[fallthrough]];
    case 5:
      h ^= uint64_t(key[4]) << 32;
      [[fallthrough]];
    case 4:
      h ^= uint64_t(key[3]) << 24;
      [[fallthrough]];
    case 3:
      h ^= uint64_t(key[2]) << 16;
      [[fallthrough]];
    case 2:
      h ^= uint64_t(key[1]) << 8;
      [[fallthrough]];
    case 1:
      h ^= uint64_t(key[0]);
      h *= m;
  }
  h ^= h >> r;
  h *= m;
  h ^= h >> r;
  return h;
}

uint64_t refHash(int dimension, int seed) {
  unsigned char buf[8];
  std::memcpy(buf, &dimension, 4);
  std::memcpy(buf + 4, &seed, 4);
  return refMurmur64A(buf, 8, 0);
}

// Morton code by interleaving bit by bit: x in the even bits, y in the odd bits.
uint64_t refMorton(uint32_t x, uint32_t y) {
  uint64_t m = 0;
  for (int b = 0; b < 32; ++b)
    m |= (uint64_t((x >> b) & 1) << (2 * b)) | (uint64_t((y >> b) & 1) << (2 * b + 1));
  return m;
}

// Sobol generator matrices of dimensions 0 and 1 as columns (Joe & Kuo: dimension 0 the
// identity; dimension 1 from the polynomial x + 1, m_1 = 1, so m_k = m_{k-1} xor 2 m_{k-1}).
uint32_t refSobol(uint64_t a, int dim) {
  uint32_t v = 0;
  uint32_t m = 1;  // m_k (odd, < 2^(k+1)); column k is m_k << (31 - k)
  for (int k = 0; k < 32 && a != 0; ++k, a >>= 1) {
    const uint32_t column = dim == 0 ? (1u << (31 - k)) : (m << (31 - k));
    if (a & 1) v ^= column;
    m = m ^ (m << 1);
  }
  return v;
}

uint32_t refReverse(uint32_t v) {
  uint32_t r = 0;
  for (int b = 0; b < 32; ++b) r |= ((v >> b) & 1u) << (31 - b);
  return r;
}

uint32_t refFastOwen(uint32_t v, uint32_t seed) {
  v = refReverse(v);
  v ^= v * 0x3d20adea;
  v += seed;
  v *= (seed >> 16) | 1;
  v ^= v * 0x05526c56;
  v ^= v * 0x53a22864;
  return refReverse(v);
}

struct RefZSobol {
  int log2spp, nBase4Digits, seed;
  RefZSobol(int spp, int resx, int resy, int seed_) : seed(seed_) {
    log2spp = 0;
    while ((1 << log2spp) < spp) ++log2spp;
    int res = 1;
    while (res < std::max(resx, resy)) res *= 2;
    int log2res = 0;
    while ((1 << log2res) < res) ++log2res;
    nBase4Digits = log2res + (log2spp + 1) / 2;
  }
  uint64_t sampleIndex(uint64_t mortonIndex, int dimension) const {
    static const uint8_t permutations[24][4] = {
        {0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 1, 3}, {0, 2, 3, 1}, {0, 3, 2, 1}, {0, 3, 1, 2},
        {1, 0, 2, 3}, {1, 0, 3, 2}, {1, 2, 0, 3}, {1, 2, 3, 0}, {1, 3, 2, 0}, {1, 3, 0, 2},
        {2, 1, 0, 3}, {2, 1, 3, 0}, {2, 0, 1, 3}, {2, 0, 3, 1}, {2, 3, 0, 1}, {2, 3, 1, 0},
        {3, 1, 2, 0}, {3, 1, 0, 2}, {3, 2, 1, 0}, {3, 2, 0, 1}, {3, 0, 2, 1}, {3, 0, 1, 2}};
    uint64_t sampleIndex = 0;
    bool pow2Samples = log2spp & 1;
    int lastDigit = pow2Samples ? 1 : 0;
    for (int i = nBase4Digits - 1; i >= lastDigit; --i) {
      int digitShift = 2 * i - (pow2Samples ? 1 : 0);
      int digit = (mortonIndex >> digitShift) & 3;
      uint64_t higherDigits = mortonIndex >> (digitShift + 2);
      int p = (refMixBits(higherDigits ^ (0x55555555u * uint64_t(dimension))) >> 24) % 24;
      digit = permutations[p][digit];
      sampleIndex |= uint64_t(digit) << digitShift;
    }
    if (pow2Samples) {
      int digit = mortonIndex & 1;
      sampleIndex |=
          digit ^ (refMixBits((mortonIndex >> 1) ^ (0x55555555u * uint64_t(dimension))) & 1);
    }
    return sampleIndex;
  }
  // The values of pbrt-v4's StartPixelSample(p, index); Get2D(); Get1D(); Get2D().
  std::vector<double> values(int px, int py, int index) const {
    const uint64_t morton = (refMorton(uint32_t(px), uint32_t(py)) << log2spp) | uint64_t(index);
    std::vector<double> out;
    int dimension = 0;
    auto unit = [](uint32_t v) { return std::min(v * 0x1p-32, 1 - 0x1p-53); };
    auto get2D = [&] {
      uint64_t si = sampleIndex(morton, dimension);
      dimension += 2;
      uint64_t bits = refHash(dimension, seed);
      out.push_back(unit(refFastOwen(refSobol(si, 0), uint32_t(bits))));
      out.push_back(unit(refFastOwen(refSobol(si, 1), uint32_t(bits >> 32))));
    };
    get2D();
    uint64_t si = sampleIndex(morton, dimension);
    ++dimension;
    out.push_back(unit(refFastOwen(refSobol(si, 0), uint32_t(refHash(dimension, seed)))));
    get2D();
    return out;
  }
};

TEST(ZSobol, ReferenceHashMatchesMurmurHash64AKnownValue) {
  // MurmurHash64A of the empty input with seed 0 is 0 (h = 0 stays 0 through the finaliser),
  // and with any input it is a bijection of the 8-byte word: distinct words, distinct hashes.
  EXPECT_EQ(refMurmur64A(nullptr, 0, 0), 0u);
  std::set<uint64_t> seen;
  for (int d = 0; d < 64; ++d) seen.insert(refHash(d, 7));
  EXPECT_EQ(seen.size(), 64u);
}

TEST(ZSobol, MatchesPbrtV4Definition) {
  struct Case {
    int spp, resx, resy, seed;
  };
  for (Case c : {Case{16, 200, 200, 0}, Case{64, 320, 240, 3}, Case{8, 33, 17, 0},
                 Case{1, 64, 64, 5}, Case{32, 1000, 10, -2}, Case{4, 7, 1, 0}}) {
    SCOPED_TRACE(testing::Message() << c.spp << " spp " << c.resx << "x" << c.resy);
    RefZSobol ref(c.spp, c.resx, c.resy, c.seed);
    ZSobolSampler s(c.spp, {c.resx, c.resy}, SobolRandomization::FastOwen, c.seed);
    EXPECT_EQ(s.samplesPerPixel(), c.spp);
    for (int py : {0, 1, c.resy / 2, c.resy - 1})
      for (int px : {0, 3, c.resx - 1})
        for (int i = 0; i < c.spp; ++i) {
          s.startPixelSample({px, py}, i);
          std::vector<double> got;
          Vec2 a = s.get2D();
          double b = s.get1D();
          Vec2 d = s.get2D();
          got = {a.x, a.y, b, d.x, d.y};
          ASSERT_EQ(got, ref.values(px, py, i)) << px << "," << py << " sample " << i;
        }
  }
}

// Starting at a dimension gives the values drawing up to it gives.
TEST(ZSobol, RestartsAtADimension) {
  ZSobolSampler s(16, {64, 64}, SobolRandomization::FastOwen, 1);
  s.startPixelSample({5, 9}, 3);
  s.get2D();
  s.get1D();
  EXPECT_EQ(s.dimension(), 3);
  const Vec2 want = s.get2D();
  s.startPixelSample({5, 9}, 3, 3);
  EXPECT_EQ(s.get2D(), want);
  auto c = s.clone();
  c->startPixelSample({5, 9}, 3, 3);
  EXPECT_EQ(c->get2D(), want);
}

// With 4^k samples a pixel's sample indices of one dimension are an aligned block of the
// Sobol sequence (the digit permutations keep the pixel's subtree together), so each 2-D
// dimension is a (0, 2k, 2)-net: every elementary interval of area 4^-k holds one point.
// With 2^(2k+1) samples the same holds for the intervals of area 2^-(2k+1). Checked here on the
// points directly, for every randomisation.
TEST(ZSobol, EveryPixelIsAZeroTwoNet) {
  for (auto r : {SobolRandomization::None, SobolRandomization::PermuteDigits,
                 SobolRandomization::FastOwen, SobolRandomization::Owen})
    for (int log2n : {2, 4, 5, 6}) {
      const int n = 1 << log2n;
      ZSobolSampler s(n, {37, 21}, r, 11);
      for (int px : {0, 17, 36})
        for (int dim : {0, 2, 5}) {
          std::vector<Vec2> pts;
          for (int i = 0; i < n; ++i) {
            s.startPixelSample({px, px % 21}, i, dim);
            pts.push_back(s.get2D());
          }
          for (int a = 0; a <= log2n; ++a) {
            const int nx = 1 << a, ny = n / nx;
            std::vector<int> count(size_t(n), 0);
            for (Vec2 p : pts) ++count[size_t(int(p.y * ny) * nx + int(p.x * nx))];
            for (int c : count)
              ASSERT_EQ(c, 1) << "randomization " << int(r) << " n " << n << " dim " << dim << " "
                              << nx << "x" << ny;
          }
          // 1-D values are stratified too: one per interval of length 1/n.
          std::vector<int> count(size_t(n), 0);
          for (int i = 0; i < n; ++i) {
            s.startPixelSample({px, 3}, i, dim);
            ++count[size_t(s.get1D() * n)];
          }
          for (int c : count) ASSERT_EQ(c, 1);
        }
    }
}

// A count that is not a power of two renders that many samples, all distinct and inside the
// pixel's block; pixels draw distinct values.
TEST(ZSobol, KeepsTheRequestedCount) {
  ZSobolSampler s(24, {100, 100});
  EXPECT_EQ(s.samplesPerPixel(), 24);
  std::set<std::pair<double, double>> seen;
  for (int i = 0; i < 24; ++i) {
    s.startPixelSample({4, 4}, i);
    Vec2 v = s.get2D();
    EXPECT_TRUE(seen.insert({v.x, v.y}).second);
  }
  EXPECT_THROW(ZSobolSampler(0, {10, 10}), Error);
  EXPECT_THROW(parseSobolRandomization("sobol"), Error);
  EXPECT_EQ(parseSobolRandomization(""), SobolRandomization::FastOwen);
}


// ---- any order of access, every randomisation ---------------------------------------------
// The sampler keeps per-dimension work for the current pixel and sample block; these tests draw
// in orders that defeat and reuse it (pixels interleaved, samples out of order, restarts at a
// dimension, dimensions past the cached ones) and compare each value with the reference.

// pbrt-v4's OwenScrambler (util/lowdiscrepancy.h).
uint32_t refOwen(uint32_t v, uint32_t seed) {
  if (seed & 1) v ^= 1u << 31;
  for (int b = 1; b < 32; ++b) {
    uint32_t mask = (~0u) << (32 - b);
    if ((uint32_t)refMixBits((v & mask) ^ seed) & (1u << b)) v ^= 1u << (31 - b);
  }
  return v;
}

uint32_t refRandomize(uint32_t v, uint32_t seed, SobolRandomization r) {
  switch (r) {
    case SobolRandomization::None:
      return v;
    case SobolRandomization::PermuteDigits:
      return v ^ seed;
    case SobolRandomization::FastOwen:
      return refFastOwen(v, seed);
    case SobolRandomization::Owen:
      return refOwen(v, seed);
  }
  return v;
}

// pbrt-v4's Get1D / Get2D at `dimension` of the sample with Morton index `morton`.
double refGet1D(const RefZSobol& ref, uint64_t morton, int dimension, SobolRandomization r) {
  const uint64_t si = ref.sampleIndex(morton, dimension);
  const uint32_t hash = uint32_t(refHash(dimension + 1, ref.seed));
  return std::min(refRandomize(refSobol(si, 0), hash, r) * 0x1p-32, 1 - 0x1p-53);
}
Vec2 refGet2D(const RefZSobol& ref, uint64_t morton, int dimension, SobolRandomization r) {
  const uint64_t si = ref.sampleIndex(morton, dimension);
  const uint64_t bits = refHash(dimension + 2, ref.seed);
  return {std::min(refRandomize(refSobol(si, 0), uint32_t(bits), r) * 0x1p-32, 1 - 0x1p-53),
          std::min(refRandomize(refSobol(si, 1), uint32_t(bits >> 32), r) * 0x1p-32,
                   1 - 0x1p-53)};
}

// A small deterministic generator for the access order (not the code under test).
struct Lcg {
  uint64_t s;
  uint32_t next(uint32_t n) {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    return uint32_t((s >> 33) % n);
  }
};

TEST(ZSobol, MatchesPbrtV4InAnyAccessOrder) {
  struct Case {
    int spp, resx, resy, seed;
  };
  for (auto r : {SobolRandomization::FastOwen, SobolRandomization::None,
                 SobolRandomization::PermuteDigits, SobolRandomization::Owen})
    for (Case c : {Case{16, 200, 200, 0}, Case{64, 320, 240, 3}, Case{8, 33, 17, 0},
                   Case{2, 1, 1, 4}, Case{1, 1, 1, 0}, Case{1, 9, 9, 2}, Case{2, 50, 3, 0},
                   Case{128, 64, 64, 1}, Case{24, 100, 100, -5}, Case{4, 7, 1, 0}}) {
      SCOPED_TRACE(testing::Message() << "randomization " << int(r) << ", " << c.spp << " spp "
                                      << c.resx << "x" << c.resy << " seed " << c.seed);
      RefZSobol ref(c.spp, c.resx, c.resy, c.seed);
      ZSobolSampler s(c.spp, {c.resx, c.resy}, r, c.seed);
      Lcg rng{uint64_t(c.spp * 7919 + c.resx)};
      // Two pixels visited in turn, a pixel's samples in order then at random, starting
      // dimensions 0, small, and around the end of the cached dimensions.
      const int px[3] = {0, c.resx - 1, int(rng.next(uint32_t(c.resx)))};
      const int py[3] = {0, c.resy - 1, int(rng.next(uint32_t(c.resy)))};
      const int queries = r == SobolRandomization::FastOwen ? 3000 : 600;
      for (int q = 0; q < queries; ++q) {
        const int k = q < queries / 3 ? (q / c.spp) % 3 : int(rng.next(3));
        const int x = px[k], y = py[k];
        const int i = q < queries / 3 ? q % c.spp : int(rng.next(uint32_t(c.spp)));
        const int starts[4] = {0, int(rng.next(12)), 250 + int(rng.next(8)), int(rng.next(300))};
        int dim = starts[rng.next(4)];
        s.startPixelSample({x, y}, i, dim);
        const uint64_t morton = (refMorton(uint32_t(x), uint32_t(y)) << ref.log2spp) | uint64_t(i);
        for (int draw = 0; draw < 8; ++draw) {
          ASSERT_EQ(s.dimension(), dim);
          if (rng.next(2) == 0) {
            ASSERT_EQ(s.get1D(), refGet1D(ref, morton, dim, r))
                << "pixel " << x << "," << y << " sample " << i << " dimension " << dim;
            dim += 1;
          } else {
            ASSERT_EQ(s.get2D(), refGet2D(ref, morton, dim, r))
                << "pixel " << x << "," << y << " sample " << i << " dimension " << dim;
            dim += 2;
          }
        }
      }
    }
}

// Many pixels of a film, every sample, the dimensions a path draws: the pattern of a render.
TEST(ZSobol, MatchesPbrtV4OverAFilm) {
  const int spp = 16, res = 48;
  RefZSobol ref(spp, res, res, 9);
  ZSobolSampler s(spp, {res, res}, SobolRandomization::FastOwen, 9);
  for (int y = 0; y < res; y += 5)
    for (int x = 0; x < res; x += 3)
      for (int i = 0; i < spp; ++i) {
        s.startPixelSample({x, y}, i);
        const uint64_t morton = (refMorton(uint32_t(x), uint32_t(y)) << ref.log2spp) | uint64_t(i);
        for (int dim = 0; dim < 40;) {
          if (dim % 3 == 0) {
            ASSERT_EQ(s.get1D(), refGet1D(ref, morton, dim, SobolRandomization::FastOwen));
            dim += 1;
          } else {
            ASSERT_EQ(s.get2D(), refGet2D(ref, morton, dim, SobolRandomization::FastOwen));
            dim += 2;
          }
        }
      }
}

}  // namespace
}  // namespace lensim::render
