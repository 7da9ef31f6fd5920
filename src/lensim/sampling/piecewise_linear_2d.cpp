#include "lensim/sampling/piecewise_linear_2d.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lensim::sampling {

namespace {

// The largest i in [0, n-2] with pred(i) true, pred being true then false over the indices
// (0 when pred(1) is false); n >= 2.
template <class Pred>
std::size_t findInterval(std::size_t n, Pred pred) {
  std::size_t lo = 1, count = n - 2;  // search [1, n-1) for the first index where pred is false
  while (count > 0) {
    const std::size_t half = count / 2, mid = lo + half;
    if (pred(mid)) {
      lo = mid + 1;
      count -= half + 1;
    } else {
      count = half;
    }
  }
  return std::min(lo - 1, n - 2);
}

// The t in [0,1] with integral_0^t ((1-s) a + s b) ds = y, for a, b >= 0 (the root of
// (b-a)/2 t^2 + a t - y = 0 in the form that needs no special case for a == b).
double solveLinearDensity(double a, double b, double y) {
  const double den = a + std::sqrt(std::max(0.0, a * a + 2 * (b - a) * y));
  const double t = den > 0 ? 2 * y / den : 0.0;
  return std::clamp(t, 0.0, 1.0);
}

}  // namespace

double PiecewiseLinear2D::sliceIntegral(std::span<const float> data, int nx, int ny,
                                        std::size_t s) {
  const float* d = data.data() + s * std::size_t(nx) * std::size_t(ny);
  double sum = 0;
  for (int y = 0; y < ny; ++y) {
    const double wy = (y == 0 || y == ny - 1) ? 0.5 : 1.0;
    for (int x = 0; x < nx; ++x) {
      const double wx = (x == 0 || x == nx - 1) ? 0.5 : 1.0;
      sum += wx * wy * d[std::size_t(y) * nx + x];
    }
  }
  return sum / (double(nx - 1) * double(ny - 1));
}

double PiecewiseLinear2D::bytesFor(std::size_t slices, int nx, int ny, Mode mode) {
  const double n = double(slices) * nx * ny;
  return mode == Mode::Density ? 4.0 * (2 * n + double(slices) * ny) : 4.0 * n;
}

PiecewiseLinear2D::PiecewiseLinear2D(std::span<const float> data, int nx, int ny,
                                     std::vector<std::vector<float>> param_values, Mode mode)
    : nx_(nx), ny_(ny), mode_(mode), params_(std::move(param_values)) {
  if (nx < 2 || ny < 2 || params_.size() > 3)
    throw std::invalid_argument("PiecewiseLinear2D: need nx, ny >= 2 and at most 3 parameters");
  std::size_t slices = 1;
  param_stride_.assign(params_.size(), 0);
  for (int d = int(params_.size()) - 1; d >= 0; --d) {
    const std::size_t n = params_[std::size_t(d)].size();
    if (n == 0) throw std::invalid_argument("PiecewiseLinear2D: empty parameter");
    param_stride_[std::size_t(d)] = n > 1 ? slices : 0;
    slices *= n;
  }
  const std::size_t per = std::size_t(nx) * std::size_t(ny);
  if (data.size() != slices * per)
    throw std::invalid_argument("PiecewiseLinear2D: data size does not match the shape");
  data_.assign(data.begin(), data.end());
  if (mode == Mode::Values) return;

  marginal_cdf_.resize(slices * std::size_t(ny));
  conditional_cdf_.resize(slices * per);
  for (std::size_t s = 0; s < slices; ++s) {
    float* d = data_.data() + s * per;
    float* cond = conditional_cdf_.data() + s * per;
    float* marg = marginal_cdf_.data() + s * std::size_t(ny);
    // Running integrals in units of one cell (trapezoids of the linear interpolant).
    std::vector<double> row_total(std::size_t(ny), 0.0);
    std::vector<double> c(per);
    for (int y = 0; y < ny; ++y) {
      double sum = 0;
      c[std::size_t(y) * nx] = 0;
      for (int x = 0; x + 1 < nx; ++x) {
        sum += 0.5 * (double(d[std::size_t(y) * nx + x]) + d[std::size_t(y) * nx + x + 1]);
        c[std::size_t(y) * nx + x + 1] = sum;
      }
      row_total[std::size_t(y)] = sum;
    }
    std::vector<double> m(std::size_t(ny), 0.0);
    for (int y = 0; y + 1 < ny; ++y)
      m[std::size_t(y) + 1] =
          m[std::size_t(y)] + 0.5 * (row_total[std::size_t(y)] + row_total[std::size_t(y) + 1]);
    const double total = m[std::size_t(ny) - 1];
    const double norm = total > 0 ? 1 / total : 0;  // the caller refuses empty slices
    for (std::size_t i = 0; i < per; ++i) {
      cond[i] = float(c[i] * norm);
      d[i] = float(d[i] * norm);
    }
    for (int y = 0; y < ny; ++y) marg[y] = float(m[std::size_t(y)] * norm);
  }
}

