#include "lensim/sampling/sampler.h"

#include <algorithm>
#include <bit>

#include <fmt/format.h>

#include "lensim/util/error.h"

namespace lensim::render {

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
}

void StratifiedSampler::startPixelSample(Point2i pixel, int sample_index, int dimension) {
  pixel_ = pixel;
  index_ = sample_index;
  dim_ = dimension;
}

// Jitter for dimension `dim`: a PCG32 stream per pixel, positioned by sample index and
// dimension, so a value never depends on which dimensions were drawn before it.
Rng StratifiedSampler::jitterRng(int dim) const {
  Rng rng(hashValues({pixelKey(pixel_), static_cast<uint64_t>(seed_), 2}), 0);
  rng.advance((static_cast<uint64_t>(index_) << 17) + 2 * static_cast<uint64_t>(dim));
  return rng;
}

double StratifiedSampler::get1D() {
  const uint64_t h =
      hashValues({pixelKey(pixel_), static_cast<uint64_t>(dim_), static_cast<uint64_t>(seed_)});
  const int n = samplesPerPixel();
  const int stratum = permutationElement(static_cast<uint32_t>(index_ % n), n, h);
  Rng rng = jitterRng(dim_);
  ++dim_;
  const double delta = jitter_ ? rng.uniform() : 0.5;
  return std::min((stratum + delta) / n, kOneMinusEpsilon);
}

Vec2 StratifiedSampler::get2D() {
  const uint64_t h =
      hashValues({pixelKey(pixel_), static_cast<uint64_t>(dim_), static_cast<uint64_t>(seed_)});
  const int n = samplesPerPixel();
  const int stratum = permutationElement(static_cast<uint32_t>(index_ % n), n, h);
  Rng rng = jitterRng(dim_);
  dim_ += 2;
  const int x = stratum % xs_, y = stratum / xs_;
  const double dx = jitter_ ? rng.uniform() : 0.5;
  const double dy = jitter_ ? rng.uniform() : 0.5;
  return {std::min((x + dx) / xs_, kOneMinusEpsilon), std::min((y + dy) / ys_, kOneMinusEpsilon)};
}

std::unique_ptr<Sampler> StratifiedSampler::clone() const {
  return std::make_unique<StratifiedSampler>(*this);
}

// ---------------------------------------------------------------------------------------------

uint32_t sobolDimension0(uint32_t index) {
  // Bit reversal: the generator matrix of the first Sobol dimension is the identity.
  uint32_t v = index;
  v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  v = ((v >> 4) & 0x0f0f0f0fu) | ((v & 0x0f0f0f0fu) << 4);
  v = ((v >> 8) & 0x00ff00ffu) | ((v & 0x00ff00ffu) << 8);
  return (v >> 16) | (v << 16);
}

namespace {
uint32_t reverseBits(uint32_t x) {
  x = (x << 16) | (x >> 16);
  x = ((x & 0x00ff00ffU) << 8) | ((x & 0xff00ff00U) >> 8);
  x = ((x & 0x0f0f0f0fU) << 4) | ((x & 0xf0f0f0f0U) >> 4);
  x = ((x & 0x33333333U) << 2) | ((x & 0xccccccccU) >> 2);
  x = ((x & 0x55555555U) << 1) | ((x & 0xaaaaaaaaU) >> 1);
  return x;
}
}  // namespace

uint32_t sobolDimension1(uint32_t index) {
  // Second Sobol dimension (primitive polynomial x + 1, m_1 = 1): direction numbers
  // v_0 = 2^31, v_k = v_{k-1} xor (v_{k-1} >> 1); the value is the xor of v_k over set bits k.
  uint32_t result = 0, v = 1u << 31;
  for (; index != 0; index >>= 1, v ^= v >> 1)
    if (index & 1u) result ^= v;
  return result;
}

uint32_t owenScramble(uint32_t v, uint64_t seed) {
  // Nested uniform scrambling by a hash on the bit-reversed value (Laine & Karras 2011, "Stratified
  // sampling for stochastic transparency", with the constants of Burley 2020, "Practical
  // Hash-based Owen Scrambling", JCGT 9(4)): after reversal, multiplication and addition only
  // carry toward higher bits, so the flip of each original bit depends only on the bits above
  // it and every elementary interval is permuted as a whole (Owen 1995). A few operations per
  // value instead of one hash per bit.
  const uint32_t s = static_cast<uint32_t>(mixBits(seed));
  uint32_t x = reverseBits(v);
  x ^= x * 0x3d20adeaU;
  x += s;
  x *= (s >> 16) | 1U;
  x ^= x * 0x05526c56U;
  x ^= x * 0x53a22864U;
  return reverseBits(x);
}

PaddedSobolSampler::PaddedSobolSampler(int samples_per_pixel, int seed) : seed_(seed) {
  if (samples_per_pixel <= 0)
    throw Error(fmt::format("pixelsamples must be positive (got {})", samples_per_pixel));
  spp_ = static_cast<int>(std::bit_ceil(static_cast<uint32_t>(samples_per_pixel)));
}

