// Zemax focus positions: configurations that differ only in the object distance and in lens gaps
// that move in fixed ratios are one focus group (LensPrescription::focus_group); gaps moving at
// different rates are floating focus (LensPrescription::floating_focus). focusLens (focus.h)
// positions either for a focus distance (docs/zoom.md, "Focus positions in Zemax files",
// "Floating focus").
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "lensim/optics/zmx_parser.h"

namespace lensim::optics::zmx_detail {

FileLoc ZmxParser::mcThicknessLoc(int surf_line, int config) const {
  for (size_t k = 0; k < surfs.size(); ++k) {
    if (surfs[k].loc.line != surf_line) continue;
    for (const McRow& r : mc_rows_)
      if (r.op == "THIC" && r.arg == int(k) && r.config == config) return r.value_loc;
  }
  return mc_loc_;
}

namespace {

// How far gaps may miss the rules (the lens's length, the ratio of the moves): a table's rounding
// to 4 decimals of a millimetre.
constexpr double kTolerance_mm = 1e-4;

std::string distanceText(const std::optional<double>& d_mm) {
  return d_mm ? fmt::format("{:.6g} mm", *d_mm) : std::string("infinity");
}

// Every operand other than THIC must have one value in all configurations: a focus position
// moves gaps only.
void checkOnlyThicknessesChange(const ZmxParser& base) {
  std::map<std::pair<std::string, int>, const ZmxParser::McRow*> first;
  for (const ZmxParser::McRow& r : base.mcRows()) {
    // Fields describe the object (heights at each distance), not the lens.
    if (r.op == "THIC" || r.op == "XFIE" || r.op == "YFIE") continue;
    auto [it, fresh] = first.try_emplace({r.op, r.arg}, &r);
    if (fresh) continue;
    const ZmxParser::McRow& a = *it->second;
    const bool same = r.op == "GLSS" ? r.value == a.value
                                     : std::strtod(r.value.c_str(), nullptr) ==
                                           std::strtod(a.value.c_str(), nullptr);
    if (!same)
      throw Error(r.value_loc,
                  fmt::format("{} {}: configuration {} has {} where configuration {} has {}; the "
                              "configurations also differ in the object distance (THIC 0), so "
                              "they are read as focus positions, which may change lens gaps "
                              "(THIC) only (zoom and focus positions in one file are not "
                              "supported)",
                              r.op, r.arg, r.config, r.value, a.config, a.value));
  }
}

// Floating focus: the moved gaps at each focus position, by the object vergence 1000 / d (d from
// the front vertex; 0 at infinity), over the infinity configuration `rest`.
void readFloatingFocus(const ZmxParser& base, LensPrescription& p, size_t rest,
                       const std::vector<size_t>& moved) {
  const auto& cfgs = p.configurations;
  std::vector<std::pair<double, size_t>> order;
  for (size_t k = 0; k < cfgs.size(); ++k) {
    const std::optional<double>& d = cfgs[k].object_distance_mm;
    if (d && !(*d > 0)) {
      FileLoc at = base.mcLoc();
      for (const ZmxParser::McRow& r : base.mcRows())
        if (r.op == "THIC" && r.arg == 0 && r.config == int(k + 1)) at = r.value_loc;
      throw Error(at, fmt::format("configuration {}: object distance {} mm; focus positions need "
                                  "an object in front of the lens (> 0)",
                                  k + 1, *d));
    }
    order.emplace_back(d ? 1000 / *d : 0.0, k);
  }
  std::sort(order.begin(), order.end());
  LensPrescription::FloatingFocus f;
  f.loc = base.mcLoc();
  for (size_t r : moved) f.rows.push_back(int(r));
  std::string positions;
  for (const auto& [u, k] : order) {
    if (!f.vergence_dpt.empty() && f.vergence_dpt.back() == u) continue;  // same gaps (checked)
    f.vergence_dpt.push_back(u);
    std::vector<double> t;
    for (size_t r : moved) t.push_back(cfgs[k].surfaces[r].thickness_mm);
    positions += fmt::format("{}{}", positions.empty() ? "" : ", ",
                             distanceText(cfgs[k].object_distance_mm));
    f.thickness_mm.push_back(std::move(t));
  }
  std::string rows;
  for (size_t r : moved) rows += fmt::format("{}{}", rows.empty() ? "" : ", ", r);
  LensConfiguration at_rest = cfgs[rest];
  p.surfaces = std::move(at_rest.surfaces);
  if (!at_rest.aperture_spec.empty()) p.aperture_spec = at_rest.aperture_spec;
  p.fields = at_rest.fields;
  p.object_distance_mm.reset();
  p.diagnostics.push_back(
      {Severity::Note, base.mcLoc(),
       fmt::format("the {} configurations differ in the object distance and in lens gaps that "
                   "move at different rates: read as floating focus over configuration {} "
                   "(object at infinity); the gaps of surfaces {} are piecewise linear in the "
                   "object vergence 1/d between the file's positions ({}), and focusing "
                   "closer than the last is refused",
                   cfgs.size(), rest + 1, rows, positions)});
  p.floating_focus = std::move(f);
  p.configurations.clear();
  p.active_configuration = 1;
}

}  // namespace

void readFocusPositions(const ZmxParser& base, LensPrescription& p) {
  const auto& cfgs = p.configurations;
  // Tilted or decentred surfaces sit where their frames put them, not at the thicknesses a focus
  // group changes: such a file keeps its configurations.
  if (cfgs.size() < 2 || p.noncoaxial_loc) return;
  const size_t n = cfgs.size(), rows = cfgs[0].surfaces.size();
  bool distances_differ = false;
  for (const LensConfiguration& c : cfgs)
    distances_differ = distances_differ || c.object_distance_mm != cfgs[0].object_distance_mm;
  if (!distances_differ) return;  // zoom positions (or one lens at one distance)
  std::vector<size_t> moved;
  for (size_t r = 0; r < rows; ++r)
    for (const LensConfiguration& c : cfgs)
      if (c.surfaces[r].thickness_mm != cfgs[0].surfaces[r].thickness_mm) {
        moved.push_back(r);
        break;
      }
  // The same lens at several object distances (unit focusing): kept as configurations.
  if (moved.empty()) return;

  checkOnlyThicknessesChange(base);
  auto thicLoc = [&](size_t row, size_t config) {
    return base.mcThicknessLoc(cfgs[config].surfaces[row].loc.line, int(config + 1));
  };
  FileLoc thic0_loc = base.mcLoc();
  for (const ZmxParser::McRow& r : base.mcRows())
    if (r.op == "THIC" && r.arg == 0) {
      thic0_loc = r.value_loc;
      break;
    }
  if (moved.back() + 1 == rows) {
    size_t k = 1;
    while (cfgs[k].surfaces[rows - 1].thickness_mm == cfgs[0].surfaces[rows - 1].thickness_mm) ++k;
    throw Error(thicLoc(rows - 1, k),
                "the configurations differ in the object distance and in the image distance (the "
                "last thickness): a focus that moves the film is not read as a focus group, "
                "whose film stays fixed");
  }
  size_t rest = n;
  for (size_t k = 0; k < n && rest == n; ++k)
    if (!cfgs[k].object_distance_mm) rest = k;
  if (rest == n)
    throw Error(thic0_loc,
                "focus positions (configurations that differ in the object distance "
                "and in lens gaps) need one with the object at infinity (THIC 0 of "
                "1e10 or more): lensim places the film by it");

  // Each configuration's gap changes from the infinity configuration.
  std::vector<std::vector<double>> delta(n, std::vector<double>(moved.size()));
  size_t far = rest;
  double far_norm = 0;
  for (size_t k = 0; k < n; ++k) {
    double norm = 0, length = 0;
    for (size_t i = 0; i < moved.size(); ++i) {
      const double d =
          cfgs[k].surfaces[moved[i]].thickness_mm - cfgs[rest].surfaces[moved[i]].thickness_mm;
      delta[k][i] = d;
      norm += d * d;
      length += d;
    }
    if (std::abs(length) > kTolerance_mm)
      throw Error(thicLoc(moved[0], k),
                  fmt::format("configuration {} changes the lens's length by {:.6g} mm against "
                              "the infinity configuration {}: lensim reads focus positions as a "
                              "group moving inside a lens whose front vertex stays fixed to the "
                              "film (the moved gaps must sum to the same length)",
                              k + 1, length, rest + 1));
    if (norm > far_norm) far = k, far_norm = norm;
  }
  // Configurations at one object distance must agree on the gaps.
  for (size_t k = 0; k < n; ++k)
    for (size_t j = 0; j < k; ++j) {
      if (cfgs[k].object_distance_mm != cfgs[j].object_distance_mm) continue;
      for (size_t i = 0; i < moved.size(); ++i)
        if (std::abs(delta[k][i] - delta[j][i]) > kTolerance_mm)
          throw Error(thicLoc(moved[0], k),
                      fmt::format("configurations {} and {} have the same object distance ({}) "
                                  "and different gaps: which is the focus position is ambiguous",
                                  j + 1, k + 1, distanceText(cfgs[k].object_distance_mm)));
    }
  // One group when every configuration's change is a multiple of the largest one; else floating
  // focus (groups moving at different rates).
  const std::vector<double>& v = delta[far];
  std::vector<double> position(n);
  bool one_group = true;
  for (size_t k = 0; k < n; ++k) {
    double dot = 0;
    for (size_t i = 0; i < moved.size(); ++i) dot += delta[k][i] * v[i];
    position[k] = dot / far_norm;
    for (size_t i = 0; i < moved.size(); ++i)
      one_group = one_group && std::abs(delta[k][i] - position[k] * v[i]) <= kTolerance_mm;
  }
  if (!one_group) {
    readFloatingFocus(base, p, rest, moved);
    return;
  }

  // Rates: the largest is 1 in size, the first moved gap's positive; x is then that gap's change.
  size_t big = 0;
  for (size_t i = 0; i < v.size(); ++i)
    if (std::abs(v[i]) > std::abs(v[big])) big = i;
  const double unit = std::abs(v[big]) * (v[0] < 0 ? -1 : 1);
  std::vector<std::pair<int, double>> group;
  std::string rates, positions;
  for (size_t i = 0; i < moved.size(); ++i) {
    group.emplace_back(int(moved[i]), v[i] / unit);
    rates += fmt::format("{}surface {} {:+.6g}", i ? ", " : "", moved[i], v[i] / unit);
  }
  for (size_t k = 0; k < n; ++k)
    positions += fmt::format("{}{}: {:.6g} mm", k ? ", " : "",
                             distanceText(cfgs[k].object_distance_mm), position[k] * unit);

  LensConfiguration at_rest = cfgs[rest];
  p.surfaces = std::move(at_rest.surfaces);
  if (!at_rest.aperture_spec.empty()) p.aperture_spec = at_rest.aperture_spec;
  p.fields = at_rest.fields;
  p.object_distance_mm.reset();
  p.focus_group = std::move(group);
  p.diagnostics.push_back(
      {Severity::Note, base.mcLoc(),
       fmt::format("the {} configurations differ in the object distance and lens gaps only: "
                   "read as the focus positions of one focus group over configuration {} (object "
                   "at infinity), thickness rates {}; the file's group positions (object distance "
                   "from the front "
                   "vertex: travel) {}",
                   n, rest + 1, rates, positions)});
  p.configurations.clear();
  p.active_configuration = 1;
}

}  // namespace lensim::optics::zmx_detail