PiecewiseLinear2D::Corners PiecewiseLinear2D::corners(std::span<const double> params) const {
  Corners c;
  c.slice[0] = 0;
  c.weight[0] = 1;
  for (std::size_t d = 0; d < params_.size(); ++d) {
    const std::vector<float>& v = params_[d];
    if (v.size() < 2) continue;
    const double p = d < params.size() ? params[d] : 0.0;
    const std::size_t i = findInterval(v.size(), [&](std::size_t k) { return v[k] <= p; });
    double w1 = (p - v[i]) / (double(v[i + 1]) - v[i]);
    if (!(w1 >= 0)) w1 = 0;  // also NaN
    w1 = std::min(w1, 1.0);
    const std::size_t stride = param_stride_[d];
    const int n = c.n;
    for (int k = 0; k < n; ++k) {
      c.slice[n + k] = c.slice[k] + (i + 1) * stride;
      c.weight[n + k] = c.weight[k] * w1;
      c.slice[k] += i * stride;
      c.weight[k] *= 1 - w1;
    }
    c.n = 2 * n;
  }
  return c;
}

double PiecewiseLinear2D::blend(const std::vector<float>& table, std::size_t stride, std::size_t i,
                                const Corners& c) {
  double v = 0;
  for (int k = 0; k < c.n; ++k) v += c.weight[k] * table[c.slice[k] * stride + i];
  return v;
}

double PiecewiseLinear2D::eval(Vec2 pos, std::span<const double> params) const {
  if (data_.empty()) return 0;
  const Corners c = corners(params);
  const double fx = std::clamp(pos.x, 0.0, 1.0) * (nx_ - 1);
  const double fy = std::clamp(pos.y, 0.0, 1.0) * (ny_ - 1);
  const int x = std::min(int(fx), nx_ - 2), y = std::min(int(fy), ny_ - 2);
  const double s = fx - x, t = fy - y;
  const std::size_t per = std::size_t(nx_) * std::size_t(ny_);
  const std::size_t i = std::size_t(y) * nx_ + x;
  const double v00 = blend(data_, per, i, c), v10 = blend(data_, per, i + 1, c),
               v01 = blend(data_, per, i + nx_, c), v11 = blend(data_, per, i + nx_ + 1, c);
  const double v = (1 - t) * ((1 - s) * v00 + s * v10) + t * ((1 - s) * v01 + s * v11);
  return mode_ == Mode::Density ? v * (nx_ - 1) * (ny_ - 1) : v;
}

