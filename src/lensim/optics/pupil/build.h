// The exit-pupil bound's build (see optics/pupil.h for the algorithm): the state shared by its
// stages, the probe that traces the region's margin and finds its boundary, and the stages
// themselves, each a function with its inputs and outputs:
//   stage 0  uniformNodes      (nodes.cpp)    the polygons at the uniform film radii
//   stage 1  refineInterval    (refine.cpp)   each uniform interval checked, split, widened
//   stage 2  solveBandNodes    (bands.cpp)    the wavelength bands' vertex distances
//   stage 3  makeSector        (tables.cpp)   sampling tables, obscuration holes, radius table
//   stage 4  checkWedge        (wedges.cpp)   anamorphic: each wedge's blended polygon checked
// The searches and the margin are in probe.cpp and find_inside.cpp, the search's state machine
// in edge_search.h. Internal to the optics library.
#pragma once

#include <optional>
#include <vector>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/pupil.h"
#include "lensim/optics/pupil/bound.h"
#include "lensim/optics/pupil/edge_search.h"

namespace lensim::optics::pupil {

// A star-shaped polygon in the frame of a film point on the +x axis: vertices
// centre + radius[j] (cos 2 pi j / n, sin 2 pi j / n).
struct Polygon {
  double r = 0;  // film radius of a node
  bool empty = true;
  Vec2 centre;
  std::vector<double> radius;
  std::vector<double> raw, node_f;  // vertex distances before the node's check, its factors
};

// What every stage reads: the lens, the options and the quantities derived from them.
struct Context {
  // Everything derived from the lens and options, for film points up to film_radius_mm.
  Context(const LensSystem& lens, const ParaxialData& p, double film_radius_mm,
          const ExitPupilOptions& opts);
  const LensSystem& lens;
  const ParaxialData& p;
  const ExitPupilOptions& opts;
  bool rotational = true;
  double kappa_x = 0, kappa_y = 0;  // anamorphic: rear-plane chief-ray crossing per film mm
  int nd = 0;                       // polygon directions
  double dphi = 0;                  // the angle between them
  std::vector<Vec2> dirs;           // their unit vectors
  double rr = 0;                    // 1.5 x the rear element's semi-aperture: searches' scale
  double disc2 = 0;                 // the rear disc's radius squared (0: none)
  bool obscured = false;            // central obscurations
  double film_radius = 0;
  int ni = 0;            // uniform radial intervals
  double min_width = 0;  // the narrowest interval refinement makes
  double wedge = 0;      // anamorphic: a wedge's angle
  double r_ic = 0;       // past the image circle, as far as the uniform nodes tell (stage 1)
};

// The polygon interpolated between nodes a and b at film radius r (the non-empty one where the
// other is empty); false where both are empty.
bool interpolateBetween(const Polygon& a, const Polygon& b, double r, Polygon& poly);
// Per-vertex factors that widen the polygon until it contains the points: a point beyond the
// edge between vertices j and j+1 scales both by the ratio (1 where nothing reaches beyond).
std::vector<double> coverFactors(const Context& ctx, const Polygon& poly,
                                 const std::vector<Vec2>& pts);
double polygonArea(const Context& ctx, const Polygon& poly);

// One task's tracer of the region at a film point: the lenses whose regions count (`cur`), the
// film azimuths (anamorphic), the search hints carried from one search to the next and the
// trace count. Each task starts from a fresh probe, so that the bound does not depend on how
// the tasks are scheduled.
class Probe {
 public:
  // For wedge edge (or wedge) `sec`: azimuth sec x wedge for an anamorphic lens.
  Probe(const Context& ctx, int sec);

  const Context& ctx;
  // The lenses whose regions count (the first traced first): the lens and also_cover while
  // building the lens's own bound; a band's lenses, or one of them, while re-solving a band's.
  std::vector<const LensSystem*> cur;
  long traces = 0;
  // Anamorphic: the film azimuth whose region counts.
  void setAzimuth(double a) {
    az_ = {a};
    last_az_ = 0;
  }

