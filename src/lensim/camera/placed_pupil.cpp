#include "lensim/camera/placed_pupil.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>

namespace lensim::camera {

namespace {

// Bins along the film's longer side (the shorter side gets as many as keep them near square);
// intervals per axis of the grid over the disc; bisection steps on a grid line's boundary (its
// bracket ends 1/128 of a grid step wide).
constexpr int kBinsLong = 6, kGrid = 16, kBisect = 7;
// Margins: the interpolation error found at a bin's checks counts this many times; a bound
// over wavelengths widens by this share of the most an edge moves between neighbouring ones.
constexpr double kCheckFactor = 1.5, kWavelengthShare = 0.5;

using Support = PlacedPupilBounds::Support;
constexpr int kDirections = PlacedPupilBounds::kDirections;

// The grid steps along the directions (k x 45 degrees).
constexpr std::array<std::array<int, 2>, kDirections> kStep{
    {{1, 0}, {1, 1}, {0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}}};

Vec2 unit(int k) {
  const double a = k * std::numbers::pi / 4;
  return {std::cos(a), std::sin(a)};
}

// The passing region's supports from one film point at one wavelength (see the header).
struct Extent {
  bool any = false;
  Support s{};
  std::uint64_t traces = 0;
  double seconds = 0;  // the task's time
};

class ExtentFinder {
 public:
  ExtentFinder(const PlacedPupilBounds::Passes& passes, Vec2 film, double lambda_nm, double r)
      : passes_(passes), film_(film), lambda_(lambda_nm), r_(r), h_(2 * r / kGrid) {}

  Extent find() {
    Extent e;
    for (int j = 0; j <= kGrid; ++j)
      for (int i = 0; i <= kGrid; ++i) {
        const Vec2 q = at(i, j);
        if (q.x * q.x + q.y * q.y > r_ * r_) continue;  // no ray outside the disc gets through
        pass_[size_t(j)][size_t(i)] = test(q);
        e.any = e.any || pass_[size_t(j)][size_t(i)];
      }
    if (e.any)
      for (int k = 0; k < kDirections; ++k) e.s[size_t(k)] = support(k);
    e.traces = traces_;
    return e;
  }

 private:
  static constexpr int kKeys = 4 * kGrid + 1;  // grid lines along a direction, indexed + 2 kGrid

  Vec2 at(int i, int j) const { return {-r_ + i * h_, -r_ + j * h_}; }
  bool test(Vec2 q) {
    ++traces_;
    return passes_(film_, q, lambda_);
  }
  // The support along direction k: on each grid line along it, the outermost passing point
  // moved out to the boundary by bisection; the extreme over the lines, widened.
  double support(int k) {
    const int gx = kStep[size_t(k)][0], gy = kStep[size_t(k)][1];
    const Vec2 n = unit(k), g{h_ * gx, h_ * gy};
    std::array<int, kKeys> outer_i{}, outer_t{};
    std::array<bool, kKeys> has{};
    for (int j = 0; j <= kGrid; ++j)
      for (int i = 0; i <= kGrid; ++i) {
        if (!pass_[size_t(j)][size_t(i)]) continue;
        const int key = gx * j - gy * i + 2 * kGrid, t = gx * i + gy * j;
        if (!has[size_t(key)] || t > outer_t[size_t(key)])
          has[size_t(key)] = true, outer_t[size_t(key)] = t, outer_i[size_t(key)] = j * (kGrid + 1) + i;
      }
    // Each line's boundary lies within one step past its outermost passing point: lines are
    // refined in order of that point, until none left can beat the best refined value; then the
    // best line's neighbours (for the widening).
    std::array<double, kKeys> value{};
    std::array<bool, kKeys> refined{};
    const double step = h_ * std::hypot(gx, gy);
    const auto refine = [&](int key) {
      const Vec2 p = at(outer_i[size_t(key)] % (kGrid + 1), outer_i[size_t(key)] / (kGrid + 1));
      double a = 0, b = 1;  // along g from p: passing, blocked (the next grid point)
      for (int m = 0; m < kBisect; ++m) {
        const double mid = (a + b) / 2;
        (test(p + g * mid) ? a : b) = mid;
      }
      const Vec2 q = p + g * b;
      value[size_t(key)] = q.x * n.x + q.y * n.y;
      refined[size_t(key)] = true;
    };
    std::array<int, kKeys> order{};
    int lines = 0;
    for (int key = 0; key < kKeys; ++key)
      if (has[size_t(key)]) order[size_t(lines++)] = key;
    std::sort(order.begin(), order.begin() + lines,
              [&](int a, int b) { return outer_t[size_t(a)] > outer_t[size_t(b)]; });
    int best = -1;
    for (int l = 0; l < lines; ++l) {
      const int key = order[size_t(l)];
      const Vec2 p = at(outer_i[size_t(key)] % (kGrid + 1), outer_i[size_t(key)] / (kGrid + 1));
      if (best >= 0 && p.x * n.x + p.y * n.y + step < value[size_t(best)]) break;
      refine(key);
      if (best < 0 || value[size_t(key)] > value[size_t(best)]) best = key;
    }
    for (int nb : {best - 1, best + 1})
      if (nb >= 0 && nb < kKeys && has[size_t(nb)] && !refined[size_t(nb)]) refine(nb);
    double widen = -1;
    for (int nb : {best - 1, best + 1})
      if (nb >= 0 && nb < kKeys && has[size_t(nb)])
        widen = std::max(widen, std::abs(value[size_t(best)] - value[size_t(nb)]));
    if (widen < 0) widen = h_ * std::hypot(gx, gy);
    return std::min(r_, value[size_t(best)] + widen);
  }