PiecewiseLinear2D::Sample PiecewiseLinear2D::sample(Vec2 u, std::span<const double> params) const {
  if (mode_ != Mode::Density || data_.empty()) return {};
  constexpr double kEps = 1e-9;
  u.x = std::clamp(u.x, kEps, 1 - kEps);
  u.y = std::clamp(u.y, kEps, 1 - kEps);
  const Corners c = corners(params);
  const std::size_t per = std::size_t(nx_) * std::size_t(ny_);

  // The row: marginal CDF, then the position t inside the row strip.
  auto marginal = [&](std::size_t k) { return blend(marginal_cdf_, std::size_t(ny_), k, c); };
  const std::size_t row =
      findInterval(std::size_t(ny_), [&](std::size_t k) { return marginal(k) < u.y; });
  double y = u.y - marginal(row);
  const std::size_t r = row * std::size_t(nx_);
  const double r0 = blend(conditional_cdf_, per, r + nx_ - 1, c);
  const double r1 = blend(conditional_cdf_, per, r + 2 * std::size_t(nx_) - 1, c);
  const double t = solveLinearDensity(r0, r1, y);

  // The column: conditional CDF of the row interpolated at t.
  double x = u.x * ((1 - t) * r0 + t * r1);
  auto conditional = [&](std::size_t k) {
    return (1 - t) * blend(conditional_cdf_, per, r + k, c) +
           t * blend(conditional_cdf_, per, r + nx_ + k, c);
  };
  const std::size_t col =
      findInterval(std::size_t(nx_), [&](std::size_t k) { return conditional(k) < x; });
  x -= conditional(col);
  const std::size_t i = r + col;
  const double v00 = blend(data_, per, i, c), v10 = blend(data_, per, i + 1, c),
               v01 = blend(data_, per, i + nx_, c), v11 = blend(data_, per, i + nx_ + 1, c);
  const double c0 = (1 - t) * v00 + t * v01, c1 = (1 - t) * v10 + t * v11;
  const double s = solveLinearDensity(c0, c1, x);
  return {{(double(col) + s) / (nx_ - 1), (double(row) + t) / (ny_ - 1)},
          ((1 - s) * c0 + s * c1) * (nx_ - 1) * (ny_ - 1)};
}

PiecewiseLinear2D::Sample PiecewiseLinear2D::invert(Vec2 p, std::span<const double> params) const {
  if (mode_ != Mode::Density || data_.empty()) return {};
  const Corners c = corners(params);
  const std::size_t per = std::size_t(nx_) * std::size_t(ny_);
  const double fx = std::clamp(p.x, 0.0, 1.0) * (nx_ - 1);
  const double fy = std::clamp(p.y, 0.0, 1.0) * (ny_ - 1);
  const int col = std::min(int(fx), nx_ - 2), row = std::min(int(fy), ny_ - 2);
  const double s = fx - col, t = fy - row;
  const std::size_t r = std::size_t(row) * nx_, i = r + col;
  const double v00 = blend(data_, per, i, c), v10 = blend(data_, per, i + 1, c),
               v01 = blend(data_, per, i + nx_, c), v11 = blend(data_, per, i + nx_ + 1, c);
  const double c0 = (1 - t) * v00 + t * v01, c1 = (1 - t) * v10 + t * v11;
  const double pdf = (1 - s) * c0 + s * c1;
  // Column: the conditional CDF of the row at t, up to the cell, plus the cell's part.
  double x = s * (c0 + 0.5 * s * (c1 - c0)) + (1 - t) * blend(conditional_cdf_, per, i, c) +
             t * blend(conditional_cdf_, per, i + nx_, c);
  const double r0 = blend(conditional_cdf_, per, r + nx_ - 1, c);
  const double r1 = blend(conditional_cdf_, per, r + 2 * std::size_t(nx_) - 1, c);
  const double row_total = (1 - t) * r0 + t * r1;
  x = row_total > 0 ? x / row_total : 0;
  // Row: the marginal CDF up to the row plus the strip's part.
  const double y =
      t * (r0 + 0.5 * t * (r1 - r0)) + blend(marginal_cdf_, std::size_t(ny_), std::size_t(row), c);
  return {{x, y}, pdf * (nx_ - 1) * (ny_ - 1)};
}

}  // namespace lensim::sampling