  // The margin at n rear-plane points for film radius h, the traces of each lens batched.
  void marginBatch(double h, const Vec2* a, int n, double* out);
  double margin(double h, Vec2 a);
  bool passes(double h, Vec2 a) { return margin(h, a) <= 1; }
  // Distance from c (inside the region) to the region's boundary along u (probe.cpp).
  double boundary(double h, Vec2 c, Vec2 u, double guess, double accept = 0, bool cover = false);
  // boundary() along `count` directions at once, the searches side by side.
  void boundaries(double h, Vec2 c, const Vec2* u, const double* guess, int count, double accept,
                  const double* accept_slopes, double* out, double* last_slopes,
                  bool cover = false);
  // A point inside the region at film radius h (find_inside.cpp); nullopt: it sees nothing.
  std::optional<Vec2> findInside(double h, const Polygon* hint);
  // Boundary points of the region at film radius h in `count` directions from angle `offset`.
  std::vector<Vec2> boundaryPoints(double h, int count, double offset, Vec2* centre_out,
                                   const Polygon* hint);
  // A node: the region's polygon at radius h, checked at the half-way directions.
  Polygon makeNode(double h, const Polygon* hint);

 private:
  void settle(const EdgeSearch& e);
  std::vector<Vec2> centreRing(double h, Vec2& c, double guess);
  std::optional<Vec2> grid(double h, Vec2 centre, double reach, int n,
                           std::vector<std::pair<double, Vec2>>* margins);
  std::optional<Vec2> patternSearch(double h, Vec2 best, double g_best, double reach,
                                    double& g_end);

  std::vector<double> az_;  // anamorphic: the film azimuths whose regions count
  int last_az_ = 0;         // the one that passed last
  double slope_hint_ = 0;   // d(margin)/ds at the last boundary
  std::vector<int> mb_todo_, mb_left_;
  std::vector<double> mb_val_;
  std::vector<EdgeSearch> es_;
  std::vector<Vec2> es_pts_;
  std::vector<int> es_lane_;
  std::vector<double> es_g_;
};

// The whole build (build.cpp): the bounds (sets[0] the lens's own, sets[1 + b] band b's; per
// set one sector per wedge edge), an anamorphic lens's wedge checks and the traces it took.
// ctx.r_ic is set on the way.
struct Bounds {
  std::vector<std::vector<Sector>> sets;
  std::vector<WedgeCheck> wedges;
  long traces = 0;
};
Bounds buildBounds(Context& ctx);

// Stage 0: the nodes at film radii film_radius k / ni, k = 0 .. n_nodes.
std::vector<Polygon> uniformNodes(Probe& probe, int n_nodes);

// Stage 1: the uniform interval (left, right) checked half-way and split where needed: its
// nodes after `left` and each sub-interval's widening factors.
struct RefinedInterval {
  std::vector<Polygon> nodes;
  std::vector<std::vector<double>> scales;
};
RefinedInterval refineInterval(Probe& probe, const Polygon& left, const Polygon& right);

// Stage 2: the wavelength bands' nodes k0 .. k1 - 1 (band_nodes[b][k], preset to the lens's own
// nodes `done`).
void solveBandNodes(Probe& probe, const std::vector<Polygon>& done, size_t k0, size_t k1,
                    std::vector<std::vector<Polygon>>& band_nodes);

// Stage 3: the sampling tables of one wedge edge's nodes (with each interval's widening factors
// `scales`), an obscuration's holes and the radius table.
Sector makeSector(Probe& probe, const std::vector<Polygon>& nodes,
                  const std::vector<std::vector<double>>& scales);
// The intervals between consecutive nodes, scaled and with their prefix sums.
std::vector<Interval> buildIntervals(int nd, const std::vector<Polygon>& nodes,
                                     const std::vector<std::vector<double>>& scales);

// Anamorphic on a film rectangle: the uniform intervals along each wedge edge and each wedge's
// reach (ExitPupilOptions::film_half_extent_mm).
void filmRectangleReach(const Context& ctx, int n_wedges, std::vector<int>& sector_nodes,
                        std::vector<double>& wedge_reach);
// Stage 4 (anamorphic): the film radii at which wedge `wdg`'s blended polygon is checked.
std::vector<double> wedgeRadii(const Context& ctx, const std::vector<Sector>& lines, int wdg,
                               double reach);
// Stage 4: the checks of wedge `wdg` (probe made for it) at radii[k0 .. k1).
WedgeCheck checkWedge(Probe& probe, const std::vector<Sector>& lines, int wdg,
                      const std::vector<double>& radii, int k0, int k1);

}  // namespace lensim::optics::pupil
