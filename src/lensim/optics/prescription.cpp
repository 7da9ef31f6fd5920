#include "lensim/optics/prescription.h"

#include "lensim/optics/lens_formats.h"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "lensim/optics/glass.h"
#include "lensim/util/file.h"
#include "lensim/util/text.h"

namespace lensim::optics {

const char* layoutName(LensFileLayout layout) {
  switch (layout) {
    case LensFileLayout::Pbrt:
      return "pbrt";
    case LensFileLayout::Iset:
      return "iset";
    case LensFileLayout::Axpos:
      return "axpos";
  }
  return "pbrt";
}

std::optional<int> LensPrescription::stopIndex() const {
  for (size_t i = 0; i < surfaces.size(); ++i)
    if (surfaces[i].isStop()) return static_cast<int>(i);
  return std::nullopt;
}

double LensSurface::apertureReach_mm() const {
  const double dx = aperture_decentre_mm[0], dy = aperture_decentre_mm[1];
  if (aperture_shape == ApertureShape::Rectangle)
    return std::hypot(aperture_half_x_mm + std::abs(dx), aperture_half_y_mm + std::abs(dy));
  const double off = std::hypot(dx, dy);
  if (aperture_shape == ApertureShape::Ellipse && off > 0)
    return off + std::max(aperture_half_x_mm, aperture_half_y_mm);
  return off + semiAperture_mm();
}

std::optional<std::array<double, 2>> apertureOutsideSag(const LensSurface& s) {
  const double dx = s.aperture_decentre_mm[0], dy = s.aperture_decentre_mm[1];
  if (s.shape.isRotational()) {
    const double reach = s.apertureReach_mm();
    if (reach < sagDomainRadius(s.radius_mm, s.shape)) return std::nullopt;
    const double off = std::hypot(dx, dy);  // the farthest point, along the decentre
    const double ux = off > 0 ? dx / off : 0.0, uy = off > 0 ? dy / off : 1.0;
    return std::array<double, 2>{ux * reach, uy * reach};
  }
  // The outline, a hair outside (the rim must be inside the domain, not on it).
  const double grow = 1 + 1e-9;
  const bool rect = s.aperture_shape == ApertureShape::Rectangle;
  const double hx = s.aperture_shape == ApertureShape::Circle ? s.semiAperture_mm()
                                                               : s.aperture_half_x_mm;
  const double hy = s.aperture_shape == ApertureShape::Circle ? s.semiAperture_mm()
                                                               : s.aperture_half_y_mm;
  auto bad = [&](double u, double v) -> std::optional<std::array<double, 2>> {
    const double x = dx + grow * u, y = dy + grow * v;
    if (surfaceSag(s.radius_mm, s.shape, x, y)) return std::nullopt;
    return std::array<double, 2>{x, y};
  };
  constexpr int kPoints = 4096;
  for (int i = 0; i < kPoints; ++i) {
    double u, v;
    if (rect) {  // the perimeter, corners and edge midpoints among the points
      const double a = 4.0 * i / kPoints, f = 2 * (a - std::floor(a)) - 1;
      const int side = int(a);
      u = side == 0 ? hx : side == 2 ? -hx : (side == 1 ? -f : f) * hx;
      v = side == 1 ? hy : side == 3 ? -hy : (side == 0 ? f : -f) * hy;
    } else {  // the axes' ends among the points
      const double phi = 2 * std::numbers::pi * i / kPoints;
      u = hx * std::cos(phi), v = hy * std::sin(phi);
    }
    if (auto p = bad(u, v)) return p;
  }
  if (rect)
    for (double u : {-hx, hx})
      for (double v : {-hy, hy})
        if (auto p = bad(u, v)) return p;
  return std::nullopt;
}

double sphericalSag(double radius_mm, double h_mm) {
  if (radius_mm == 0) return 0;
  double r = std::abs(radius_mm);
  double s = r - std::sqrt(std::max(0.0, r * r - h_mm * h_mm));
  return radius_mm > 0 ? s : -s;
}

namespace {

struct Token {
  std::string_view text;
  int column;  // 1-based
};

const char* kColumnNames[4] = {"radius", "thickness", "index of refraction", "aperture diameter"};

std::vector<Token> splitColumns(std::string_view line) {
  std::vector<Token> tokens;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i >= line.size()) break;
    size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    tokens.push_back({line.substr(start, i - start), static_cast<int>(start) + 1});
  }
  return tokens;
}

