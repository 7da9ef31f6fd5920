// Stage 1 of the exit-pupil build: each uniform interval's interpolated polygon checked half-way
// against the true region; the interval split where the region changes fast, and each
// sub-interval's widening factors (the checks' and the safety margin).
#include <algorithm>

#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

namespace {

// At the edge of the image circle (one end empty) the region moves and vanishes within the
// interval: its interpolated polygon checked all across, the factors raised to hold it.
void checkAcross(Probe& probe, const Polygon& left, const Polygon& right, std::vector<double>& f) {
  const Context& ctx = probe.ctx;
  for (double t : {0.1, 0.3, 0.7, 0.9, 0.99}) {
    const double ht = left.r + t * (right.r - left.r);
    Polygon at;
    interpolateBetween(left, right, ht, at);
    const std::vector<double> g =
        coverFactors(ctx, at, probe.boundaryPoints(ht, ctx.nd, 0.25 * ctx.dphi, nullptr, &at));
    for (int j = 0; j < ctx.nd; ++j) f[j] = std::max(f[j], g[j]);
  }
}

}  // namespace

RefinedInterval refineInterval(Probe& probe, const Polygon& left_end, const Polygon& right_end) {
  const Context& ctx = probe.ctx;
  const int nd = ctx.nd;
  RefinedInterval out;
  std::vector<Polygon> stack{right_end};  // right ends still to process, nearest last
  Polygon left = left_end;
  while (!stack.empty()) {
    Polygon right = stack.back();
    const double h = 0.5 * (left.r + right.r);
    Polygon interp;
    const bool any = interpolateBetween(left, right, h, interp);
    std::vector<double> f(nd, 1.0);
    bool split = false;
    if (any) {
      f = coverFactors(ctx, interp, probe.boundaryPoints(h, nd, 0.25 * ctx.dphi, nullptr, &interp));
      const double worst = *std::max_element(f.begin(), f.end());
      const double a0 = polygonArea(ctx, left), a1 = polygonArea(ctx, right);
      // Where the region's area changes fast, interpolation wastes samples: split. Not beyond
      // the image circle, whose samples the waste budget leaves out, and where the region
      // shrinks to nothing at the edge (the splits there would cost the toroidal anamorphic on
      // 36x24 an eighth of its traces for no fewer samples wasted); an interval the checks would
      // widen by over 3%, or the one where the region vanishes, is split all the same.
      const bool fast = left.empty != right.empty ||
                        (left.r < ctx.r_ic && std::max(a0, a1) > 1.25 * std::min(a0, a1));
      split = (worst > 1.03 || fast) && right.r - left.r > 2 * ctx.min_width;
    }
    if (split) {
      stack.push_back(probe.makeNode(h, left.empty ? &right : &left));
      continue;
    }
    if (any && left.empty != right.empty) checkAcross(probe, left, right, f);
    // Where the region vanishes (the edge of the image circle) it changes shape fastest: triple
    // the margin there.
    const double base_margin = ctx.opts.margin;
    const double margin = left.empty != right.empty ? 3 * base_margin : base_margin;
    for (double& v : f) v *= 1 + margin;
    out.scales.push_back(std::move(f));
    out.nodes.push_back(right);
    stack.pop_back();
    left = right;
  }
  return out;
}

}  // namespace lensim::optics::pupil
