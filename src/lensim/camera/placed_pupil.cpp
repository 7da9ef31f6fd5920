#include "lensim/camera/placed_pupil.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace lensim::camera {

namespace {

// Bins along the film's longer side (the shorter side gets as many as keep them near square);
// intervals per axis of the grid over the disc; bisection steps on each row's and column's
// boundary (its bracket ends 1/128 of a grid step wide).
constexpr int kBinsLong = 8, kGrid = 12, kBisect = 7;
// Margins: the interpolation error found at a bin's checks counts this many times; a bound
// over wavelengths widens by this share of the most an edge moves between neighbouring ones.
constexpr double kCheckFactor = 1.5, kWavelengthShare = 0.5;

using Box = PlacedBox;

// The passing region's extent from one film point at one wavelength (see the header): a grid
// over the disc's square finds passing points; each grid row's leftmost and rightmost passing
// point (each column's lowest and highest) is moved out to the boundary by bisection, keeping
// the blocked end; an edge is the extreme row's (column's) value, widened by the most it differs
// from its neighbouring rows' (columns') values: for a convex region that bounds the boundary
// between grid rows (the boundary's tangent through the extreme row and its neighbour lies
// outside it), and one grid step when no neighbouring row passes.
struct Extent {
  bool any = false;
  Box box{};
  std::uint64_t traces = 0;
};

class ExtentFinder {
 public:
  ExtentFinder(const PlacedPupilBounds::Passes& passes, Vec2 film, double lambda_nm, double r)
      : passes_(passes), film_(film), lambda_(lambda_nm), r_(r), h_(2 * r / kGrid) {}

  Extent find() {
    Extent e;
    std::array<std::array<bool, kGrid + 1>, kGrid + 1> pass{};  // [row j][column i]
    for (int j = 0; j <= kGrid; ++j)
      for (int i = 0; i <= kGrid; ++i) {
        const Vec2 q = at(i, j);
        if (q.x * q.x + q.y * q.y > r_ * r_) continue;  // no ray outside the disc gets through
        pass[size_t(j)][size_t(i)] = test(q);
        e.any = e.any || pass[size_t(j)][size_t(i)];
      }
    if (e.any) {
      e.box.x0 = edge(pass, false, false), e.box.x1 = edge(pass, false, true);
      e.box.y0 = edge(pass, true, false), e.box.y1 = edge(pass, true, true);
    }
    e.traces = traces_;
    return e;
  }

 private:
  Vec2 at(int i, int j) const { return {-r_ + i * h_, -r_ + j * h_}; }
  bool test(Vec2 q) {
    ++traces_;
    return passes_(film_, q, lambda_);
  }
  // The edge along x (columns: along y), toward + when `high`: per grid line, the outermost
  // passing point moved out by bisection; then the extreme over the lines and its widening.
  double edge(const std::array<std::array<bool, kGrid + 1>, kGrid + 1>& pass, bool columns,
              bool high) {
    const double s = high ? 1 : -1;
    std::array<double, kGrid + 1> value{};
    std::array<bool, kGrid + 1> has{};
    for (int l = 0; l <= kGrid; ++l) {
      int outer = -1;
      for (int k = 0; k <= kGrid; ++k) {
        const int m = high ? kGrid - k : k;
        if (columns ? pass[size_t(m)][size_t(l)] : pass[size_t(l)][size_t(m)]) {
          outer = m;
          break;
        }
      }
      if (outer < 0) continue;
      has[size_t(l)] = true;
      const Vec2 p = columns ? at(l, outer) : at(outer, l);
      double a = columns ? p.y : p.x, b = a + s * h_;  // passing, blocked
      if (s * b > r_) {
        value[size_t(l)] = s * r_;  // the disc's square ends there
        continue;
      }
      for (int step = 0; step < kBisect; ++step) {
        const double m = (a + b) / 2;
        (test(columns ? Vec2{p.x, m} : Vec2{m, p.y}) ? a : b) = m;
      }
      value[size_t(l)] = b;
    }
    int best = -1;
    for (int l = 0; l <= kGrid; ++l)
      if (has[size_t(l)] && (best < 0 || s * value[size_t(l)] > s * value[size_t(best)])) best = l;
    double widen = -1;
    for (int n : {best - 1, best + 1})
      if (n >= 0 && n <= kGrid && has[size_t(n)])
        widen = std::max(widen, std::abs(value[size_t(best)] - value[size_t(n)]));
    if (widen < 0) widen = h_;
    return std::clamp(value[size_t(best)] + s * widen, -r_, r_);
  }