double parseNumber(const Token& tok, const FileLoc& loc, const char* what) {
  double value = 0;
  const char* first = tok.text.data();
  const char* last = first + tok.text.size();
  if (!tok.text.empty() && *first == '+') ++first;  // from_chars rejects a leading '+'
  auto [ptr, ec] = std::from_chars(first, last, value);
  if (ec == std::errc::result_out_of_range)
    throw Error(loc, fmt::format("{} '{}' is out of range", what, tok.text));
  if (ec != std::errc() || ptr != last)
    throw Error(loc, fmt::format("expected a number for the {}, found '{}'", what, tok.text));
  if (!std::isfinite(value))
    throw Error(loc, fmt::format("the {} must be a finite number, found '{}'", what, tok.text));
  return value;
}

std::string stemOf(const std::string& path) {
  std::string stem = std::filesystem::path(path).filename().string();
  if (auto dot = stem.rfind(".dat"); dot != std::string::npos && dot + 4 == stem.size())
    stem.resize(dot);
  return stem;
}

std::string trim(std::string_view s) {
  size_t b = s.find_first_not_of(" \t\"");
  if (b == std::string_view::npos) return {};
  size_t e = s.find_last_not_of(" \t\"");
  return std::string(s.substr(b, e - b + 1));
}

// Warns about neighbouring surfaces whose profiles cross inside both clear apertures: the glass
// (or air gap) between them would have negative thickness there.
void checkCrossings(LensPrescription& p) {
  double z = 0;
  for (size_t i = 0; i + 1 < p.surfaces.size(); ++i) {
    const LensSurface& a = p.surfaces[i];
    const LensSurface& b = p.surfaces[i + 1];
    double zb = z + a.thickness_mm;
    double hmax = std::min(a.semiAperture_mm(), b.semiAperture_mm());
    constexpr int kSteps = 256;
    double first_h = -1, worst = 0, worst_h = 0;
    for (int k = 0; k <= kSteps; ++k) {
      const double h = hmax * k / kSteps;
      const double gap = zb + sphericalSag(b.radius_mm, h) - (z + sphericalSag(a.radius_mm, h));
      if (gap < -1e-9) {
        if (first_h < 0) first_h = h;
        if (gap < worst) worst = gap, worst_h = h;
      }
    }
    if (first_h >= 0)
      p.diagnostics.push_back(
          {Severity::Warning, b.loc,
           fmt::format("this surface crosses the previous one ({}) inside both apertures, from "
                       "height {:.3f} mm outward: the {} between them reaches {:.3f} mm "
                       "thickness at height {:.3f} mm",
                       a.loc.str(), first_h, a.ior > 1 ? "glass" : "air gap", worst, worst_h)});
    z = zb;
  }
}

}  // namespace

