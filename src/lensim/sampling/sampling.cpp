#include "lensim/sampling/sampling.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "lensim/util/error.h"

namespace lensim::sampling {

SinCos sinCosSmall(double x) {
  // Estrin's scheme in x^2 (short dependency chains) with the reciprocal factorials, each
  // correctly rounded; the leading terms x and 1 are added last.
  const double y = x * x, y2 = y * y, y4 = y2 * y2;
  const double ps = ((-1.0 / 6 + y * (1.0 / 120)) + y2 * (-1.0 / 5040 + y * (1.0 / 362880))) +
                    y4 * ((-1.0 / 39916800 + y * (1.0 / 6227020800)) +
                          y2 * (-1.0 / 1307674368000 + y * (1.0 / 355687428096000)));
  const double pc = ((-0.5 + y * (1.0 / 24)) + y2 * (-1.0 / 720 + y * (1.0 / 40320))) +
                    y4 * ((-1.0 / 3628800 + y * (1.0 / 479001600)) +
                          y2 * (-1.0 / 87178291200 + y * (1.0 / 20922789888000)));
  return {x + (x * y) * ps, 1 + y * pc};
}

SinCos sinCos2Pi(double u) {
  // 2 pi u = (pi/2) (q + f) with q whole and f in [-1/2, 1/2]: 4u and its rounding to the
  // nearest whole number are exact (adding and removing 1.5 * 2^52 rounds any |4u| < 2^51,
  // without a libm call), so is f; the quarter turns swap and negate.
  const double v = 4 * u;
  constexpr double kRound = 0x1.8p52;
  const double q = (v + kRound) - kRound;
  const SinCos sc = sinCosSmall((kPi / 2) * (v - q));
  switch (static_cast<int64_t>(q) & 3) {
    case 0:
      return sc;
    case 1:
      return {sc.cos, -sc.sin};
    case 2:
      return {-sc.sin, -sc.cos};
    default:
      return {-sc.cos, sc.sin};
  }
}

Vec3 sampleUniformHemisphere(Vec2 u) {
  const double z = u.x;
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  const SinCos phi = sinCos2Pi(u.y);
  return {r * phi.cos, r * phi.sin, z};
}

Vec3 sampleUniformSphere(Vec2 u) {
  const double z = 1 - 2 * u.x;
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  const SinCos phi = sinCos2Pi(u.y);
  return {r * phi.cos, r * phi.sin, z};
}

// Shirley & Chiu 1997, "A Low Distortion Map Between Disk and Square".
Vec2 sampleUniformDiskConcentric(Vec2 u) {
  const double a = 2 * u.x - 1, b = 2 * u.y - 1;
  if (a == 0 && b == 0) return {0, 0};
  // theta = (pi/4)(b/a), or pi/2 - (pi/4)(a/b) whose cosine and sine are the sine and
  // cosine of (pi/4)(a/b).
  if (std::abs(a) > std::abs(b)) {
    const SinCos t = sinCosSmall((kPi / 4) * (b / a));
    return {a * t.cos, a * t.sin};
  }
  const SinCos t = sinCosSmall((kPi / 4) * (a / b));
  return {b * t.sin, b * t.cos};
}

Vec3 sampleCosineHemisphere(Vec2 u) {
  const Vec2 d = sampleUniformDiskConcentric(u);
  const double z = std::sqrt(std::max(0.0, 1 - d.x * d.x - d.y * d.y));
  return {d.x, d.y, z};
}

Vec3 sampleUniformCone(Vec2 u, double cos_theta_max) {
  const double cos_theta = (1 - u.x) + u.x * cos_theta_max;
  const double sin_theta = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
  const SinCos phi = sinCos2Pi(u.y);
  return {sin_theta * phi.cos, sin_theta * phi.sin, cos_theta};
}

double sampleTent(double u, double r) {
  // Pick a side with probability 1/2, then invert the linear density on [0, r].
  if (u < 0.5) {
    const double v = u * 2;  // in [0,1)
    return -r + r * std::sqrt(v);
  }
  const double v = (u - 0.5) * 2;
  return r - r * std::sqrt(1 - v);
}

// ---------------------------------------------------------------------------------------------

PiecewiseConstant1D::PiecewiseConstant1D(std::span<const double> f, double min, double max)
    : pdf_(f.begin(), f.end()), min_(min), max_(max) {
  if (pdf_.empty()) throw Error("piecewise-constant distribution needs at least one value");
  for (double& v : pdf_) v = std::abs(v);
  const size_t n = pdf_.size();
  cdf_.assign(n + 1, 0.0);
  for (size_t i = 1; i <= n; ++i) cdf_[i] = cdf_[i - 1] + pdf_[i - 1] * (max_ - min_) / n;
  integral_ = cdf_[n];
  if (integral_ == 0) {
    for (size_t i = 1; i <= n; ++i) cdf_[i] = double(i) / n;
  } else {
    for (size_t i = 1; i <= n; ++i) cdf_[i] /= integral_;
  }
  // The densities, divided once here instead of at every sample.
  for (double& v : pdf_) v = integral_ > 0 ? v / integral_ : 1.0 / (max_ - min_);
  // A power of two, so that g / steps is exact and floor(u * steps) / steps <= u.
  const size_t steps = std::bit_ceil(n);
  steps_ = static_cast<double>(steps);
  guide_.resize(steps + 1);
  size_t o = 0;
  for (size_t g = 0; g <= steps; ++g) {
    const double u = static_cast<double>(g) / static_cast<double>(steps);
    while (o + 1 <= n && cdf_[o + 1] <= u) ++o;
    guide_[g] = static_cast<int>(o);
  }
}

double PiecewiseConstant1D::pdf(double x) const {
  if (x < min_ || x > max_) return 0.0;
  const int n = size();
  const int o = std::clamp(static_cast<int>((x - min_) / (max_ - min_) * n), 0, n - 1);
  return pdf_[static_cast<size_t>(o)];
}

PiecewiseConstant2D::PiecewiseConstant2D(std::span<const double> f, int nu, int nv, Vec2 min,
                                         Vec2 max)
    : min_(min), max_(max) {
  if (nu <= 0 || nv <= 0 || f.size() != static_cast<size_t>(nu) * nv)
    throw Error("piecewise-constant 2-D distribution: value count does not match nu * nv");
  std::vector<double> marginal;
  for (int v = 0; v < nv; ++v) {
    conditional_.emplace_back(f.subspan(static_cast<size_t>(v) * nu, nu), min.x, max.x);
    marginal.push_back(conditional_.back().integral());
  }
  marginal_ = PiecewiseConstant1D(marginal, min.y, max.y);
}

PiecewiseConstant2D::Sample PiecewiseConstant2D::sample(Vec2 u) const {
  const auto sv = marginal_.sample(u.y);
  const auto su = conditional_[sv.offset].sample(u.x);
  return {{su.x, sv.x}, su.pdf * sv.pdf};
}

double PiecewiseConstant2D::pdf(Vec2 p) const {
  if (p.x < min_.x || p.x > max_.x || p.y < min_.y || p.y > max_.y) return 0.0;
  const int nv = static_cast<int>(conditional_.size());
  const int v = std::clamp(static_cast<int>((p.y - min_.y) / (max_.y - min_.y) * nv), 0, nv - 1);
  return conditional_[v].pdf(p.x) * marginal_.pdf(p.y);
}

// ---------------------------------------------------------------------------------------------

uint64_t mixBits(uint64_t v) {
  v ^= v >> 33;
  v *= 0xff51afd7ed558ccdULL;
  v ^= v >> 33;
  v *= 0xc4ceb9fe1a85ec53ULL;
  v ^= v >> 33;
  return v;
}

uint64_t hashValues(std::initializer_list<uint64_t> values) {
  uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (uint64_t v : values) h = mixBits(h ^ mixBits(v + 0x632be59bd9b4e019ULL));
  return h;
}

void Rng::setSequence(uint64_t sequence_index, uint64_t seed) {
  state_ = 0;
  inc_ = (sequence_index << 1u) | 1u;
  uniformU32();
  state_ += seed;
  uniformU32();
}

void Rng::advance(uint64_t delta) {
  // Compose the LCG step x -> a x + c with itself delta times by repeated squaring.
  uint64_t cur_mult = 6364136223846793005ULL, cur_plus = inc_;
  uint64_t acc_mult = 1, acc_plus = 0;
  while (delta > 0) {
    if (delta & 1) {
      acc_mult *= cur_mult;
      acc_plus = acc_plus * cur_mult + cur_plus;
    }
    cur_plus = (cur_mult + 1) * cur_plus;
    cur_mult *= cur_mult;
    delta >>= 1;
  }
  state_ = acc_mult * state_ + acc_plus;
}

uint32_t Rng::uniformU32() {
  const uint64_t old = state_;
  state_ = old * 6364136223846793005ULL + inc_;
  const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
  const uint32_t rot = static_cast<uint32_t>(old >> 59u);
  return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
}

double Rng::uniform() {
  // 53 random bits from two outputs.
  const uint64_t hi = uniformU32(), lo = uniformU32();
  return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
}

PermutationKeys::PermutationKeys(uint64_t seed) {
  for (int round = 0; round < 3; ++round) {
    const uint64_t key = mixBits(seed + static_cast<uint64_t>(round));
    xor_key[round] = static_cast<uint32_t>(key);
    mul[round] = static_cast<uint32_t>(key >> 32) | 1u;
    add[round] = static_cast<uint32_t>(key >> 17);
  }
}

int permutationElement(uint32_t i, uint32_t n, const PermutationKeys& keys) {
  // Cycle-walking: apply a bijective hash on the smallest power-of-two domain containing n
  // until the value lands in [0, n).
  uint32_t w = n - 1;
  w |= w >> 1, w |= w >> 2, w |= w >> 4, w |= w >> 8, w |= w >> 16;
  uint32_t x = i;
  do {
    // A bijection on [0, w]: xor with a key, odd multiply, xorshift (all invertible mod 2^k).
    for (int round = 0; round < 3; ++round) {
      x ^= keys.xor_key[round] & w;
      x = (x * keys.mul[round]) & w;
      x ^= (x >> 3) & w;
      x = (x * 0x2c1b3c6dU + keys.add[round]) & w;
      x ^= (x >> 7);
      x &= w;
    }
  } while (x >= n);
  return static_cast<int>(x);
}

int permutationElement(uint32_t i, uint32_t n, uint64_t seed) {
  return permutationElement(i, n, PermutationKeys(seed));
}

}  // namespace lensim::sampling
