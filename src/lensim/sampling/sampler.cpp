#include "lensim/sampling/sampler.h"

#include <algorithm>
#include <bit>

#include <fmt/format.h>

#include "lensim/util/error.h"

namespace lensim::sampling {

namespace {
double toUnit(uint32_t v) {
  return std::min(v * 0x1p-32, kOneMinusEpsilon);
}
uint64_t pixelKey(Point2i p) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(p.x)) << 32) | static_cast<uint32_t>(p.y);
}
}  // namespace

// ---------------------------------------------------------------------------------------------

IndependentSampler::IndependentSampler(int samples_per_pixel, int seed)
    : spp_(samples_per_pixel), seed_(seed) {
  if (spp_ <= 0) throw Error(fmt::format("pixelsamples must be positive (got {})", spp_));
}

void IndependentSampler::startPixelSample(Point2i pixel, int sample_index, int dimension) {
  // Each sample index gets its own stretch of the stream (2^16 values per sample, 2 per value).
  rng_ = Rng(hashValues({pixelKey(pixel), static_cast<uint64_t>(seed_), 1}), 0);
  rng_.advance((static_cast<uint64_t>(sample_index) << 17) + 2 * static_cast<uint64_t>(dimension));
  dim_ = dimension;
}

std::unique_ptr<Sampler> IndependentSampler::clone() const {
  return std::make_unique<IndependentSampler>(*this);
}

// ---------------------------------------------------------------------------------------------

StratifiedSampler::StratifiedSampler(int x_samples, int y_samples, bool jitter, int seed)
    : xs_(x_samples), ys_(y_samples), seed_(seed), jitter_(jitter) {
  if (xs_ <= 0 || ys_ <= 0)
    throw Error(fmt::format("xsamples and ysamples must be positive (got {}, {})", xs_, ys_));
  pixel_rng_ = pixelRng();
}

Rng StratifiedSampler::pixelRng() const {
  return Rng(hashValues({pixelKey(pixel_), static_cast<uint64_t>(seed_), 2}), 0);
}

void StratifiedSampler::startPixelSample(Point2i pixel, int sample_index, int dimension) {
  if (pixel != pixel_) {
    keys_.newPixel();
    pixel_ = pixel;
    pixel_rng_ = pixelRng();
  }
  index_ = sample_index;
  stratum_index_ = static_cast<uint32_t>(index_ % samplesPerPixel());
  sample_rng_ = pixel_rng_;
  sample_rng_.advance(static_cast<uint64_t>(index_) << 17);
  dim_ = dimension;
}

// Jitter for dimension `dim`: a PCG32 stream per pixel, positioned by sample index and
// dimension (2^16 values per sample, 2 per dimension), so a value never depends on which
// dimensions were drawn before it. (Advancing by a then by b is advancing by a + b.)
Rng StratifiedSampler::jitterRng(int dim) const {
  Rng rng = sample_rng_;
  rng.advance(2 * static_cast<uint64_t>(dim));
  return rng;
}

// The stratum permutation's keys for dimension `dim` of the current pixel: computed once per
// pixel and dimension, and every time beyond the cached dimensions.
const PermutationKeys& StratifiedSampler::keys(int dim) {
  return keys_.get(dim, [&] {
    return PermutationKeys(
        hashValues({pixelKey(pixel_), static_cast<uint64_t>(dim), static_cast<uint64_t>(seed_)}));
  });
}

int StratifiedSampler::stratum(int dim) {
  return permutationElement(stratum_index_, static_cast<uint32_t>(samplesPerPixel()), keys(dim));
}

double StratifiedSampler::get1D() {
  const int n = samplesPerPixel();
  const int s = stratum(dim_);
  Rng rng = jitterRng(dim_);
  ++dim_;
  const double delta = jitter_ ? rng.uniform() : 0.5;
  return std::min((s + delta) / n, kOneMinusEpsilon);
}

