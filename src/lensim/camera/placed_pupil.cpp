#include "lensim/camera/placed_pupil.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>

#include "lensim/sampling/sampling.h"

namespace lensim::camera {

namespace {

// Bins along the film's longer side (the shorter side gets as many as keep them near square);
// intervals per axis of the grid over the disc; bisection steps on a grid line's boundary (its
// bracket ends 1/128 of a grid step wide).
constexpr int kBinsLong = 6, kGrid = 16, kBisect = 7;
// Margins: the interpolation error found at a bin's checks counts this many times; a bound
// over wavelengths widens by this share of the most an edge moves between neighbouring ones.
constexpr double kCheckFactor = 1.5, kWavelengthShare = 0.5;
// The least widening of a support, in grid steps (bisection's final bracket).
constexpr double kFloor = 1.0 / (1 << kBisect);

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
        if (!has[size_t(key)] || t > outer_t[size_t(key)]) {
          has[size_t(key)] = true;
          outer_t[size_t(key)] = t;
          outer_i[size_t(key)] = j * (kGrid + 1) + i;
        }
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
    // A floor of kFloor grid steps: the widening above can come out near zero where the
    // boundary runs along a grid line, and the blend across a bin then decides alone (a
    // tilted film's bounds missed a passing ray by 0.5 um there).
    return std::min(r_, value[size_t(best)] + widen + kFloor * h_);
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
    if ((da < 0 && db > 0) || (da > 0 && db < 0))
      out.v[size_t(out.n++)] = a + (b - a) * (da / (da - db));
  }
  return out;
}

double cross(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}

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
  std::vector<int> by_wavelength(lambdas.size());  // indices into lambdas, sorted by wavelength
  for (size_t k = 0; k < lambdas.size(); ++k) by_wavelength[k] = int(k);
  std::sort(by_wavelength.begin(), by_wavelength.end(),
            [&](int a, int b) { return lambdas[size_t(a)] < lambdas[size_t(b)]; });

  // Film points on a lattice at a quarter bin's spacing. A cell (a bin, or a quarter of one) of
  // side `span` lattice steps has its corners (nodes, traced at every wavelength) and its edge
  // middles and centre (checks, traced at the primary wavelength) on it.
  px_ = 4 * nx_ + 1;
  const int py = 4 * ny_ + 1, points = px_ * py, nl = int(lambdas.size());
  const auto filmAt = [&](int a, int b) {
    return Vec2{-half_.x + a * half_.x / (2 * nx_), -half_.y + b * half_.y / (2 * ny_)};
  };
  std::vector<Extent> ext(size_t(points * nl));
  std::vector<bool> done(ext.size());
  // Traces the cells' lattice points not traced yet, side by side.
  const auto trace = [&](const std::vector<std::array<int, 3>>& cells) {
    std::vector<std::array<int, 2>> tasks;  // point, wavelength
    for (const auto& [a0, b0, span] : cells)
      for (int b = b0; b <= b0 + span; b += span / 2)
        for (int a = a0; a <= a0 + span; a += span / 2) {
          const bool node = (a - a0) % span == 0 && (b - b0) % span == 0;
          for (int k = 0; k < (node ? nl : 1); ++k) {
            const size_t t = size_t(k * points + b * px_ + a);
            if (!done[t]) done[t] = true, tasks.push_back({b * px_ + a, k});
          }
        }
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, tasks.size(), 1),
        [&](const tbb::blocked_range<size_t>& range) {
          for (size_t t = range.begin(); t != range.end(); ++t) {
            const auto t0 = std::chrono::steady_clock::now();
            const auto [point, k] = tasks[t];
            const Vec2 film = filmAt(point % px_, point / px_);
            Extent& e = ext[size_t(k * points + point)];
            e = ExtentFinder(passes, film, lambdas[size_t(k)], disc_radius(film)).find();
            e.seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          }
        });
  };
  const auto at = [&](int a, int b, int k) -> const Extent& {
    return ext[size_t(k * points + b * px_ + a)];
  };
  nodes_.assign(size_t(points), std::nullopt);
  // A node's support: the largest over the wavelengths, widened by a share of the most it
  // moves between neighbouring ones; nullopt where some wavelength sees nothing.
  const auto node = [&](int a, int b) -> const std::optional<Support>& {
    std::optional<Support>& n = nodes_[size_t(b * px_ + a)];
    if (n) return n;
    Support u{}, moved{};
    for (size_t i = 0; i < by_wavelength.size(); ++i) {
      const Extent& e = at(a, b, by_wavelength[i]);
      if (!e.any) return n;
      for (size_t d = 0; d < u.size(); ++d) {
        u[d] = i == 0 ? e.s[d] : std::max(u[d], e.s[d]);
        if (i > 0)
          moved[d] = std::max(moved[d], std::abs(e.s[d] - at(a, b, by_wavelength[i - 1]).s[d]));
      }
    }
    for (size_t d = 0; d < u.size(); ++d) u[d] += kWavelengthShare * moved[d];
    return n = u;
  };
  // A cell is bounded when every node and check sees a region: the checks against the bilinear
  // blend of the corners' primary-wavelength supports give its margins.
  const auto cell = [&](int a0, int b0, int span) {
    Cell c;
    for (int b = b0; b <= b0 + span; b += span)
      for (int a = a0; a <= a0 + span; a += span)
        if (!node(a, b)) return c;
    Support margin{};
    for (int b = b0; b <= b0 + span; b += span / 2)
      for (int a = a0; a <= a0 + span; a += span / 2) {
        const Extent& e = at(a, b, 0);
        if (!e.any) return c;
        const double u = double(a - a0) / span, v = double(b - b0) / span;
        const int a1 = a0 + span, b1 = b0 + span;
        const Support blend = lerp(lerp(at(a0, b0, 0).s, at(a1, b0, 0).s, u),
                                   lerp(at(a0, b1, 0).s, at(a1, b1, 0).s, u), v);
        for (size_t d = 0; d < margin.size(); ++d)
          margin[d] = std::max(margin[d], e.s[d] - blend[d]);
      }
    c.bounded = true;
    for (size_t d = 0; d < margin.size(); ++d) c.margin[d] = kCheckFactor * margin[d];
    return c;
  };

  std::vector<std::array<int, 3>> cells;
  for (int j = 0; j < ny_; ++j)
    for (int i = 0; i < nx_; ++i) cells.push_back({4 * i, 4 * j, 4});
  trace(cells);
  bins_.assign(size_t(nx_ * ny_), Bin{});
  // A bin that light reaches only in part is cut into quarters (where some of its points see
  // a region), each bounded on its own where it can be.
  std::vector<int> split;
  for (int j = 0; j < ny_; ++j)
    for (int i = 0; i < nx_; ++i) {
      Bin& bin = bins_[size_t(j * nx_ + i)];
      bin.whole = cell(4 * i, 4 * j, 4);
      bool some = false;
      for (int b = 4 * j; b <= 4 * j + 4; b += 2)
        for (int a = 4 * i; a <= 4 * i + 4; a += 2) some = some || at(a, b, 0).any;
      if (!bin.whole.bounded && some) split.push_back(j * nx_ + i);
    }
  cells.clear();
  for (int n : split)
    for (int q = 0; q < 4; ++q)
      cells.push_back({4 * (n % nx_) + 2 * (q % 2), 4 * (n / nx_) + 2 * (q / 2), 2});
  trace(cells);
  for (int n : split) {
    Bin& bin = bins_[size_t(n)];
    bin.split = true;
    for (int q = 0; q < 4; ++q)
      bin.quarter[size_t(q)] = cell(4 * (n % nx_) + 2 * (q % 2), 4 * (n / nx_) + 2 * (q / 2), 2);
  }
  for (const Extent& e : ext) traces_ += e.traces, task_seconds_ += e.seconds;
}

