// Stage 3 of the exit-pupil build: one wedge edge's sampling tables (the intervals' scaled vertex
// distances and fan prefix sums), a catadioptric lens's holes and the table from film radius to
// interval; and the interval lookup the sampler uses.
#include <algorithm>

#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

namespace {

// With central obscurations: whether the ray from the film point at height h toward rear-plane
// point a gets through, at any wavelength covered.
bool passesAll(Probe& probe, double h, Vec2 a) {
  ++probe.traces;
  if (probe.ctx.lens.traceFromFilmPoint({h, 0}, a).ok()) return true;
  for (const LensSystem* other : probe.ctx.opts.also_cover) {
    ++probe.traces;
    if (other->traceFromFilmPoint({h, 0}, a).ok()) return true;
  }
  return false;
}

// Along each direction of the polygon (centre c, vertex distances R): the distance from the
// centre to the first passing point (the edge of the blocked middle), a 16th of the vertex
// distance at a time, then bisected to a 1024th. All zero where the centre itself passes (no
// blocked middle there).
std::vector<double> holeDistances(Probe& probe, double h, Vec2 c, const std::vector<double>& R) {
  const Context& ctx = probe.ctx;
  const int nd = ctx.nd;
  std::vector<double> d(size_t(nd), 0.0);
  if (passesAll(probe, h, c)) return d;
  for (int j = 0; j < nd; ++j) {
    constexpr int kSteps = 16;
    double lo = 0, hi = 1;
    for (int s = 1; s <= kSteps; ++s) {
      const double f = double(s) / kSteps;
      if (passesAll(probe, h, c + ctx.dirs[size_t(j)] * (R[size_t(j)] * f))) {
        hi = f;
        break;
      }
      lo = f;
    }
    for (int it = 0; it < 6 && hi < 1; ++it) {
      const double mid = 0.5 * (lo + hi);
      (passesAll(probe, h, c + ctx.dirs[size_t(j)] * (R[size_t(j)] * mid)) ? hi : lo) = mid;
    }
    d[size_t(j)] = lo * R[size_t(j)];
  }
  return d;
}

// The interval's polygon at t in [0, 1] across it (centre c, vertex distances R); its film radius.
double polygonAt(const Interval& iv, int nd, double t, Vec2& c, std::vector<double>& R) {
  c = iv.c0 * (1 - t) + iv.c1 * t;
  R.resize(size_t(nd));
  for (int j = 0; j < nd; ++j) R[size_t(j)] = iv.A[size_t(j)] * (1 - t) + iv.B[size_t(j)] * t;
  return iv.r0 + t * (iv.r1 - iv.r0);
}

// The hole of one interval (not empty): its vertex distances at the ends, each no farther than
// the blocked middle's edge at its end and (so that the interpolated hole lies inside at the
// middle too) at the middle, pulled in by the safety margin; checked between the ends (every
// vertex of the hole and the middle of every edge blocked), else shrunk; and the fan's prefix
// sums made to count the polygon minus the hole. No hole where the middle is not blocked.
void cutHole(Probe& probe, Interval& iv) {
  const Context& ctx = probe.ctx;
  const int nd = ctx.nd;
  Vec2 c;
  std::vector<double> R;
  std::vector<double> d[3];
  bool any = true;
  for (int e = 0; e < 3 && any; ++e) {
    const double h = polygonAt(iv, nd, 0.5 * e, c, R);
    d[e] = holeDistances(probe, h, c, R);
    any = *std::max_element(d[e].begin(), d[e].end()) > 0;
  }
  if (!any) return;
  const double pull = 1 - ctx.opts.margin;
  std::vector<double> HA(static_cast<size_t>(nd)), HB(static_cast<size_t>(nd));
  for (int j = 0; j < nd; ++j) {
    HA[size_t(j)] = std::min(d[0][size_t(j)], d[1][size_t(j)]) * pull;
    HB[size_t(j)] = std::min(d[2][size_t(j)], d[1][size_t(j)]) * pull;
  }
  double k = 1;
  for (int tries = 0; tries < 4; ++tries) {
    bool ok = true;
    for (double t : {0.25, 0.75}) {
      const double h = polygonAt(iv, nd, t, c, R);
      for (int j = 0; j < nd && ok; ++j) {
        const int j1 = (j + 1) % nd;
        const Vec2 a = ctx.dirs[size_t(j)] * (k * (HA[size_t(j)] * (1 - t) + HB[size_t(j)] * t));
        const Vec2 b = ctx.dirs[size_t(j1)] * (k * (HA[size_t(j1)] * (1 - t) + HB[size_t(j1)] * t));
        ok = !passesAll(probe, h, c + a) && !passesAll(probe, h, c + (a + b) * 0.5);
      }
    }
    if (ok) break;
    k = tries < 3 ? k * 0.8 : 0.0;
  }
  if (!(k > 0)) return;
  for (int j = 0; j < nd; ++j) HA[size_t(j)] *= k, HB[size_t(j)] *= k;
  for (int j = 0; j < nd; ++j) {
    const int j1 = (j + 1) % nd;
    double* p = &iv.P[3 * size_t(j)];
    p[3] = p[0] + iv.A[size_t(j)] * iv.A[size_t(j1)] - HA[size_t(j)] * HA[size_t(j1)];
    p[4] = p[1] + iv.A[size_t(j)] * iv.B[size_t(j1)] + iv.B[size_t(j)] * iv.A[size_t(j1)] -
           HA[size_t(j)] * HB[size_t(j1)] - HB[size_t(j)] * HA[size_t(j1)];
    p[5] = p[2] + iv.B[size_t(j)] * iv.B[size_t(j1)] - HB[size_t(j)] * HB[size_t(j1)];
  }
  iv.HA = std::move(HA);
  iv.HB = std::move(HB);
}

}  // namespace