Vec2 StratifiedSampler::get2D() {
  const int s = stratum(dim_);
  Rng rng = jitterRng(dim_);
  dim_ += 2;
  const int x = s % xs_, y = s / xs_;
  const double dx = jitter_ ? rng.uniform() : 0.5;
  const double dy = jitter_ ? rng.uniform() : 0.5;
  return {std::min((x + dx) / xs_, kOneMinusEpsilon), std::min((y + dy) / ys_, kOneMinusEpsilon)};
}

std::unique_ptr<Sampler> StratifiedSampler::clone() const {
  return std::make_unique<StratifiedSampler>(*this);
}

// ---------------------------------------------------------------------------------------------

namespace {
uint32_t reverseBits(uint32_t x) {
  x = (x << 16) | (x >> 16);
  x = ((x & 0x00ff00ffU) << 8) | ((x & 0xff00ff00U) >> 8);
  x = ((x & 0x0f0f0f0fU) << 4) | ((x & 0xf0f0f0f0U) >> 4);
  x = ((x & 0x33333333U) << 2) | ((x & 0xccccccccU) >> 2);
  x = ((x & 0x55555555U) << 1) | ((x & 0xaaaaaaaaU) >> 1);
  return x;
}

// The second Sobol dimension at `index`, bit-reversed. Its generator matrix (primitive
// polynomial x + 1, m_1 = 1: direction numbers v_0 = 2^31, v_k = v_{k-1} xor (v_{k-1} >> 1)) is
// Pascal's triangle mod 2: index bit k sets value bit 31 - j where C(k, j) is odd, that is
// (Lucas) where the bits of j are a subset of those of k. So reversed bit j is the parity of the
// index bits at the supersets of j: a superset-xor transform, five shift-and-xor steps.
uint32_t sobolDimension1Reversed(uint32_t index) {
  uint32_t x = index;
  x ^= (x >> 1) & 0x55555555U;
  x ^= (x >> 2) & 0x33333333U;
  x ^= (x >> 4) & 0x0f0f0f0fU;
  x ^= (x >> 8) & 0x00ff00ffU;
  x ^= (x >> 16) & 0x0000ffffU;
  return x;
}
}  // namespace

// The first Sobol dimension's generator matrix is the identity: the value is the index's bits
// reversed (van der Corput).
uint32_t sobolDimension0(uint32_t index) { return reverseBits(index); }

uint32_t sobolDimension1(uint32_t index) { return reverseBits(sobolDimension1Reversed(index)); }

uint32_t owenScrambleReversed(uint32_t x, uint32_t s) {
  // Nested uniform scrambling by a hash on the bit-reversed value (Laine & Karras 2011, "Stratified
  // sampling for stochastic transparency", with the constants of Burley 2020, "Practical
  // Hash-based Owen Scrambling", JCGT 9(4)): after reversal, multiplication and addition only
  // carry toward higher bits, so the flip of each original bit depends only on the bits above
  // it and every elementary interval is permuted as a whole (Owen 1995). A few operations per
  // value instead of one hash per bit.
  x ^= x * 0x3d20adeaU;
  x += s;
  x *= (s >> 16) | 1U;
  x ^= x * 0x05526c56U;
  x ^= x * 0x53a22864U;
  return x;
}

uint32_t owenScramble(uint32_t v, uint64_t seed) {
  return reverseBits(owenScrambleReversed(reverseBits(v), static_cast<uint32_t>(mixBits(seed))));
}

PaddedSobolSampler::PaddedSobolSampler(int samples_per_pixel, int seed) : seed_(seed) {
  if (samples_per_pixel <= 0)
    throw Error(fmt::format("pixelsamples must be positive (got {})", samples_per_pixel));
  spp_ = static_cast<int>(std::bit_ceil(static_cast<uint32_t>(samples_per_pixel)));
}

void PaddedSobolSampler::startPixelSample(Point2i pixel, int sample_index, int dimension) {
  if (pixel != pixel_) {
    pixel_ = pixel;
    keys_.newPixel();
  }
  index_ = sample_index;
  index_in_block_ = static_cast<uint32_t>(index_ % spp_);
  dim_ = dimension;
}

uint64_t PaddedSobolSampler::dimensionHash(int dim) const {
  return hashValues(
      {pixelKey(pixel_), static_cast<uint64_t>(dim), static_cast<uint64_t>(seed_), 3});
}

