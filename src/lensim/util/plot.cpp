#include "lensim/util/plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace lensim::plot {

const char* paletteColor(int i) {
  // Okabe-Ito palette (colour-blind safe), without the yellow that vanishes on white.
  static const char* kColors[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                  "#E69F00", "#56B4E9", "#000000"};
  return kColors[((i % 7) + 7) % 7];
}

std::vector<double> niceTicks(double lo, double hi, int target_count) {
  std::vector<double> ticks;
  if (!(hi > lo)) {
    ticks.push_back(lo);
    return ticks;
  }
  const double raw = (hi - lo) / std::max(1, target_count);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (double t = first; t <= hi + 1e-9 * step; t += step)
    ticks.push_back(std::abs(t) < 1e-12 * step ? 0.0 : t);
  return ticks;
}

namespace {

std::string tickLabel(double v, double step) {
  if (v == 0) return "0";
  const double a = std::abs(v);
  if (a >= 1e5 || a < 1e-3) return fmt::format("{:.3g}", v);
  int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  if (decimals > 6) decimals = 6;
  return fmt::format("{:.{}f}", v, decimals);
}

std::pair<double, double> padRange(double lo, double hi, bool pad) {
  if (!(hi > lo)) {
    const double d = lo == 0 ? 1.0 : std::abs(lo) * 0.1;
    return {lo - d, hi + d};
  }
  if (!pad) return {lo, hi};
  const double d = 0.05 * (hi - lo);
  return {lo - d, hi + d};
}

}  // namespace