  const PlacedPupilBounds::Passes& passes_;
  Vec2 film_;
  double lambda_, r_, h_;
  std::array<std::array<bool, kGrid + 1>, kGrid + 1> pass_{};  // [row j][column i]
  std::uint64_t traces_ = 0;
};

Support lerp(const Support& a, const Support& b, double t) {
  Support r;
  for (size_t k = 0; k < r.size(); ++k) r[k] = a[k] + (b[k] - a[k]) * t;
  return r;
}

// The convex polygon p cut by the half-plane q . n <= s.
PlacedPolygon clip(const PlacedPolygon& p, Vec2 n, double s) {
  PlacedPolygon out;
  for (int i = 0; i < p.n; ++i) {
    const Vec2 a = p.v[size_t(i)], b = p.v[size_t((i + 1) % p.n)];
    const double da = a.x * n.x + a.y * n.y - s, db = b.x * n.x + b.y * n.y - s;
    if (da <= 0) out.v[size_t(out.n++)] = a;
    if ((da < 0 && db > 0) || (da > 0 && db < 0)) out.v[size_t(out.n++)] = a + (b - a) * (da / (da - db));
  }
  return out;
}

double cross(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }

}  // namespace

PlacedPupilBounds::PlacedPupilBounds(Vec2 half_mm, const std::vector<double>& wavelengths_nm,
                                     const DiscRadius& disc_radius, const Passes& passes)
    : half_(half_mm) {
  const double longer = std::max(half_mm.x, half_mm.y), shorter = std::min(half_mm.x, half_mm.y);
  const int short_bins = std::max(2, int(std::lround(kBinsLong * shorter / longer)));
  nx_ = half_mm.x >= half_mm.y ? kBinsLong : short_bins;
  ny_ = half_mm.x >= half_mm.y ? short_bins : kBinsLong;
  // The primary wavelength first, the others sorted (neighbours in wavelength are adjacent).
  std::vector<double> lambdas = wavelengths_nm;
  std::sort(lambdas.begin() + 1, lambdas.end());
  std::vector<double> sorted = lambdas;
  std::sort(sorted.begin(), sorted.end());

  // Film points on the lattice at half-bin spacing: (a, b) both even are the bins' corners
  // (nodes, traced at every wavelength), the others their edge middles and centres (checks,
  // traced at the primary wavelength).
  const int px = 2 * nx_ + 1, py = 2 * ny_ + 1, points = px * py, nl = int(lambdas.size());
  const auto filmAt = [&](int a, int b) {
    return Vec2{-half_.x + a * half_.x / nx_, -half_.y + b * half_.y / ny_};
  };
  struct Task {
    int point, k;
  };
  std::vector<Task> tasks;
  for (int k = 0; k < nl; ++k)
    for (int p = 0; p < points; ++p)
      if (k == 0 || ((p % px) % 2 == 0 && (p / px) % 2 == 0)) tasks.push_back({p, k});
  std::vector<Extent> ext(size_t(points * nl));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tasks.size(), 1),
                    [&](const tbb::blocked_range<size_t>& range) {
                      for (size_t t = range.begin(); t != range.end(); ++t) {
                        const Task& task = tasks[t];
                        const auto t0 = std::chrono::steady_clock::now();
                        const Vec2 film = filmAt(task.point % px, task.point / px);
                        Extent& e = ext[size_t(task.k * points + task.point)];
                        e = ExtentFinder(passes, film, lambdas[size_t(task.k)], disc_radius(film))
                                .find();
                        e.seconds = std::chrono::duration<double>(
                                        std::chrono::steady_clock::now() - t0)
                                        .count();
                      }
                    });
  for (const Extent& e : ext) traces_ += e.traces, task_seconds_ += e.seconds;
  const auto at = [&](int a, int b, int k) -> const Extent& {
    return ext[size_t(k * points + b * px + a)];
  };

  // Nodes: the largest support over the wavelengths, widened by a share of the most it moves
  // between neighbouring ones.
  nodes_.assign(size_t((nx_ + 1) * (ny_ + 1)), std::nullopt);
  for (int b = 0; b <= ny_; ++b)
    for (int a = 0; a <= nx_; ++a) {
      std::vector<Support> by_wavelength;  // sorted
      for (double l : sorted) {
        const int k = int(std::find(lambdas.begin(), lambdas.end(), l) - lambdas.begin());
        const Extent& e = at(2 * a, 2 * b, k);
        if (e.any) by_wavelength.push_back(e.s);
      }
      if (int(by_wavelength.size()) != nl) continue;
      Support u = by_wavelength[0], moved{};
      for (size_t k = 1; k < by_wavelength.size(); ++k)
        for (size_t d = 0; d < u.size(); ++d) {
          u[d] = std::max(u[d], by_wavelength[k][d]);
          moved[d] = std::max(moved[d], std::abs(by_wavelength[k][d] - by_wavelength[k - 1][d]));
        }
      for (size_t d = 0; d < u.size(); ++d) u[d] += kWavelengthShare * moved[d];
      nodes_[size_t(b * (nx_ + 1) + a)] = u;
    }

  // Bins: the checks against the bilinear blend of the corners' primary-wavelength supports.
  bins_.assign(size_t(nx_ * ny_), Bin{});
  for (int j = 0; j < ny_; ++j)
    for (int i = 0; i < nx_; ++i) {
      Bin& bin = bins_[size_t(j * nx_ + i)];
      bool all = true;
      for (int b = 0; b <= 1; ++b)
        for (int a = 0; a <= 1; ++a)
          all = all && nodes_[size_t((j + b) * (nx_ + 1) + i + a)].has_value();
      Support margin{};
      for (int b = 2 * j; b <= 2 * j + 2 && all; ++b)
        for (int a = 2 * i; a <= 2 * i + 2 && all; ++a) {
          const Extent& e = at(a, b, 0);
          all = e.any;
          if (!all || (a % 2 == 0 && b % 2 == 0)) continue;
          const double u = (a - 2 * i) / 2.0, v = (b - 2 * j) / 2.0;
          const Support blend =
              lerp(lerp(at(2 * i, 2 * j, 0).s, at(2 * i + 2, 2 * j, 0).s, u),
                   lerp(at(2 * i, 2 * j + 2, 0).s, at(2 * i + 2, 2 * j + 2, 0).s, u), v);
          for (size_t d = 0; d < margin.size(); ++d)
            margin[d] = std::max(margin[d], e.s[d] - blend[d]);
        }
      if (!all) continue;  // the whole disc
      bin.bounded = true;
      for (size_t d = 0; d < margin.size(); ++d) bin.margin[d] = kCheckFactor * margin[d];
    }
}