// The keys of dimension `dim` for the current pixel: computed once per pixel and dimension
// (the pixel's samples follow each other), and every time beyond the cached dimensions.
const PaddedSobolSampler::DimensionKeys& PaddedSobolSampler::keys(int dim) {
  return keys_.get(dim, [&] {
    const uint64_t h = dimensionHash(dim);
    DimensionKeys k;
    k.permutation = PermutationKeys(h);
    k.owen[0] = static_cast<uint32_t>(mixBits(mixBits(h + 1)));
    k.owen[1] = static_cast<uint32_t>(mixBits(mixBits(h + 2)));
    return k;
  });
}

uint32_t PaddedSobolSampler::permutedIndex(const DimensionKeys& k) const {
  return static_cast<uint32_t>(
      permutationElement(index_in_block_, static_cast<uint32_t>(spp_), k.permutation));
}

double PaddedSobolSampler::get1D() {
  const DimensionKeys& k = keys(dim_++);
  // Sobol dimension 0 bit-reversed is the index itself.
  return toUnit(reverseBits(owenScrambleReversed(permutedIndex(k), k.owen[0])));
}

Vec2 PaddedSobolSampler::get2D() {
  const DimensionKeys& k = keys(dim_);
  dim_ += 2;
  const uint32_t i = permutedIndex(k);
  return {toUnit(reverseBits(owenScrambleReversed(i, k.owen[0]))),
          toUnit(reverseBits(owenScrambleReversed(sobolDimension1Reversed(i), k.owen[1])))};
}

std::unique_ptr<Sampler> PaddedSobolSampler::clone() const {
  return std::make_unique<PaddedSobolSampler>(*this);
}

// ---------------------------------------------------------------------------------------------

namespace {

// pbrt-v4's MixBits (src/pbrt/util/hash.h), distinct from lensim's mixBits.
uint64_t pbrtMixBits(uint64_t v) {
  v ^= v >> 31;
  v *= 0x7fb5d329728ea185ULL;
  v ^= v >> 27;
  v *= 0x81dadef4bc2dd44dULL;
  v ^= v >> 33;
  return v;
}

// pbrt-v4's Hash(int dimension, int seed): MurmurHash64A (seed 0) of the two ints' 8 bytes.
uint64_t pbrtHash(int a, int b) {
  constexpr uint64_t m = 0xc6a4a7935bd1e995ULL;
  uint64_t h = 8 * m;
  uint64_t k = static_cast<uint64_t>(static_cast<uint32_t>(a)) |
               (static_cast<uint64_t>(static_cast<uint32_t>(b)) << 32);
  k *= m;
  k ^= k >> 47;
  k *= m;
  h ^= k;
  h *= m;
  h ^= h >> 47;
  h *= m;
  h ^= h >> 47;
  return h;
}

uint64_t spreadBits2(uint64_t x) {
  x &= 0xffffffffULL;
  x = (x ^ (x << 16)) & 0x0000ffff0000ffffULL;
  x = (x ^ (x << 8)) & 0x00ff00ff00ff00ffULL;
  x = (x ^ (x << 4)) & 0x0f0f0f0f0f0f0f0fULL;
  x = (x ^ (x << 2)) & 0x3333333333333333ULL;
  x = (x ^ (x << 1)) & 0x5555555555555555ULL;
  return x;
}

// The 24 permutations of a base-4 digit, in pbrt-v4's order; entry p maps digit d to
// (kDigitPermutations[p] >> 2d) & 3.
constexpr uint8_t kDigitPermutations[24] = {0xe4, 0xb4, 0xd8, 0x78, 0x6c, 0x9c, 0xe1, 0xb1,
                                            0xc9, 0x39, 0x2d, 0x8d, 0xc6, 0x36, 0xd2, 0x72,
                                            0x4e, 0x1e, 0x27, 0x87, 0x1b, 0x4b, 0x63, 0x93};

// The digit permutation (a kDigitPermutations entry) pbrt-v4 picks for a digit whose higher
// digits are `higher`, at the dimension whose salt is 0x55555555 * dimension.
uint8_t digitPermutation(uint64_t higher, uint64_t dim_salt) {
  return kDigitPermutations[(pbrtMixBits(higher ^ dim_salt) >> 24) % 24];
}

int ceilLog2(uint64_t v) {
  return v <= 1 ? 0 : 64 - std::countl_zero(v - 1);
}

}  // namespace