void Chart::render(svg::Document& doc, double x, double y, double w, double h) const {
  // Data ranges.
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin;
  double ymin = xmin, ymax = -xmin;
  for (const Series& s : series)
    for (const auto& [px, py] : s.points) {
      if (!std::isfinite(px) || !std::isfinite(py)) continue;
      xmin = std::min(xmin, px), xmax = std::max(xmax, px);
      ymin = std::min(ymin, py), ymax = std::max(ymax, py);
    }
  if (!std::isfinite(xmin)) xmin = 0, xmax = 1, ymin = 0, ymax = 1;
  if (include_zero_y) ymin = std::min(ymin, 0.0), ymax = std::max(ymax, 0.0);
  // Plain references, not structured bindings: clang 14 (the fuzz and sanitizer builds) cannot
  // capture those in the lambdas below.
  std::pair<double, double> xr = x_range ? *x_range : padRange(xmin, xmax, !x_log);
  std::pair<double, double> yr = y_range ? *y_range : padRange(ymin, ymax, true);
  double &x0 = xr.first, &x1 = xr.second, &y0 = yr.first, &y1 = yr.second;
  if (x_log) {
    x0 = std::max(x0, 1e-300);
    if (!(x1 > x0)) x1 = x0 * 10;
  }

  // Plot area inside the margins.
  const double left = x + 62, right = x + w - 14, top = y + 30, bottom = y + h - 44;
  double pw = right - left, ph = bottom - top;
  double ox = left, oy = top;
  if (equal_aspect) {
    // Same mm per pixel on both axes: widen the range that needs it.
    const double sx = (x1 - x0) / pw, sy = (y1 - y0) / ph;
    if (sx > sy) {
      const double c = 0.5 * (y0 + y1), half = 0.5 * sx * ph;
      y0 = c - half, y1 = c + half;
    } else {
      const double c = 0.5 * (x0 + x1), half = 0.5 * sy * pw;
      x0 = c - half, x1 = c + half;
    }
  }
  auto mapX = [&](double v) {
    if (x_log)
      return ox + pw * (std::log10(v) - std::log10(x0)) / (std::log10(x1) - std::log10(x0));
    return ox + pw * (v - x0) / (x1 - x0);
  };
  auto mapY = [&](double v) { return oy + ph * (1 - (v - y0) / (y1 - y0)); };

  doc.beginGroup({{"class", "chart"}});
  doc.rect(ox, oy, pw, ph, {{"fill", "#ffffff"}, {"stroke", "#444444"}, {"stroke-width", "1"}});
  // Ticks and grid.
  const svg::Attrs grid{{"stroke", "#e3e3e3"}, {"stroke-width", "0.8"}};
  const svg::Attrs label{{"font-size", "11"}, {"fill", "#333333"}};
  std::vector<double> xt;
  if (x_log) {
    for (int e = static_cast<int>(std::floor(std::log10(x0))); e <= std::ceil(std::log10(x1)); ++e)
      for (double m : {1.0, 2.0, 5.0}) {
        const double v = m * std::pow(10.0, e);
        if (v >= x0 * (1 - 1e-9) && v <= x1 * (1 + 1e-9)) xt.push_back(v);
      }
  } else {
    xt = niceTicks(x0, x1);
  }
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1;
  for (double t : xt) {
    const double px = mapX(t);
    doc.line(px, oy, px, oy + ph, grid);
    doc.line(px, oy + ph, px, oy + ph + 4, {{"stroke", "#444444"}});
    auto attrs = label;
    attrs.push_back({"text-anchor", "middle"});
    doc.text(px, oy + ph + 16, x_log ? fmt::format("{:g}", t) : tickLabel(t, xstep), attrs);
  }
  const std::vector<double> yt = niceTicks(y0, y1);
  const double ystep = yt.size() > 1 ? yt[1] - yt[0] : 1;
  for (double t : yt) {
    const double py = mapY(t);
    doc.line(ox, py, ox + pw, py, grid);
    doc.line(ox - 4, py, ox, py, {{"stroke", "#444444"}});
    auto attrs = label;
    attrs.push_back({"text-anchor", "end"});
    doc.text(ox - 6, py + 4, tickLabel(t, ystep), attrs);
  }
  // Axis labels and title.
  doc.text(ox + pw / 2, oy + ph + 34, x_label,
           {{"font-size", "12"}, {"text-anchor", "middle"}, {"fill", "#000000"}});
  doc.text(
      x + 14, oy + ph / 2, y_label,
      {{"font-size", "12"},
       {"text-anchor", "middle"},
       {"fill", "#000000"},
       {"transform", fmt::format("rotate(-90 {} {})", svg::num(x + 14), svg::num(oy + ph / 2))}});
  doc.text(ox + pw / 2, y + 18, title,
           {{"font-size", "13"}, {"font-weight", "bold"}, {"text-anchor", "middle"}});

  // Series.
  for (const Series& s : series) {
    std::vector<std::pair<double, double>> pts;
    for (const auto& [px, py] : s.points) {
      if (!std::isfinite(px) || !std::isfinite(py) || (x_log && px <= 0)) continue;
      pts.push_back({mapX(px), mapY(py)});
    }
    if (s.style == Style::Bars) {
      doc.beginGroup({{"class", "series bars"}, {"fill", s.color}});
      const double base = mapY(std::clamp(0.0, std::min(y0, y1), std::max(y0, y1)));
      for (const auto& [px, py] : s.points) {
        if (!std::isfinite(px) || !std::isfinite(py) || x_log) continue;
        const double l = mapX(px - 0.5 * s.bar_width), r = mapX(px + 0.5 * s.bar_width);
        const double top = std::min(mapY(py), base), bot = std::max(mapY(py), base);
        doc.rect(l, top, r - l, bot - top, {{"class", "bar"}});
      }
      doc.endGroup();
    } else if (s.style == Style::Markers) {
      doc.beginGroup({{"class", "series"}, {"fill", s.color}});
      for (const auto& [px, py] : pts) doc.circle(px, py, s.marker_radius);
      doc.endGroup();
    } else if (!pts.empty()) {
      svg::Attrs a{{"class", "series"}, {"stroke", s.color}, {"stroke-width", "1.8"}};
      if (s.style == Style::Dashed) a.push_back({"stroke-dasharray", "6 4"});
      doc.polyline(pts, a);
    }
  }
  // Legend (top right) and notes (top left).
  int row = 0;
  for (const Series& s : series) {
    if (s.name.empty()) continue;
    const double ly = oy + 14 + 15 * row++;
    const double lx = ox + pw - 190;
    if (s.style == Style::Markers)
      doc.circle(lx + 10, ly - 4, 3, {{"fill", s.color}});
    else if (s.style == Style::Bars)
      doc.rect(lx + 4, ly - 9, 12, 10, {{"fill", s.color}});
    else
      doc.line(lx, ly - 4, lx + 20, ly - 4,
               {{"stroke", s.color},
                {"stroke-width", "2"},
                {"stroke-dasharray", s.style == Style::Dashed ? "6 4" : "none"}});
    doc.text(lx + 26, ly, s.name, {{"font-size", "11"}});
  }
  for (size_t i = 0; i < notes.size(); ++i)
    doc.text(ox + 8, oy + 16 + 14 * static_cast<double>(i), notes[i], {{"font-size", "11"}});
  doc.endGroup();
}

}  // namespace lensim::plot