  const PlacedPupilBounds::Passes& passes_;
  Vec2 film_;
  double lambda_, r_, h_;
  std::uint64_t traces_ = 0;
};

Box lerp(const Box& a, const Box& b, double t) {
  return {a.x0 + (b.x0 - a.x0) * t, a.x1 + (b.x1 - a.x1) * t, a.y0 + (b.y0 - a.y0) * t,
          a.y1 + (b.y1 - a.y1) * t};
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
                        const Vec2 film = filmAt(task.point % px, task.point / px);
                        ext[size_t(task.k * points + task.point)] =
                            ExtentFinder(passes, film, lambdas[size_t(task.k)], disc_radius(film))
                                .find();
                      }
                    });
  for (const Extent& e : ext) traces_ += e.traces;
  const auto at = [&](int a, int b, int k) -> const Extent& {
    return ext[size_t(k * points + b * px + a)];
  };

  // Nodes: the union over the wavelengths, widened by a share of the most each edge moves
  // between neighbouring wavelengths.
  nodes_.assign(size_t((nx_ + 1) * (ny_ + 1)), std::nullopt);
  for (int b = 0; b <= ny_; ++b)
    for (int a = 0; a <= nx_; ++a) {
      std::vector<Box> boxes;  // by wavelength, sorted
      for (double l : sorted) {
        const int k = int(std::find(lambdas.begin(), lambdas.end(), l) - lambdas.begin());
        const Extent& e = at(2 * a, 2 * b, k);
        if (e.any) boxes.push_back(e.box);
      }
      if (int(boxes.size()) != nl) continue;
      Box u = boxes[0];
      std::array<double, 4> moved{};
      for (size_t k = 1; k < boxes.size(); ++k) {
        const Box& e = boxes[k];
        const Box& f = boxes[k - 1];
        u = {std::min(u.x0, e.x0), std::max(u.x1, e.x1), std::min(u.y0, e.y0),
             std::max(u.y1, e.y1)};
        moved = {std::max(moved[0], std::abs(e.x0 - f.x0)),
                 std::max(moved[1], std::abs(e.x1 - f.x1)),
                 std::max(moved[2], std::abs(e.y0 - f.y0)),
                 std::max(moved[3], std::abs(e.y1 - f.y1))};
      }
      const double w = kWavelengthShare;
      nodes_[size_t(b * (nx_ + 1) + a)] =
          Box{u.x0 - w * moved[0], u.x1 + w * moved[1], u.y0 - w * moved[2], u.y1 + w * moved[3]};
    }

  // Bins: the checks against the bilinear blend of the corners' primary-wavelength extents.
  bins_.assign(size_t(nx_ * ny_), Bin{});
  for (int j = 0; j < ny_; ++j)
    for (int i = 0; i < nx_; ++i) {
      Bin& bin = bins_[size_t(j * nx_ + i)];
      bool all = true;
      for (int b = 0; b <= 1; ++b)
        for (int a = 0; a <= 1; ++a) all = all && nodes_[size_t((j + b) * (nx_ + 1) + i + a)];
      std::array<double, 4> margin{};
      for (int b = 2 * j; b <= 2 * j + 2 && all; ++b)
        for (int a = 2 * i; a <= 2 * i + 2 && all; ++a) {
          const Extent& e = at(a, b, 0);
          all = e.any;
          if (!all || (a % 2 == 0 && b % 2 == 0)) continue;
          const double u = (a - 2 * i) / 2.0, v = (b - 2 * j) / 2.0;
          const Box blend = lerp(lerp(at(2 * i, 2 * j, 0).box, at(2 * i + 2, 2 * j, 0).box, u),
                                 lerp(at(2 * i, 2 * j + 2, 0).box, at(2 * i + 2, 2 * j + 2, 0).box, u),
                                 v);
          margin = {std::max(margin[0], blend.x0 - e.box.x0),
                    std::max(margin[1], e.box.x1 - blend.x1),
                    std::max(margin[2], blend.y0 - e.box.y0),
                    std::max(margin[3], e.box.y1 - blend.y1)};
        }
      if (!all) continue;  // the whole disc
      bin.bounded = true;
      bin.margin = {kCheckFactor * margin[0], kCheckFactor * margin[1], kCheckFactor * margin[2],
                    kCheckFactor * margin[3]};
    }
}

std::optional<PlacedBox> PlacedPupilBounds::box(Vec2 film) const {
  if (bins_.empty() || !(std::abs(film.x) <= half_.x) || !(std::abs(film.y) <= half_.y))
    return std::nullopt;
  const double fx = (film.x + half_.x) / (2 * half_.x) * nx_,
               fy = (film.y + half_.y) / (2 * half_.y) * ny_;
  const int i = std::min(nx_ - 1, int(fx)), j = std::min(ny_ - 1, int(fy));
  const Bin& bin = bins_[size_t(j * nx_ + i)];
  if (!bin.bounded) return std::nullopt;
  const auto node = [&](int a, int b) -> const Box& {
    return *nodes_[size_t((j + b) * (nx_ + 1) + i + a)];
  };
  const double u = fx - i, v = fy - j;
  const Box c = lerp(lerp(node(0, 0), node(1, 0), u), lerp(node(0, 1), node(1, 1), u), v);
  return Box{c.x0 - bin.margin[0], c.x1 + bin.margin[1], c.y0 - bin.margin[2],
             c.y1 + bin.margin[3]};
}

int PlacedPupilBounds::wholeBins() const {
  return int(std::count_if(bins_.begin(), bins_.end(), [](const Bin& b) { return !b.bounded; }));
}

}  // namespace lensim::camera