SobolRandomization parseSobolRandomization(const std::string& name) {
  if (name.empty() || name == "fastowen") return SobolRandomization::FastOwen;
  if (name == "none") return SobolRandomization::None;
  if (name == "permutedigits") return SobolRandomization::PermuteDigits;
  if (name == "owen") return SobolRandomization::Owen;
  throw Error(
      fmt::format("sampler randomization \"{}\": expected \"none\", \"permutedigits\", "
                  "\"fastowen\" or \"owen\"",
                  name));
}

ZSobolSampler::ZSobolSampler(int samples_per_pixel, Point2i full_resolution,
                             SobolRandomization randomization, int seed)
    : spp_(samples_per_pixel), seed_(seed), randomization_(randomization) {
  if (spp_ <= 0) throw Error(fmt::format("pixelsamples must be positive (got {})", spp_));
  if (full_resolution.x <= 0 || full_resolution.y <= 0)
    throw Error(fmt::format("film resolution {} x {}: expected positive sizes", full_resolution.x,
                            full_resolution.y));
  log2_spp_ = ceilLog2(static_cast<uint64_t>(spp_));
  const int res_log2 =
      ceilLog2(static_cast<uint64_t>(std::max(full_resolution.x, full_resolution.y)));
  base4_digits_ = res_log2 + (log2_spp_ + 1) / 2;
  // get1D and get2D hash the dimension after the step: up to two past the last cached one.
  dim_hash_.resize(kSamplerCachedDimensions + 2);
  for (size_t d = 0; d < dim_hash_.size(); ++d) dim_hash_[d] = pbrtHash(static_cast<int>(d), seed_);
}

void ZSobolSampler::startPixelSample(Point2i pixel, int sample_index, int dimension) {
  dim_ = dimension;
  if (pixel != pixel_) {
    pixel_ = pixel;
    pixel_morton_ = (spreadBits2(static_cast<uint32_t>(pixel.y)) << 1) |
                    spreadBits2(static_cast<uint32_t>(pixel.x));
  }
  morton_ = (pixel_morton_ << log2_spp_) | static_cast<uint64_t>(sample_index);
}

// Digits from_digit > i >= to_digit of pbrt-v4 ZSobolSampler::GetSampleIndex: each base-4 digit
// of the Morton index, from the top, goes through one of the 24 permutations chosen by a hash of
// the digits above it and the dimension.
uint64_t ZSobolSampler::permuteDigits(int from_digit, int to_digit) const {
  const int odd = log2_spp_ & 1;
  const uint64_t dim_salt = 0x55555555ULL * static_cast<uint64_t>(dim_);
  uint64_t index = 0;
  for (int i = from_digit - 1; i >= to_digit; --i) {
    const int shift = 2 * i - odd;
    const unsigned digit = static_cast<unsigned>(morton_ >> shift) & 3u;
    const uint64_t higher = morton_ >> (shift + 2);
    index |= static_cast<uint64_t>((digitPermutation(higher, dim_salt) >> (2 * digit)) & 3u)
             << shift;
  }
  return index;
}

