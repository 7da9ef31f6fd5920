// Pixel reconstruction filters with pbrt-v4's parameters and defaults, and importance sampling.
//
// Filters are functions of the offset (pixels) from the pixel centre, zero outside
// [-radius.x, radius.x] x [-radius.y, radius.y]. All lensim filters are separable:
// f(x, y) = f1(x; radius.x) f1(y; radius.y). Sampling returns an offset and the weight
// f(p) / pdf(p) (negative where the filter is negative), so that the film's weighted average
// sum(w L) / sum(w) estimates the filtered image.
#pragma once

#include <memory>
#include <vector>

#include "lensim/sampling/sampling.h"
#include "lensim/util/vec.h"

namespace lensim::sampling {

/// A filter sample: offset from the pixel centre (pixels) and weight f(p)/pdf(p) (pixels^2).
struct FilterSample {
  Vec2 p;
  double weight;
};

/// A separable pixel filter.
class Filter {
 public:
  explicit Filter(Vec2 radius);
  virtual ~Filter() = default;
  /// Half-widths in pixels.
  Vec2 radius() const { return radius_; }
  /// Filter value at offset p (pixels).
  double eval(Vec2 p) const { return eval1D(p.x, radius_.x) * eval1D(p.y, radius_.y); }
  /// Integral of the filter over its support (pixels^2).
  double integral() const { return integral_; }
  /// Draws an offset from u in [0,1)^2.
  virtual FilterSample sample(Vec2 u) const;
  /// Density of sample() at p (per pixel^2).
  virtual double pdf(Vec2 p) const;

 protected:
  /// The 1-D profile at x for half-width r.
  virtual double eval1D(double x, double r) const = 0;
  /// Must be called by derived constructors: integrates the profile and tabulates |f1| for
  /// sampling (32 cells per pixel of radius, as pbrt-v4's FilterSampler).
  void init();
  /// sample() with the filter's value at p given by eval(p): a final filter passes its own
  /// profile, called without virtual dispatch (same value as eval(p)).
  template <class Eval>
  FilterSample sampleTabulated(Vec2 u, Eval eval) const {
    const auto sx = dist_x_.sample(u.x), sy = dist_y_.sample(u.y);
    const Vec2 p(sx.x, sy.x);
    const double pdf = sx.pdf * sy.pdf;
    return {p, pdf > 0 ? eval(p) / pdf : 0.0};
  }

 private:
  Vec2 radius_;
  double integral_ = 0;
  PiecewiseConstant1D dist_x_, dist_y_;
};

/// "box": 1 inside the support; default radius 0.5. Sampled exactly (uniformly).
class BoxFilter final : public Filter {
 public:
  explicit BoxFilter(Vec2 radius = {0.5, 0.5});
  FilterSample sample(Vec2 u) const override;
  double pdf(Vec2 p) const override;

 protected:
  double eval1D(double x, double r) const override { return std::abs(x) <= r ? 1.0 : 0.0; }
};

/// "gaussian": exp(-x^2 / (2 sigma^2)) / sqrt(2 pi sigma^2) minus its value at the radius;
/// defaults radius 1.5, sigma 0.5. The profile is read by linear interpolation from a table of
/// |x| in [0, r] with cells no wider than 1/kCellsPerPixel pixel: error at most
/// (1/kCellsPerPixel)^2 / 8 times max |g''| = 1 / (sqrt(2 pi) sigma^3), i.e. 7.7e-6 of the peak
/// for sigma = 0.5 (the error of the filter, not of the image's expectation).
class GaussianFilter final : public Filter {
 public:
  static constexpr int kCellsPerPixel = 256;
  explicit GaussianFilter(Vec2 radius = {1.5, 1.5}, double sigma = 0.5);
  /// The profile from exp itself (no table), for half-width r.
  double eval1DExact(double x, double r) const;
  FilterSample sample(Vec2 u) const override;

 protected:
  double eval1D(double x, double r) const override;

 private:
  /// The profile read from table t (of half-width r).
  static double lookup(double x, double r, const std::vector<double>& t);

  double sigma_;
  // Profile at |x| = i / kCellsPerPixel for each axis' radius (x then y).
  std::vector<double> table_x_, table_y_;
};

/// "mitchell": Mitchell & Netravali 1988 cubic with parameters B, C on [-2, 2] scaled to the
/// radius; defaults radius 2, B = C = 1/3.
class MitchellFilter final : public Filter {
 public:
  explicit MitchellFilter(Vec2 radius = {2, 2}, double b = 1.0 / 3.0, double c = 1.0 / 3.0);
  /// The unscaled cubic on [-2, 2].
  double mitchell1D(double x) const;
  FilterSample sample(Vec2 u) const override;

 protected:
  double eval1D(double x, double r) const override { return mitchell1D(2 * x / r); }

 private:
  double b_, c_;
};

/// "sinc" (Lanczos windowed sinc): sinc(x) sinc(x / tau), sinc(x) = sin(pi x)/(pi x), zero
/// beyond the radius; defaults radius 4, tau 3.
class LanczosSincFilter final : public Filter {
 public:
  explicit LanczosSincFilter(Vec2 radius = {4, 4}, double tau = 3);
  FilterSample sample(Vec2 u) const override;

 protected:
  double eval1D(double x, double r) const override;

 private:
  double tau_;
};

/// "triangle": max(0, r - |x|); default radius 2. Sampled exactly (tent distribution).
class TriangleFilter final : public Filter {
 public:
  explicit TriangleFilter(Vec2 radius = {2, 2});
  FilterSample sample(Vec2 u) const override;
  double pdf(Vec2 p) const override;

 protected:
  double eval1D(double x, double r) const override { return std::max(0.0, r - std::abs(x)); }
};

}  // namespace lensim::sampling