std::optional<PlacedPolygon> PlacedPupilBounds::polygon(Vec2 film, double r) const {
  if (bins_.empty() || !(std::abs(film.x) <= half_.x) || !(std::abs(film.y) <= half_.y))
    return std::nullopt;
  // Film position in lattice steps.
  const double fx = (film.x + half_.x) / (2 * half_.x) * 4 * nx_,
               fy = (film.y + half_.y) / (2 * half_.y) * 4 * ny_;
  const int i = std::min(nx_ - 1, int(fx / 4)), j = std::min(ny_ - 1, int(fy / 4));
  const Bin& bin = bins_[size_t(j * nx_ + i)];
  int a0 = 4 * i, b0 = 4 * j, span = 4;
  const Cell* c = &bin.whole;
  if (!c->bounded && bin.split) {
    const int qa = fx - a0 >= 2 ? 1 : 0, qb = fy - b0 >= 2 ? 1 : 0;
    c = &bin.quarter[size_t(qb * 2 + qa)];
    a0 += 2 * qa, b0 += 2 * qb, span = 2;
  }
  if (!c->bounded) return std::nullopt;
  const auto node = [&](int a, int b) -> const Support& {
    return *nodes_[size_t((b0 + b * span) * px_ + a0 + a * span)];
  };
  const double u = std::clamp((fx - a0) / span, 0.0, 1.0),
               v = std::clamp((fy - b0) / span, 0.0, 1.0);
  const Support s = lerp(lerp(node(0, 0), node(1, 0), u), lerp(node(0, 1), node(1, 1), u), v);
  PlacedPolygon p;
  p.n = 4;
  p.v[0] = {-r, -r}, p.v[1] = {r, -r}, p.v[2] = {r, r}, p.v[3] = {-r, r};
  for (int k = 0; k < kDirections && p.n >= 3; ++k)
    p = clip(p, unit(k), s[size_t(k)] + c->margin[size_t(k)]);
  if (p.n < 3 || !(p.area() > 0)) return std::nullopt;
  return p;
}

PupilRegion PlacedPupilBounds::region(Vec2 film, double r) const {
  PupilRegion s;
  s.disc_radius = r;
  if (std::optional<PlacedPolygon> p = polygon(film, r))
    if (p->area() < std::numbers::pi * r * r) s.polygon = *p;
  return s;
}

double PupilRegion::area() const {
  return polygon ? polygon->area() : std::numbers::pi * disc_radius * disc_radius;
}

bool PupilRegion::holds(Vec2 q) const {
  const Vec2 d = q - centre;
  return polygon ? polygon->holds(q) : d.x * d.x + d.y * d.y <= disc_radius * disc_radius;
}

Vec2 PupilRegion::sample(Vec2 u) const {
  return polygon ? polygon->sample(u)
                 : centre + sampling::sampleUniformDiskConcentric(u) * disc_radius;
}

int PlacedPupilBounds::wholeBins() const {
  return int(
      std::count_if(bins_.begin(), bins_.end(), [](const Bin& b) { return !b.whole.bounded; }));
}

int PlacedPupilBounds::splitBins() const {
  return int(std::count_if(bins_.begin(), bins_.end(), [](const Bin& b) { return b.split; }));
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
