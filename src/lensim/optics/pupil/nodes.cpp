// Stage 0 of the exit-pupil build: the polygons at the uniform film radii of one wedge edge, each
// found from its neighbour's.
#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

// Past the edge of the image circle (two nodes in a row found empty after one that was not), the
// nodes farther out are empty without a search: film points beyond the image circle see nothing
// (as fieldOfView's image circle and the empty intervals between empty nodes assume), and the
// search for a region about no neighbouring polygon (passingRearAim's grids, thousands of traces
// a node) would cost a lens with a small image circle more than the rest of its bound.
std::vector<Polygon> uniformNodes(Probe& probe, int n_nodes) {
  const Context& ctx = probe.ctx;
  std::vector<Polygon> nodes;
  bool seen = false;
  int empty_run = 0;
  for (int k = 0; k <= n_nodes; ++k) {
    const double h = ctx.film_radius * k / ctx.ni;
    if (seen && empty_run >= 2) {
      Polygon none;
      none.r = h;
      nodes.push_back(none);
      continue;
    }
    nodes.push_back(probe.makeNode(h, k > 0 ? &nodes.back() : nullptr));
    seen = seen || !nodes.back().empty;
    empty_run = nodes.back().empty ? empty_run + 1 : 0;
  }
  return nodes;
}

}  // namespace lensim::optics::pupil