uint64_t ZSobolSampler::sampleIndex() const {
  const int odd = log2_spp_ & 1;
  const uint64_t dim_salt = 0x55555555ULL * static_cast<uint64_t>(dim_);
  const size_t d = static_cast<size_t>(dim_);
  if (d >= kSamplerCachedDimensions) {
    uint64_t index = permuteDigits(base4_digits_, odd);
    if (odd) index |= (morton_ & 1) ^ (pbrtMixBits((morton_ >> 1) ^ dim_salt) & 1);
    return index;
  }
  if (d >= cache_.size()) cache_.resize(d + 1);
  DimensionCache& c = cache_[d];
  uint64_t index = 0;
  // The lowest full digit is digit `odd` (at bit `odd`); where there is none (one or two
  // samples per pixel on a one-pixel film), only the last bit below.
  if (base4_digits_ > odd) {
    const uint64_t key = morton_ >> (odd + 2);
    if (c.sample_key != key) {
      // The digits above the lowest. A permuted digit depends only on the index bits from its
      // own up, so the digits above the highest bit in which the key differs from the cached
      // one are kept: consecutive samples and neighbouring pixels share most of them.
      int from_digit = base4_digits_;
      uint64_t keep = 0;
      if (c.sample_key != ~0ULL) {
        const int high_bit = 63 - std::countl_zero(c.sample_key ^ key) + odd + 2;
        from_digit = std::min(base4_digits_, (high_bit + odd) / 2 + 1);
        const int keep_from_bit = 2 * from_digit - odd;
        keep = keep_from_bit >= 64 ? 0 : ~0ULL << keep_from_bit;
      }
      c.prefix = (c.prefix & keep) | permuteDigits(from_digit, odd + 1);
      c.low_permutation = digitPermutation(key, dim_salt);
      c.sample_key = key;
    }
    const unsigned digit = static_cast<unsigned>(morton_ >> odd) & 3u;
    index = c.prefix | (static_cast<uint64_t>((c.low_permutation >> (2 * digit)) & 3u) << odd);
  }
  if (odd) {
    const uint64_t key = morton_ >> 1;
    if (c.flip_key != key) {
      c.flip = static_cast<uint32_t>(pbrtMixBits(key ^ dim_salt) & 1);
      c.flip_key = key;
    }
    index |= (morton_ & 1) ^ c.flip;
  }
  return index;
}

uint64_t ZSobolSampler::dimensionHash(int dim) const {
  return static_cast<size_t>(dim) < dim_hash_.size() ? dim_hash_[static_cast<size_t>(dim)]
                                                      : pbrtHash(dim, seed_);
}

// The scrambled Sobol value whose bit reversal is `reversed`.
uint32_t ZSobolSampler::scrambleReversed(uint32_t reversed, uint32_t hash) const {
  switch (randomization_) {
    case SobolRandomization::None:
      return reverseBits(reversed);
    case SobolRandomization::PermuteDigits:
      return reverseBits(reversed) ^ hash;
    case SobolRandomization::FastOwen:
      // pbrt-v4's FastOwenScrambler is owenScramble's hash with `hash` as the mixed seed.
      return reverseBits(owenScrambleReversed(reversed, hash));
    case SobolRandomization::Owen: {
      // pbrt-v4 OwenScrambler: bit 31 - b flips by a hash of the b bits above it.
      uint32_t v = reverseBits(reversed);
      if (hash & 1u) v ^= 1u << 31;
      for (int b = 1; b < 32; ++b) {
        const uint32_t mask = ~0u << (32 - b);
        if (static_cast<uint32_t>(pbrtMixBits((v & mask) ^ hash)) & (1u << b)) v ^= 1u << (31 - b);
      }
      return v;
    }
  }
  return reverseBits(reversed);
}

// Sobol dimension 0 bit-reversed is the index itself; dimension 1 is sobolDimension1Reversed.
double ZSobolSampler::get1D() {
  const uint64_t index = sampleIndex();
  ++dim_;
  const uint32_t hash = static_cast<uint32_t>(dimensionHash(dim_));
  return toUnit(scrambleReversed(static_cast<uint32_t>(index), hash));
}

Vec2 ZSobolSampler::get2D() {
  const uint32_t index = static_cast<uint32_t>(sampleIndex());
  dim_ += 2;
  const uint64_t bits = dimensionHash(dim_);
  return {toUnit(scrambleReversed(index, static_cast<uint32_t>(bits))),
          toUnit(scrambleReversed(sobolDimension1Reversed(index), static_cast<uint32_t>(bits >> 32)))};
}

std::unique_ptr<Sampler> ZSobolSampler::clone() const {
  return std::make_unique<ZSobolSampler>(*this);
}

}  // namespace lensim::sampling
