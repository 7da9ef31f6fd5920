// Warping functions from [0,1)^n to common domains, tabulated distributions, MIS weights.
//
// Directions are unit vectors in a local frame with +z as the normal. Pdfs are per unit solid
// angle (sr^-1) for directions and per unit area for points.
#pragma once

#include <algorithm>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::sampling {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kInvPi = 1.0 / std::numbers::pi;
/// The largest double below 1, the upper end of sample values.
inline constexpr double kOneMinusEpsilon = 0x1.fffffffffffffp-1;

/// sin x and cos x for |x| <= pi/4 by their Taylor polynomials to x^17 and x^16 (truncation
/// below 1e-19; within 2 ulp of the exact values, tests/sincos_warp_test.cpp): the warps' angles
/// without a libm call.
struct SinCos {
  double sin, cos;
};
SinCos sinCosSmall(double x);
/// sin and cos of 2 pi u for |u| < 2^49, the angle reduced exactly in u (quarter turns of 4u)
/// to |x| <= pi/4.
SinCos sinCos2Pi(double u);

/// Uniform direction on the +z hemisphere; pdf 1/(2 pi) sr^-1.
Vec3 sampleUniformHemisphere(Vec2 u);
inline double uniformHemispherePdf() {
  return 0.5 * kInvPi;
}
/// Uniform direction on the unit sphere; pdf 1/(4 pi) sr^-1.
Vec3 sampleUniformSphere(Vec2 u);
inline double uniformSpherePdf() {
  return 0.25 * kInvPi;
}
/// Uniform point on the unit disk by Shirley & Chiu's concentric map; pdf 1/pi per unit area.
Vec2 sampleUniformDiskConcentric(Vec2 u);
/// Cosine-weighted direction on the +z hemisphere (Malley's method); pdf cos(theta)/pi.
Vec3 sampleCosineHemisphere(Vec2 u);
inline double cosineHemispherePdf(double cos_theta) {
  return cos_theta * kInvPi;
}
/// Uniform direction in the cone of half-angle acos(cos_theta_max) around +z;
/// pdf 1/(2 pi (1 - cos_theta_max)).
Vec3 sampleUniformCone(Vec2 u, double cos_theta_max);
inline double uniformConePdf(double cos_theta_max) {
  return 1.0 / (2 * kPi * (1 - cos_theta_max));
}
/// x in [-r, r] with density (r - |x|) / r^2 (the tent of the triangle filter).
double sampleTent(double u, double r);
inline double tentPdf(double x, double r) {
  return std::abs(x) >= r ? 0.0 : (r - std::abs(x)) / (r * r);
}

/// Veach's power heuristic (beta = 2) MIS weight for nf samples of f against ng samples of g.
inline double powerHeuristic(int nf, double f_pdf, int ng, double g_pdf) {
  const double f = nf * f_pdf, g = ng * g_pdf;
  if (std::isinf(f * f)) return 1.0;
  return f * f / (f * f + g * g);
}

/// A density proportional to |f| of a piecewise-constant function on [min, max] (n equal
/// cells). A function that is zero everywhere is sampled uniformly. Sampling inverts the CDF with
/// a guide table (the cells holding each of 2^k >= n equal steps of u) and a binary search
/// between two guide entries, usually zero or one comparisons.
class PiecewiseConstant1D {
 public:
  PiecewiseConstant1D() = default;
  PiecewiseConstant1D(std::span<const double> f, double min = 0.0, double max = 1.0);

  struct Sample {
    double x;    ///< in [min, max)
    double pdf;  ///< per unit of x
    int offset;  ///< cell index
  };
  /// Inline: the pixel filter draws two per camera sample.
  Sample sample(double u) const;
  /// Density at x (0 outside [min, max]).
  double pdf(double x) const;
  /// Integral of |f| over [min, max].
  double integral() const { return integral_; }
  int size() const { return static_cast<int>(pdf_.size()); }

 private:
  /// The cell of u: the last o with cdf_[o] <= u (cells of zero probability skipped), in [0, n).
  int cell(double u) const;

  /// pdf_[o]: the density in cell o, |f_o| / integral (1 / (max - min) where f is all zero).
  std::vector<double> pdf_, cdf_;
  /// guide_[g] = last index o with cdf_[o] <= g / (guide_.size() - 1).
  std::vector<int> guide_;
  double min_ = 0, max_ = 1, integral_ = 0, steps_ = 1;
};