std::optional<PlacedPolygon> PlacedPupilBounds::polygon(Vec2 film, double r) const {
  if (bins_.empty() || !(std::abs(film.x) <= half_.x) || !(std::abs(film.y) <= half_.y))
    return std::nullopt;
  const double fx = (film.x + half_.x) / (2 * half_.x) * nx_,
               fy = (film.y + half_.y) / (2 * half_.y) * ny_;
  const int i = std::min(nx_ - 1, int(fx)), j = std::min(ny_ - 1, int(fy));
  const Bin& bin = bins_[size_t(j * nx_ + i)];
  if (!bin.bounded) return std::nullopt;
  const auto node = [&](int a, int b) -> const Support& {
    return *nodes_[size_t((j + b) * (nx_ + 1) + i + a)];
  };
  const double u = fx - i, v = fy - j;
  const Support s = lerp(lerp(node(0, 0), node(1, 0), u), lerp(node(0, 1), node(1, 1), u), v);
  PlacedPolygon p;
  p.n = 4;
  p.v[0] = {-r, -r}, p.v[1] = {r, -r}, p.v[2] = {r, r}, p.v[3] = {-r, r};
  for (int k = 0; k < kDirections && p.n >= 3; ++k)
    p = clip(p, unit(k), s[size_t(k)] + bin.margin[size_t(k)]);
  if (p.n < 3 || !(p.area() > 0)) return std::nullopt;
  return p;
}

int PlacedPupilBounds::wholeBins() const {
  return int(std::count_if(bins_.begin(), bins_.end(), [](const Bin& b) { return !b.bounded; }));
}

double PlacedPolygon::area() const {
  double a = 0;
  for (int i = 1; i + 1 < n; ++i) a += cross(v[size_t(i)] - v[0], v[size_t(i + 1)] - v[0]);
  return a / 2;
}

bool PlacedPolygon::holds(Vec2 q) const {
  for (int i = 0; i < n; ++i)
    if (cross(v[size_t((i + 1) % n)] - v[size_t(i)], q - v[size_t(i)]) < 0) return false;
  return true;
}

Vec2 PlacedPolygon::sample(Vec2 u) const {
  const double total = area();
  double t = u.x * total;
  int i = 1;
  double a = 0;
  for (; i + 1 < n; ++i) {
    a = cross(v[size_t(i)] - v[0], v[size_t(i + 1)] - v[0]) / 2;
    if (t < a || i + 2 == n) break;
    t -= a;
  }
  const double s = std::sqrt(std::clamp(t / a, 0.0, 1.0));
  return v[0] * (1 - s) + (v[size_t(i)] * (1 - u.y) + v[size_t(i + 1)] * u.y) * s;
}

}  // namespace lensim::camera
