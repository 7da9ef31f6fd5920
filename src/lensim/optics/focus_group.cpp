// Group focusing: an inner group moves to focus while the film stays put (focus.h).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <limits>

#include "lensim/optics/focus.h"

namespace lensim::optics {

namespace {

LensPrescription shifted(const LensPrescription& p, double x) {
  LensPrescription q = p;
  for (const auto& [row, rate] : p.focus_group) q.surfaces[size_t(row)].thickness_mm += rate * x;
  return q;
}

// The position x in [lo, hi] (rest: 0) at which the lens `at(x)` images an object
// `focus_distance_m` from the film onto the film that the rest position's infinity focus places,
// fixed relative to the front vertex: a search outward from 0 for a sign change, then bisection.
// `what` names the mechanism in messages; `beyond` follows the refusal of a distance no position
// reaches, located at `where`.
GroupFocus solveFocusPosition(const LensSetup& setup,
                              double focus_distance_m, double lo, double hi,
                              const std::function<LensPrescription(double)>& at,
                              const std::string& what, const FileLoc& where,
                              const std::string& beyond) {
  LensSystemOptions opts;
  opts.aperture_diameter_mm = setup.aperture_diameter_mm;
  auto film = [&](double x, double distance_m) {
    LensSystem lens(at(x), opts);
    const ParaxialData para = computeParaxial(lens);
    return std::pair{lens.rearVertexZ_mm(),
                     filmDistanceForFocus(lens, para, distance_m, setup.focus_method)};
  };
  // The film plane (from the front vertex) of the infinity focus at rest.
  const auto [rear0, film0] = film(0, std::numeric_limits<double>::infinity());
  const double track = rear0 + film0;
  // g(x): how far behind the fixed film the lens at x focuses the object.
  auto g = [&](double x) {
    try {
      const auto [rear, f] = film(x, focus_distance_m);
      return rear + f - track;
    } catch (const Error&) {
      return std::numeric_limits<double>::quiet_NaN();
    }
  };
  const double g0 = g(0);
  if (g0 == 0) return {at(0), 0, film0};
  double a = 0, ga = g0, b = 0, gb = g0;
  bool found = false;
  const double span = std::min(hi - lo, 1e4);
  for (int k = 1; k <= 200 && !found; ++k) {
    for (double dir : {1.0, -1.0}) {
      const double x = std::clamp(dir * span * k / 200, lo, hi);
      const double gx = g(x);
      if (std::isfinite(gx) && std::isfinite(g0) && (gx < 0) != (g0 < 0)) {
        b = x, gb = gx, found = true;
        break;
      }
    }
  }
  if (!found || !std::isfinite(g0))
    throw Error(where, fmt::format("{}: no position between {:.6g} and {:.6g} focuses {} m{}",
                                   what, lo, hi, focus_distance_m, beyond));
  for (int it = 0; it < 100 && std::abs(b - a) > 1e-12 * (1 + std::abs(b)); ++it) {
    const double m = 0.5 * (a + b);
    const double gm = g(m);
    if (!std::isfinite(gm)) break;
    if ((gm < 0) == (ga < 0))
      a = m, ga = gm;
    else
      b = m, gb = gm;
  }
  const double x = std::abs(ga) < std::abs(gb) ? a : b;
  GroupFocus out;
  out.prescription = at(x);
  out.shift_mm = x;
  LensSystem lens(out.prescription, opts);
  out.film_distance_mm = track - lens.rearVertexZ_mm();
  return out;
}

}  // namespace

GroupFocus focusByGroup(const LensPrescription& p, const LensSetup& setup,
                        double focus_distance_m) {
  const int rows = int(p.surfaces.size());
  const FileLoc where{p.path};
  // The range of x over which every moved thickness stays >= 0.
  double lo = -std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& [row, rate] : p.focus_group) {
    if (row < 0 || row + 1 >= rows)
      throw Error(where, fmt::format("focus group: surface {} is not a gap between two surfaces "
                                     "(0 to {})",
                                     row, rows - 2));
    if (!(rate != 0) || !std::isfinite(rate))
      throw Error(where, fmt::format("focus group: surface {}: rate {} must be finite and non-zero",
                                     row, rate));
    const double t = p.surfaces[size_t(row)].thickness_mm;
    (rate > 0 ? lo : hi) = rate > 0 ? std::max(lo, -t / rate) : std::min(hi, -t / rate);
  }
  if (!(lo < hi)) throw Error(where, "focus group: the moved gaps leave no room to move");
  return solveFocusPosition(
      setup, focus_distance_m, lo, hi, [&](double x) { return shifted(p, x); },
      "focus group (travel in mm)", where, "");
}

LensPrescription atFloatingFocus(const LensPrescription& p, double u) {
  const LensPrescription::FloatingFocus& f = *p.floating_focus;
  const std::vector<double>& v = f.vergence_dpt;
  if (!(u >= v.front() && u <= v.back()))
    throw Error(f.loc, fmt::format("floating focus: parameter {} dioptres is outside the file's "
                                   "focus positions ({} to {})",
                                   u, v.front(), v.back()));
  size_t k = 0;
  while (k + 2 < v.size() && u > v[k + 1]) ++k;
  const double s = (u - v[k]) / (v[k + 1] - v[k]);
  LensPrescription q = p;
  for (size_t i = 0; i < f.rows.size(); ++i)
    q.surfaces[size_t(f.rows[i])].thickness_mm =
        (1 - s) * f.thickness_mm[k][i] + s * f.thickness_mm[k + 1][i];
  return q;
}

GroupFocus focusByFloatingFocus(const LensPrescription& p, const LensSetup& setup,
                                double focus_distance_m) {
  const LensPrescription::FloatingFocus& f = *p.floating_focus;
  return solveFocusPosition(
      setup, focus_distance_m, f.vergence_dpt.front(), f.vergence_dpt.back(),
      [&](double u) { return atFloatingFocus(p, u); },
      "floating focus (object vergence parameter in dioptres)", f.loc,
      fmt::format("; the file's focus positions span object distances from infinity to {:.6g} mm "
                  "before the front vertex, and lensim does not extrapolate beyond them",
                  1000 / f.vergence_dpt.back()));
}

}  // namespace lensim::optics