inline int PiecewiseConstant1D::cell(double u) const {
  // For u in [g, g + 1) / steps the cell lies between guide_[g] and guide_[g + 1]: usually one
  // or two entries apart, scanned; a long run (many narrow cells within one step) is
  // binary-searched. Outside [0, 1) (and NaN) the whole CDF is searched.
  const int n = size();
  int o;
  if (u >= 0 && u < 1) {
    const size_t g = static_cast<size_t>(u * steps_);
    const int lo = guide_[g], hi = guide_[g + 1];
    if (hi - lo <= 8) {
      o = lo;
      while (o < hi && cdf_[static_cast<size_t>(o) + 1] <= u) ++o;
    } else {
      o = static_cast<int>(std::upper_bound(cdf_.begin() + lo + 1, cdf_.begin() + hi + 1, u) -
                           cdf_.begin()) -
          1;
    }
  } else {
    o = static_cast<int>(std::upper_bound(cdf_.begin(), cdf_.end(), u) - cdf_.begin()) - 1;
  }
  return std::clamp(o, 0, n - 1);
}

inline PiecewiseConstant1D::Sample PiecewiseConstant1D::sample(double u) const {
  const int n = size();
  const int o = cell(u);
  const size_t i = static_cast<size_t>(o);
  double du = u - cdf_[i];
  const double width = cdf_[i + 1] - cdf_[i];
  if (width > 0) du /= width;
  du = std::clamp(du, 0.0, kOneMinusEpsilon);
  const double x = min_ + (o + du) / n * (max_ - min_);
  return {std::min(x, max_), pdf_[i], o};
}

/// A density proportional to |f| of a piecewise-constant function on a rectangle, nu x nv cells,
/// f given row-major (v rows of nu values); marginal in v, conditional in u.
class PiecewiseConstant2D {
 public:
  PiecewiseConstant2D() = default;
  PiecewiseConstant2D(std::span<const double> f, int nu, int nv, Vec2 min = {0, 0},
                      Vec2 max = {1, 1});
  struct Sample {
    Vec2 p;      ///< point in the rectangle
    double pdf;  ///< per unit area
  };
  Sample sample(Vec2 u) const;
  double pdf(Vec2 p) const;
  double integral() const { return marginal_.integral(); }

 private:
  std::vector<PiecewiseConstant1D> conditional_;
  PiecewiseConstant1D marginal_;
  Vec2 min_, max_;
};

/// 64-bit finaliser of MurmurHash3 (Appleby): a bijective avalanche mix of the bits.
uint64_t mixBits(uint64_t v);
/// Hash of several 64-bit values.
uint64_t hashValues(std::initializer_list<uint64_t> values);

/// PCG32 random number generator (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient
/// Statistically Good Algorithms for Random Number Generation"), XSH RR output.
class Rng {
 public:
  Rng() : Rng(0x853c49e6748fea9bULL, 0xda3e39cb94b95bdbULL) {}
  /// Stream `sequence_index` started from `seed` (PCG's two initialisation values).
  Rng(uint64_t sequence_index, uint64_t seed) { setSequence(sequence_index, seed); }
  void setSequence(uint64_t sequence_index, uint64_t seed);
  /// Skips `delta` 32-bit outputs in O(log delta) (Brown 1994, "Random number generation with
  /// arbitrary strides").
  void advance(uint64_t delta);
  uint32_t uniformU32();
  /// Uniform in [0, 1).
  double uniform();

 private:
  uint64_t state_ = 0, inc_ = 1;
};

/// The element at index i of a pseudo-random permutation of [0, n) chosen by seed (Kensler 2013,
/// "Correlated Multi-Jittered Sampling", cycle-walking hash permutation; here built from mixBits).
int permutationElement(uint32_t i, uint32_t n, uint64_t seed);

/// The round keys permutationElement derives from its seed, for callers that draw many elements
/// of one permutation: permutationElement(i, n, PermutationKeys(seed)) is
/// permutationElement(i, n, seed).
struct PermutationKeys {
  PermutationKeys() = default;
  explicit PermutationKeys(uint64_t seed);
  uint32_t xor_key[3] = {}, mul[3] = {}, add[3] = {};
};
int permutationElement(uint32_t i, uint32_t n, const PermutationKeys& keys);

}  // namespace lensim::sampling
