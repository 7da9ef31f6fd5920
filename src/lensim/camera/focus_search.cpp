#include "lensim/camera/focus_search.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace lensim::camera {

std::vector<AfZone> parseAfZones(const std::string& text, const std::string& path) {
  std::vector<AfZone> zones;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#' || line[0] == ' ' || line[0] == '\t') continue;
    double v[4];
    size_t pos = 0;
    for (int k = 0; k < 4; ++k) {
      while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t')) ++pos;
      const size_t start = pos;
      while (pos < line.size() && line[pos] != ' ' && line[pos] != '\t') ++pos;
      const FileLoc loc{path, line_no, static_cast<int>(start) + 1};
      if (start == pos)
        throw Error(loc, fmt::format("expected 4 numbers (left right top bottom), found {}", k));
      std::string tok = line.substr(start, pos - start);
      const char* b = tok.data();
      if (*b == '+') ++b;
      auto [ptr, ec] = std::from_chars(b, tok.data() + tok.size(), v[k]);
      if (ec != std::errc() || ptr != tok.data() + tok.size() || !std::isfinite(v[k]))
        throw Error(loc, fmt::format("expected a number, found '{}'", tok));
      if (v[k] < 0 || v[k] > 1)
        throw Error(loc,
                    fmt::format("{} is outside [0, 1]: zones are fractions of the image", tok));
    }
    while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t')) ++pos;
    if (pos < line.size() && line[pos] != '#')
      throw Error(FileLoc{path, line_no, static_cast<int>(pos) + 1},
                  "expected 4 numbers (left right top bottom), found more");
    AfZone z{v[0], v[1], v[2], v[3], FileLoc{path, line_no, 1}};
    if (!(z.right > z.left) || !(z.bottom > z.top))
      throw Error(z.loc, "empty zone: expected left < right and top < bottom");
    zones.push_back(z);
  }
  if (zones.empty()) throw Error(FileLoc{path, std::max(1, line_no), 0}, "no zones in the file");
  return zones;
}

std::vector<AfZone> readAfZones(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(FileLoc{path}, "cannot open autofocus zone file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parseAfZones(ss.str(), path);
}

namespace {

// Laplacian energy of one scale after [1 2 1]/4 smoothing, relative to the squared mean.
double laplacianEnergy(const ZoneImage& img) {
  const int w = img.width, h = img.height;
  if (w < 5 || h < 5) return 0;
  auto at = [&](const std::vector<double>& v, int x, int y) {
    return v[static_cast<size_t>(std::clamp(y, 0, h - 1)) * w + std::clamp(x, 0, w - 1)];
  };
  std::vector<double> tmp(img.pixels.size()), s(img.pixels.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      tmp[static_cast<size_t>(y) * w + x] =
          0.25 * (at(img.pixels, x - 1, y) + 2 * at(img.pixels, x, y) + at(img.pixels, x + 1, y));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      s[static_cast<size_t>(y) * w + x] =
          0.25 * (at(tmp, x, y - 1) + 2 * at(tmp, x, y) + at(tmp, x, y + 1));
  double mean = 0;
  for (double p : s) mean += p;
  mean /= static_cast<double>(s.size());
  if (!(mean > 0)) return 0;
  double sum = 0;
  int n = 0;
  for (int y = 1; y < h - 1; ++y)
    for (int x = 1; x < w - 1; ++x) {
      const double lap =
          4 * at(s, x, y) - at(s, x - 1, y) - at(s, x + 1, y) - at(s, x, y - 1) - at(s, x, y + 1);
      sum += lap * lap;
      ++n;
    }
  return sum / n / (mean * mean);
}

ZoneImage halve(const ZoneImage& img) {
  ZoneImage out;
  out.width = img.width / 2;
  out.height = img.height / 2;
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      auto at = [&](int xx, int yy) {
        return img.pixels[static_cast<size_t>(yy) * img.width + xx];
      };
      out.pixels.push_back(0.25 * (at(2 * x, 2 * y) + at(2 * x + 1, 2 * y) + at(2 * x, 2 * y + 1) +
                                   at(2 * x + 1, 2 * y + 1)));
    }
  return out;
}

}  // namespace

double sharpness(const ZoneImage& img) {
  // Three scales: the finest pins the focus, the coarser ones still respond when the image is
  // far out of focus (and average the Monte Carlo noise away), so a coarse search finds the peak.
  double total = 0;
  ZoneImage level = img;
  for (int k = 0; k < 3 && level.width >= 5 && level.height >= 5; ++k) {
    total += laplacianEnergy(level);
    level = halve(level);
  }
  return total;
}

AutofocusResult autofocus(const std::function<double(double)>& score, const AutofocusOptions& o) {
  if (!(o.film_max_mm > o.film_min_mm) || !(o.film_min_mm >= 0))
    throw Error(fmt::format("autofocus: empty search range [{}, {}]", o.film_min_mm,
                            o.film_max_mm));
  AutofocusResult r;
  auto eval = [&](double s) {
    const double v = score(s);
    r.evaluated.push_back({s, v});
    return v;
  };
  int n = std::max(3, o.coarse_steps);
  if (o.max_step_mm > 0)
    n = std::max(n,
                 1 + static_cast<int>(std::ceil((o.film_max_mm - o.film_min_mm) / o.max_step_mm)));
  std::vector<double> xs(n), vs(n);
  int best = 0;
  for (int k = 0; k < n; ++k) {
    xs[k] = o.film_min_mm + (o.film_max_mm - o.film_min_mm) * k / (n - 1);
    vs[k] = eval(xs[k]);
    if (vs[k] > vs[best]) best = k;
  }
  // Golden-section search in the bracket around the best coarse sample.
  double a = xs[std::max(0, best - 1)], b = xs[std::min(n - 1, best + 1)];
  const double g = (std::sqrt(5.0) - 1) / 2;
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = eval(c), fd = eval(d);
  for (int it = 0; it < o.refine_steps; ++it) {
    if (fc > fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = eval(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = eval(d);
    }
  }
  // The best of everything evaluated (the refinement can only improve on the coarse scan).
  r.film_distance_mm = xs[best];
  r.score = vs[best];
  for (const auto& [x, v] : r.evaluated)
    if (v > r.score) r.film_distance_mm = x, r.score = v;
  return r;
}

}  // namespace lensim::camera