LensPrescription parseLensPrescription(std::string_view text, const std::string& path) {
  LensPrescription p;
  p.path = path;
  std::optional<std::string> firstComment;
  std::optional<int> stopLine;
  int lineNo = 0;
  int lastLine = 1;
  size_t pos = 0;
  while (pos <= text.size()) {
    // Next line, accepting LF, CRLF and lone CR.
    size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    ++lineNo;
    if (end < text.size() && text[end] == '\r' && end + 1 < text.size() && text[end + 1] == '\n')
      pos = end + 2;
    else
      pos = end + 1;
    if (end == text.size() && line.empty()) break;
    lastLine = lineNo;

    // Comments: whole lines or trailing.
    if (size_t hash = line.find('#'); hash != std::string_view::npos) {
      std::string comment = trim(line.substr(hash + 1));
      if (!firstComment && !comment.empty() && line.find_first_not_of(" \t") == hash)
        firstComment = comment;
      line = line.substr(0, hash);
    }
    std::vector<Token> cols = splitColumns(line);
    if (cols.empty()) continue;

    FileLoc loc{path, lineNo, cols[0].column};
    if (cols.size() == 1 && p.surfaces.empty() && !p.nominal_focal_length_mm) {
      // ISET layout: the focal length on a line of its own before the surface rows.
      double f = parseNumber(cols[0], loc, "focal length");
      p.nominal_focal_length_mm = f;
      p.layout = LensFileLayout::Iset;
      continue;
    }
    if (p.surfaces.size() >= kMaxLensSurfaces)
      throw Error(loc,
                  fmt::format("too many surfaces: at most {} rows are read", kMaxLensSurfaces));
    if (cols.size() < 4 || cols.size() > 6)
      throw Error(loc, fmt::format("expected 4 numbers (radius, thickness, index of refraction, "
                                   "aperture diameter), optionally followed by the Abbe number "
                                   "V_d and a glass name, found {} columns",
                                   cols.size()));

    double v[4];
    for (int c = 0; c < 4; ++c)
      v[c] = parseNumber(cols[c], FileLoc{path, lineNo, cols[c].column}, kColumnNames[c]);
    LensSurface s;
    s.radius_mm = v[0];
    s.thickness_mm = v[1];
    s.ior = v[2] == 0 ? 1.0 : v[2];
    s.aperture_diameter_mm = v[3];
    s.loc = loc;

    auto at = [&](int c) { return FileLoc{path, lineNo, cols[c].column}; };
    if (v[1] < 0)
      throw Error(at(1),
                  fmt::format("thickness {} mm is negative; expected a distance >= 0", v[1]));
    if (v[2] < 0 || (v[2] > 0 && v[2] < 1))
      throw Error(at(2), fmt::format("index of refraction {} is not physical; expected 0 (air) "
                                     "or a value >= 1",
                                     v[2]));
    if (v[3] <= 0) throw Error(at(3), fmt::format("aperture diameter {} mm must be > 0", v[3]));
    if (s.radius_mm != 0 && s.semiAperture_mm() > std::abs(s.radius_mm))
      throw Error(at(3),
                  fmt::format("semi-aperture {} mm is larger than the radius of curvature |{}| mm: "
                              "a spherical surface cannot be that wide",
                              s.semiAperture_mm(), s.radius_mm));
    if (s.isStop()) {
      if (stopLine)
        throw Error(at(0), fmt::format("second aperture stop (radius 0); the first is at {}:{}",
                                       path, *stopLine));
      stopLine = lineNo;
    }
    // Optional columns 5 (Abbe number V_d, '-' for none) and 6 (catalogue glass name): the
    // medium after the surface disperses (optics/glass.h resolves them).
    if (cols.size() >= 5) {
      if (v[2] == 0 || v[2] == 1)
        throw Error(at(4), fmt::format("'{}': air (index {}) takes no Abbe number or glass",
                                       cols[4].text, v[2]));
      s.glass.n_d = s.ior;
      s.glass.loc = at(4);
      if (cols[4].text != "-") {
        const double vd = parseNumber(cols[4], at(4), "Abbe number V_d");
        if (!(vd > 0))
          throw Error(at(4), fmt::format("Abbe number V_d {} must be > 0 (or '-' for none)", vd));
        s.glass.v_d = vd;
      }
      if (cols.size() == 6) {
        s.glass.name = std::string(cols[5].text);
        s.glass.loc = at(5);
      }
      resolveGlass(s.glass, s.ior);  // an unknown name is an error here, at its column
    }
    p.surfaces.push_back(s);
  }

  if (p.surfaces.empty())
    throw Error(FileLoc{path, lastLine, 0},
                "no surface rows: a lens file needs rows of 'radius thickness index aperture' "
                "(millimetres)");

  // The older axpos layout: column 2 is the distance from the previous surface.
  if (p.surfaces.size() > 1 && p.surfaces[0].thickness_mm == 0 && !p.surfaces[0].isStop()) {
    p.layout = LensFileLayout::Axpos;
    for (size_t i = 0; i + 1 < p.surfaces.size(); ++i)
      p.surfaces[i].thickness_mm = p.surfaces[i + 1].thickness_mm;
    p.surfaces.back().thickness_mm = 0;
    p.diagnostics.push_back({Severity::Note, p.surfaces[0].loc,
                             "the first row has thickness 0: read in the 'axpos' layout (column 2 "
                             "is the distance from the previous surface)"});
  }

  p.name = firstComment ? *firstComment : stemOf(path);
  if (p.name.rfind("Name:", 0) == 0) p.name = trim(p.name.substr(5));
  // The name goes into SVG, JSON and messages: printable, valid UTF-8, not too long.
  p.name = shortToken(p.name, 200);
  checkCrossings(p);
  return p;
}

LensPrescription readLensFile(const std::string& spec) {
  // Names from the catalogue (lentil:KEY, lenses:NAME) and the format by extension:
  // .zmx Zemax, .json lensim / ISET3d / lentil, anything else the .dat table.
  const LensRef ref = resolveLensName(spec);
  const std::string& path = ref.path;
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  // Only regular files of a sane size: a FIFO would block, /dev/zero never ends.
  const std::string text = readRegularFile(path, "lens file", kMaxLensFileBytes);
  if (!ref.lentil_key.empty() || ext == ".json") return parseLensJson(text, path, ref.lentil_key);
  if (ext == ".zmx") return parseZmx(text, path);
  return parseLensPrescription(text, path);
}

}  // namespace lensim::optics