void PaddedSobolSampler::startPixelSample(Point2i pixel, int sample_index, int dimension) {
  pixel_ = pixel;
  index_ = sample_index;
  dim_ = dimension;
}

uint64_t PaddedSobolSampler::dimensionHash(int dim) const {
  return hashValues(
      {pixelKey(pixel_), static_cast<uint64_t>(dim), static_cast<uint64_t>(seed_), 3});
}

double PaddedSobolSampler::get1D() {
  const uint64_t h = dimensionHash(dim_++);
  const uint32_t i =
      static_cast<uint32_t>(permutationElement(static_cast<uint32_t>(index_ % spp_), spp_, h));
  return toUnit(owenScramble(sobolDimension0(i), mixBits(h + 1)));
}

Vec2 PaddedSobolSampler::get2D() {
  const uint64_t h = dimensionHash(dim_);
  dim_ += 2;
  const uint32_t i =
      static_cast<uint32_t>(permutationElement(static_cast<uint32_t>(index_ % spp_), spp_, h));
  return {toUnit(owenScramble(sobolDimension0(i), mixBits(h + 1))),
          toUnit(owenScramble(sobolDimension1(i), mixBits(h + 2)))};
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
  pixel_digit_ = (log2_spp_ + 1) / 2;
}

void ZSobolSampler::startPixelSample(Point2i pixel, int sample_index, int dimension) {
  dim_ = dimension;
  if (pixel != pixel_) {
    pixel_ = pixel;
    if (++stamp_ == 0) std::fill(pixel_stamp_.begin(), pixel_stamp_.end(), 0u), stamp_ = 1;
  }
  morton_ = (((spreadBits2(static_cast<uint32_t>(pixel.y)) << 1) |
              spreadBits2(static_cast<uint32_t>(pixel.x)))
             << log2_spp_) |
            static_cast<uint64_t>(sample_index);
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
    const unsigned p = static_cast<unsigned>((pbrtMixBits(higher ^ dim_salt) >> 24) % 24);
    index |= static_cast<uint64_t>((kDigitPermutations[p] >> (2 * digit)) & 3u) << shift;
  }
  return index;
}

uint64_t ZSobolSampler::sampleIndex() const {
  const int odd = log2_spp_ & 1;
  // The pixel's digits (cached per dimension), then the sample's.
  uint64_t index;
  const size_t d = static_cast<size_t>(dim_);
  if (d < pixel_part_.size() && pixel_stamp_[d] == stamp_) {
    index = pixel_part_[d];
  } else {
    index = permuteDigits(base4_digits_, pixel_digit_);
    if (d < 256) {
      if (d >= pixel_part_.size()) {
        pixel_part_.resize(d + 1, 0);
        pixel_stamp_.resize(d + 1, 0);
      }
      pixel_part_[d] = index;
      pixel_stamp_[d] = stamp_;
    }
  }
  index |= permuteDigits(pixel_digit_, odd);
  if (odd)
    index |= (morton_ & 1) ^
             (pbrtMixBits((morton_ >> 1) ^ (0x55555555ULL * static_cast<uint64_t>(dim_))) & 1);
  return index;
}

uint32_t ZSobolSampler::scramble(uint32_t v, uint32_t hash) const {
  switch (randomization_) {
    case SobolRandomization::None:
      return v;
    case SobolRandomization::PermuteDigits:
      return v ^ hash;
    case SobolRandomization::FastOwen: {
      uint32_t x = reverseBits(v);
      x ^= x * 0x3d20adeaU;
      x += hash;
      x *= (hash >> 16) | 1U;
      x ^= x * 0x05526c56U;
      x ^= x * 0x53a22864U;
      return reverseBits(x);
    }
    case SobolRandomization::Owen: {
      // pbrt-v4 OwenScrambler: bit 31 - b flips by a hash of the b bits above it.
      if (hash & 1u) v ^= 1u << 31;
      for (int b = 1; b < 32; ++b) {
        const uint32_t mask = ~0u << (32 - b);
        if (static_cast<uint32_t>(pbrtMixBits((v & mask) ^ hash)) & (1u << b)) v ^= 1u << (31 - b);
      }
      return v;
    }
  }
  return v;
}

double ZSobolSampler::get1D() {
  const uint64_t index = sampleIndex();
  ++dim_;
  const uint32_t hash = static_cast<uint32_t>(pbrtHash(dim_, seed_));
  return toUnit(scramble(sobolDimension0(static_cast<uint32_t>(index)), hash));
}

Vec2 ZSobolSampler::get2D() {
  const uint64_t index = sampleIndex();
  dim_ += 2;
  const uint64_t bits = pbrtHash(dim_, seed_);
  return {
      toUnit(scramble(sobolDimension0(static_cast<uint32_t>(index)), static_cast<uint32_t>(bits))),
      toUnit(scramble(sobolDimension1(static_cast<uint32_t>(index)),
                      static_cast<uint32_t>(bits >> 32)))};
}

std::unique_ptr<Sampler> ZSobolSampler::clone() const {
  return std::make_unique<ZSobolSampler>(*this);
}

}  // namespace lensim::render