std::vector<Interval> buildIntervals(int nd, const std::vector<Polygon>& nodes,
                                     const std::vector<std::vector<double>>& scales) {
  std::vector<Interval> intervals;
  for (size_t k = 0; k + 1 < nodes.size(); ++k) {
    const Polygon& a = nodes[k];
    const Polygon& b = nodes[k + 1];
    Interval iv;
    iv.r0 = a.r;
    iv.r1 = b.r;
    iv.empty = a.empty && b.empty;
    if (!iv.empty) {
      const Polygon& pa = a.empty ? b : a;
      const Polygon& pb = b.empty ? a : b;
      iv.c0 = pa.centre;
      iv.c1 = pb.centre;
      iv.A.resize(nd);
      iv.B.resize(nd);
      for (int j = 0; j < nd; ++j) {
        iv.A[j] = pa.radius[j] * scales[k][j];
        iv.B[j] = pb.radius[j] * scales[k][j];
      }
      iv.P.assign(3 * size_t(nd + 1), 0.0);
      for (int j = 0; j < nd; ++j) {
        const int j1 = (j + 1) % nd;
        double* p = &iv.P[3 * size_t(j)];
        p[3] = p[0] + iv.A[j] * iv.A[j1];
        p[4] = p[1] + iv.A[j] * iv.B[j1] + iv.B[j] * iv.A[j1];
        p[5] = p[2] + iv.B[j] * iv.B[j1];
      }
    }
    intervals.push_back(std::move(iv));
  }
  return intervals;
}

Sector makeSector(Probe& probe, const std::vector<Polygon>& nodes,
                  const std::vector<std::vector<double>>& scales) {
  const Context& ctx = probe.ctx;
  Sector out;
  out.intervals = buildIntervals(ctx.nd, nodes, scales);
  // Central obscurations: a hole in each interval's polygon (rotationally symmetric lenses).
  if (ctx.obscured && ctx.rotational)
    for (Interval& iv : out.intervals)
      if (!iv.empty) cutHole(probe, iv);
  // A table from film radius to the first interval that can hold it, so that a lookup is a
  // table read and a step or two instead of a binary search.
  if (!out.intervals.empty() && ctx.film_radius > 0) {
    constexpr int kLut = 512;
    std::vector<int> lut(kLut + 1);
    for (int k = 0; k <= kLut; ++k)
      lut[size_t(k)] = intervalIn(out.intervals, {}, 0, ctx.film_radius * k / kLut);
    out.lut_scale = kLut / ctx.film_radius;
    out.lut = std::move(lut);
  }
  return out;
}

int intervalIn(const std::vector<Interval>& intervals, const std::vector<int>& radius_lut,
               double lut_scale, double r) {
  // Intervals are sorted by radius; the first whose upper end reaches r.
  const int last = static_cast<int>(intervals.size()) - 1;
  if (!radius_lut.empty()) {
    // The table's entry for the radius below r is the first interval reaching that radius, at
    // or before the answer.
    const double x = std::max(0.0, r * lut_scale);
    int k = radius_lut[std::min(size_t(x), radius_lut.size() - 1)];
    while (k < last && intervals[size_t(k)].r1 < r) ++k;
    return k;
  }
  auto it = std::lower_bound(intervals.begin(), intervals.end(), r,
                             [](const Interval& iv, double v) { return iv.r1 < v; });
  const int k = static_cast<int>(it - intervals.begin());
  return std::clamp(k, 0, static_cast<int>(intervals.size()) - 1);
}

}  // namespace lensim::optics::pupil
