#include "lensim/sampling/filter.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "lensim/util/error.h"

namespace lensim::sampling {

Filter::Filter(Vec2 radius) : radius_(radius) {
  if (!(radius.x > 0) || !(radius.y > 0))
    throw Error(fmt::format("filter radius ({}, {}) must be positive", radius.x, radius.y));
}

void Filter::init() {
  // Composite Simpson rule on each axis (the profiles are piecewise smooth; 4096 intervals keep
  // the error far below Monte Carlo noise).
  auto integrate = [&](double r) {
    const int n = 4096;
    const double h = 2 * r / n;
    double s = eval1D(-r, r) + eval1D(r, r);
    for (int i = 1; i < n; ++i) s += eval1D(-r + i * h, r) * (i % 2 ? 4 : 2);
    return s * h / 3;
  };
  integral_ = integrate(radius_.x) * integrate(radius_.y);
  auto table = [&](double r) {
    const int n = std::max(1, static_cast<int>(std::ceil(32 * r))) * 2;
    std::vector<double> f(n);
    // Each cell takes the largest |f| of a few points in it, so no cell where f != 0 gets
    // probability zero.
    for (int i = 0; i < n; ++i) {
      double m = 0;
      for (int k = 0; k <= 4; ++k)
        m = std::max(m, std::abs(eval1D(-r + (i + k / 4.0) * 2 * r / n, r)));
      f[i] = m;
    }
    return PiecewiseConstant1D(f, -r, r);
  };
  dist_x_ = table(radius_.x);
  dist_y_ = table(radius_.y);
}

FilterSample Filter::sample(Vec2 u) const {
  return sampleTabulated(u, [this](Vec2 p) { return eval(p); });
}

double Filter::pdf(Vec2 p) const {
  return dist_x_.pdf(p.x) * dist_y_.pdf(p.y);
}

// ---------------------------------------------------------------------------------------------

BoxFilter::BoxFilter(Vec2 radius) : Filter(radius) {
  init();
}

FilterSample BoxFilter::sample(Vec2 u) const {
  const Vec2 p((2 * u.x - 1) * radius().x, (2 * u.y - 1) * radius().y);
  return {p, 4 * radius().x * radius().y};
}

double BoxFilter::pdf(Vec2 p) const {
  if (std::abs(p.x) > radius().x || std::abs(p.y) > radius().y) return 0.0;
  return 1.0 / (4 * radius().x * radius().y);
}

GaussianFilter::GaussianFilter(Vec2 radius, double sigma) : Filter(radius), sigma_(sigma) {
  if (!(sigma > 0)) throw Error(fmt::format("gaussian filter sigma {} must be positive", sigma));
  auto table = [&](double r) {
    // n cells of width r / n <= 1 / kCellsPerPixel on [0, r], and one more node at r so that
    // |x| = r has both neighbours.
    const int n = static_cast<int>(std::ceil(r * kCellsPerPixel));
    std::vector<double> t(static_cast<size_t>(n) + 2);
    for (int i = 0; i <= n; ++i) t[size_t(i)] = eval1DExact(r * i / n, r);
    t[size_t(n) + 1] = t[size_t(n)];
    return t;
  };
  table_x_ = table(radius.x);
  table_y_ = table(radius.y);
  init();
}

double GaussianFilter::eval1DExact(double x, double r) const {
  auto g = [&](double t) {
    return std::exp(-t * t / (2 * sigma_ * sigma_)) / std::sqrt(2 * kPi * sigma_ * sigma_);
  };
  return std::abs(x) > r ? 0.0 : std::max(0.0, g(x) - g(r));
}

FilterSample GaussianFilter::sample(Vec2 u) const {
  const Vec2 r = radius();
  return sampleTabulated(
      u, [&](Vec2 p) { return lookup(p.x, r.x, table_x_) * lookup(p.y, r.y, table_y_); });
}

double GaussianFilter::eval1D(double x, double r) const {
  // eval1D is only called with the filter's own radii.
  return lookup(x, r, r == radius().x ? table_x_ : table_y_);
}

double GaussianFilter::lookup(double x, double r, const std::vector<double>& t) {
  const double a = std::abs(x);
  if (a > r) return 0.0;
  const double f = a / r * static_cast<double>(t.size() - 2);
  const size_t i = static_cast<size_t>(f);
  const double w = f - static_cast<double>(i);
  return t[i] * (1 - w) + t[i + 1] * w;
}

MitchellFilter::MitchellFilter(Vec2 radius, double b, double c) : Filter(radius), b_(b), c_(c) {
  init();
}

FilterSample MitchellFilter::sample(Vec2 u) const {
  // eval(p), with the qualified (non-virtual) call.
  return sampleTabulated(u, [this](Vec2 p) {
    return MitchellFilter::eval1D(p.x, radius().x) * MitchellFilter::eval1D(p.y, radius().y);
  });
}

double MitchellFilter::mitchell1D(double x) const {
  x = std::abs(x);
  const double B = b_, C = c_;
  if (x <= 1)
    return ((12 - 9 * B - 6 * C) * x * x * x + (-18 + 12 * B + 6 * C) * x * x + (6 - 2 * B)) / 6;
  if (x <= 2)
    return ((-B - 6 * C) * x * x * x + (6 * B + 30 * C) * x * x + (-12 * B - 48 * C) * x +
            (8 * B + 24 * C)) /
           6;
  return 0.0;
}

LanczosSincFilter::LanczosSincFilter(Vec2 radius, double tau) : Filter(radius), tau_(tau) {
  if (!(tau > 0)) throw Error(fmt::format("sinc filter tau {} must be positive", tau));
  init();
}

FilterSample LanczosSincFilter::sample(Vec2 u) const {
  return sampleTabulated(u, [this](Vec2 p) {
    return LanczosSincFilter::eval1D(p.x, radius().x) * LanczosSincFilter::eval1D(p.y, radius().y);
  });
}

double LanczosSincFilter::eval1D(double x, double r) const {
  if (std::abs(x) > r) return 0.0;
  auto sinc = [](double t) { return std::abs(t) < 1e-5 ? 1.0 : std::sin(kPi * t) / (kPi * t); };
  return sinc(x) * sinc(x / tau_);
}

TriangleFilter::TriangleFilter(Vec2 radius) : Filter(radius) {
  init();
}

FilterSample TriangleFilter::sample(Vec2 u) const {
  const Vec2 p(sampleTent(u.x, radius().x), sampleTent(u.y, radius().y));
  return {p, radius().x * radius().x * radius().y * radius().y};
}

double TriangleFilter::pdf(Vec2 p) const {
  return tentPdf(p.x, radius().x) * tentPdf(p.y, radius().y);
}

}  // namespace lensim::sampling
