// The exit-pupil bound of an anamorphic lens (ExitPupilOptions::rotational false): the reach of
// each wedge edge and wedge on a film rectangle, stage 4 of the build (each wedge's blended
// polygon checked against the true region at the wedge's middle azimuth), and the blended
// polygon the sampler uses.
#include <algorithm>
#include <cmath>

#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

// Each wedge edge's nodes are the same film radii as over the whole film radius, up to the first
// at or past the rectangle's farthest point at the azimuths of the edge's two wedges; each
// wedge's checks reach the first past its own farthest point. A film point lies within both
// edges' reach.
void filmRectangleReach(const Context& ctx, int n_wedges, std::vector<int>& sector_nodes,
                        std::vector<double>& wedge_reach) {
  const Vec2 e = ctx.opts.film_half_extent_mm;
  const double film_radius_mm = ctx.film_radius, wedge = ctx.wedge;
  const int ni = ctx.ni;
  // The rectangle's farthest point at azimuths [lo, hi] (its distance grows up to the corner's
  // azimuth and falls after it).
  auto farthest = [&](double lo, double hi) {
    const double a = std::clamp(std::atan2(e.y, e.x), lo, hi);
    const double c = std::cos(a), s = std::sin(a);
    return std::min({film_radius_mm, c > 0 ? e.x / c : kInf, s > 0 ? e.y / s : kInf});
  };
  for (int sec = 0; sec < n_wedges + 1; ++sec) {
    const double r = farthest(std::max(0, sec - 1) * wedge, std::min(n_wedges, sec + 1) * wedge);
    sector_nodes[size_t(sec)] = std::clamp(int(std::ceil(r / film_radius_mm * ni - 1e-9)), 1, ni);
  }
  for (int wdg = 0; wdg < n_wedges; ++wdg)
    wedge_reach[size_t(wdg)] = farthest(wdg * wedge, (wdg + 1) * wedge);
}

// Both edges' nodes and interval middles, up to the first at or past the wedge's reach, none
// closer than a quarter of the narrowest interval to the one before.
std::vector<double> wedgeRadii(const Context& ctx, const std::vector<Sector>& lines, int wdg,
                               double reach) {
  std::vector<double> rs;
  for (int l : {wdg, wdg + 1})
    for (const Interval& iv : lines[size_t(l)].intervals)
      rs.insert(rs.end(), {iv.r0, 0.5 * (iv.r0 + iv.r1), iv.r1});
  std::sort(rs.begin(), rs.end());
  std::vector<double> kept;
  for (double r : rs) {
    if (!kept.empty() && kept.back() >= reach) break;
    if (kept.empty() || r - kept.back() > 0.25 * ctx.min_width) kept.push_back(r);
  }
  return kept;
}

// The factors that widen the wedge's blended polygon (unwidened while checking) to hold the
// boundary points found at its middle azimuth, with the safety margin. (Checking at a quarter and
// three quarters across as well found nothing more in lentil:2004 at twice the traces.)
WedgeCheck checkWedge(Probe& probe, const std::vector<Sector>& lines, int wdg,
                      const std::vector<double>& radii, int k0, int k1) {
  const Context& ctx = probe.ctx;
  const int nd = ctx.nd;
  constexpr double kWedgeChecks[] = {0.5};
  WedgeCheck wc;
  std::vector<double> R(static_cast<size_t>(nd));
  for (int k = k0; k < k1; ++k) {
    const double h = radii[size_t(k)];
    Polygon poly;
    poly.r = h;
    std::vector<double> f(size_t(nd), 1.0);
    for (double sw : kWedgeChecks) {
      if (!blendedPolygon(lines, nullptr, nd, ctx.film_radius, wdg, h, sw, poly.centre, R.data()))
        continue;
      probe.setAzimuth((wdg + sw) * ctx.wedge);
      poly.empty = false;
      poly.radius = R;
      // At a quarter and three quarters of the way between the polygon's directions: one search
      // for a point inside the region (not one per set of directions).
      const std::vector<double> g =
          coverFactors(ctx, poly, probe.boundaryPoints(h, 2 * nd, 0.25 * ctx.dphi, nullptr, &poly));
      for (int j = 0; j < nd; ++j) f[size_t(j)] = std::max(f[size_t(j)], g[size_t(j)]);
    }
    for (double& v : f)
      if (v > 1) v *= 1 + ctx.opts.margin;
    wc.r.push_back(h);
    wc.f.push_back(std::move(f));
  }
  return wc;
}

bool blendedPolygon(const std::vector<Sector>& lines, const WedgeCheck* wc, int nd,
                    double film_radius_mm, int wedge, double r, double s, Vec2& c, double* R) {
  if (r > film_radius_mm * (1 + 1e-9)) return false;
  // Beyond an edge's reach (a film rectangle's, ExitPupilOptions::film_half_extent_mm): no bound.
  for (int l : {wedge, wedge + 1}) {
    const std::vector<Interval>& ivs = lines[size_t(l)].intervals;
    if (!ivs.empty() && r > ivs.back().r1 * (1 + 1e-9)) return false;
  }
  auto lineAt = [&](const Sector& L, Vec2& cc, double* RR) {
    if (L.intervals.empty()) return false;
    const Interval& iv = L.intervals[size_t(intervalIn(L.intervals, L.lut, L.lut_scale, r))];
    if (iv.empty) return false;
    const double t = iv.r1 > iv.r0 ? std::clamp((r - iv.r0) / (iv.r1 - iv.r0), 0.0, 1.0) : 0.0;
    cc = iv.c0 * (1 - t) + iv.c1 * t;
    for (int j = 0; j < nd; ++j) RR[j] = iv.A[size_t(j)] * (1 - t) + iv.B[size_t(j)] * t;
    return true;
  };
  thread_local std::vector<double> other;
  other.resize(size_t(nd));
  Vec2 cb;
  const bool a = lineAt(lines[size_t(wedge)], c, R);
  const bool b = lineAt(lines[size_t(wedge) + 1], cb, other.data());
  if (!a && !b) return false;
  if (a && b) {
    c = c * (1 - s) + cb * s;
    for (int j = 0; j < nd; ++j) R[j] = R[j] * (1 - s) + other[size_t(j)] * s;
  } else if (b) {  // one edge's region is empty at r (beyond its image circle): the other's
    c = cb;
    std::copy(other.begin(), other.end(), R);
  }
  if (wc && !wc->r.empty()) {
    // The checks at the film radii around r; beyond the last, the last's.
    const size_t m = size_t(std::upper_bound(wc->r.begin(), wc->r.end(), r) - wc->r.begin());
    const std::vector<double>& f0 = wc->f[m > 0 ? m - 1 : 0];
    const std::vector<double>& f1 = wc->f[std::min(m, wc->r.size() - 1)];
    for (int j = 0; j < nd; ++j) R[j] *= std::max(f0[size_t(j)], f1[size_t(j)]);
  }
  return true;
}

}  // namespace lensim::optics::pupil
