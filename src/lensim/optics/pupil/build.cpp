// The exit-pupil build's driver: its stages run one after another, the independent pieces of each
// side by side (TBB; the start-up budget is wall time on two cores). Each task starts from a fresh
// probe (no search hints carried over from another task), so that the bounds do not depend on how
// the tasks are scheduled.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "lensim/optics/anamorphic.h"
#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

namespace {

// Runs f(0) .. f(n - 1) side by side.
template <class F>
void runTasks(size_t n, const F& f) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1),
                    [&](const tbb::blocked_range<size_t>& range) {
                      for (size_t i = range.begin(); i != range.end(); ++i) f(i);
                    });
}

// One wedge edge's results as the stages make them.
struct EdgeWork {
  std::vector<Polygon> initial;               // stage 0
  std::vector<std::vector<Polygon>> refined;  // stage 1, per uniform interval
  std::vector<std::vector<std::vector<double>>> refined_scales;
  std::vector<Polygon> done;                     // all nodes, by radius
  std::vector<std::vector<double>> scales;       // per interval
  std::vector<std::vector<Polygon>> band_nodes;  // stage 2
  std::vector<Sector> sets;                      // stage 3
};

// Past the image circle, as far as the uniform nodes tell: the least over the wedge edges of the
// first empty node's radius after one that is not (the film radius if there is none).
double imageCircleEnd(const std::vector<EdgeWork>& work, double film_radius) {
  double r_ic = film_radius;
  for (const EdgeWork& w : work)
    for (size_t k = 1; k < w.initial.size(); ++k)
      if (w.initial[k].empty && !w.initial[k - 1].empty) {
        r_ic = std::min(r_ic, w.initial[k].r);
        break;
      }
  return r_ic;
}

// Stage 1 over all uniform intervals, then each edge's nodes and factors put in order.
void refineAll(const Context& ctx, std::vector<EdgeWork>& work,
               const std::vector<int>& sector_nodes, std::atomic<long>& traces) {
  std::vector<std::array<int, 2>> tasks;  // (edge, uniform interval)
  for (size_t sec = 0; sec < work.size(); ++sec) {
    const int nk = sector_nodes[sec];
    work[sec].refined.assign(size_t(nk), {});
    work[sec].refined_scales.assign(size_t(nk), {});
    for (int k = 0; k < nk; ++k) tasks.push_back({int(sec), k});
  }
  runTasks(tasks.size(), [&](size_t i) {
    const auto [sec, k] = tasks[i];
    EdgeWork& w = work[size_t(sec)];
    Probe probe(ctx, sec);
    RefinedInterval ri = refineInterval(probe, w.initial[size_t(k)], w.initial[size_t(k) + 1]);
    w.refined[size_t(k)] = std::move(ri.nodes);
    w.refined_scales[size_t(k)] = std::move(ri.scales);
    traces += probe.traces;
  });
  for (size_t sec = 0; sec < work.size(); ++sec) {
    EdgeWork& w = work[sec];
    w.done = {w.initial[0]};
    for (int k = 0; k < sector_nodes[sec]; ++k) {
      w.done.insert(w.done.end(), w.refined[size_t(k)].begin(), w.refined[size_t(k)].end());
      w.scales.insert(w.scales.end(), w.refined_scales[size_t(k)].begin(),
                      w.refined_scales[size_t(k)].end());
    }
  }
}

// Stage 2: the wavelength bands' nodes, a few nodes of an edge a task.
void solveAllBands(const Context& ctx, std::vector<EdgeWork>& work, std::atomic<long>& traces) {
  constexpr int kBandNodesPerTask = 8;
  std::vector<std::array<int, 3>> tasks;  // (edge, first node, end)
  for (size_t sec = 0; sec < work.size(); ++sec) {
    EdgeWork& w = work[sec];
    w.band_nodes.assign(ctx.opts.bands.size(), w.done);
    const int n = static_cast<int>(w.done.size());
    if (!ctx.opts.bands.empty())
      for (int k = 0; k < n; k += kBandNodesPerTask)
        tasks.push_back({int(sec), k, std::min(n, k + kBandNodesPerTask)});
  }
  runTasks(tasks.size(), [&](size_t i) {
    const auto [sec, k0, k1] = tasks[i];
    EdgeWork& w = work[size_t(sec)];
    Probe probe(ctx, sec);
    solveBandNodes(probe, w.done, size_t(k0), size_t(k1), w.band_nodes);
    traces += probe.traces;
  });
}

// Stage 4 (anamorphic): each wedge's checks, kWedgeRadiiPerTask film radii of a wedge a task,
// against the bounds `lines` of the lens's own set.
std::vector<WedgeCheck> checkAllWedges(const Context& ctx, const std::vector<Sector>& lines,
                                       int n_wedges, const std::vector<double>& wedge_reach,
                                       std::atomic<long>& traces) {
  constexpr int kWedgeRadiiPerTask = 8;
  std::vector<std::vector<double>> wedge_radii(static_cast<size_t>(n_wedges));
  std::vector<std::vector<WedgeCheck>> wedge_parts(static_cast<size_t>(n_wedges));
  std::vector<std::array<int, 3>> tasks;  // (wedge, first radius, end)
  for (int wdg = 0; wdg < n_wedges; ++wdg) {
    wedge_radii[size_t(wdg)] = wedgeRadii(ctx, lines, wdg, wedge_reach[size_t(wdg)]);
    const int n = static_cast<int>(wedge_radii[size_t(wdg)].size());
    wedge_parts[size_t(wdg)].resize(size_t((n + kWedgeRadiiPerTask - 1) / kWedgeRadiiPerTask));
    for (int k = 0; k < n; k += kWedgeRadiiPerTask)
      tasks.push_back({wdg, k, std::min(n, k + kWedgeRadiiPerTask)});
  }
  runTasks(tasks.size(), [&](size_t i) {
    const auto [wdg, k0, k1] = tasks[i];
    Probe probe(ctx, wdg);
    wedge_parts[size_t(wdg)][size_t(k0 / kWedgeRadiiPerTask)] =
        checkWedge(probe, lines, wdg, wedge_radii[size_t(wdg)], k0, k1);
    traces += probe.traces;
  });
  std::vector<WedgeCheck> wedges(static_cast<size_t>(n_wedges));
  for (int wdg = 0; wdg < n_wedges; ++wdg)
    for (WedgeCheck& part : wedge_parts[size_t(wdg)]) {
      WedgeCheck& wc = wedges[size_t(wdg)];
      wc.r.insert(wc.r.end(), part.r.begin(), part.r.end());
      wc.f.insert(wc.f.end(), std::make_move_iterator(part.f.begin()),
                  std::make_move_iterator(part.f.end()));
    }
  return wedges;
}

}  // namespace

Context::Context(const LensSystem& lens_, const ParaxialData& p_, double film_radius_mm,
                 const ExitPupilOptions& opts_)
    : lens(lens_), p(p_), opts(opts_) {
  rotational = opts.rotational;
  nd = std::max(8, opts.directions);
  for (int j = 0; j < nd; ++j) dirs.push_back(unit(2 * std::numbers::pi * j / nd));
  // Anamorphic: the paraxial chief ray from film height h crosses the rear plane at kappa h
  // (aimed at the exit pupil's centre).
  if (!rotational) {
    const double z_film = lens.filmZ_mm(), z_rear = lens.rearVertexZ_mm();
    auto kappa = [&](double z_xp) {
      return std::abs(z_xp - z_film) > 1e-9 ? (z_xp - z_rear) / (z_xp - z_film) : 0.0;
    };
    kappa_y = kappa(p.exit_pupil_z_mm);
    const AnamorphicData ad = anamorphicData(lens);
    kappa_x = ad.x ? kappa(ad.x->exit_pupil_z_mm) : kappa_y;
  }
  dphi = 2 * std::numbers::pi / nd;
  rr = 1.5 * lens.interfaces().back().semi_aperture_mm;
  disc2 = opts.rear_disc_radius_mm * opts.rear_disc_radius_mm;
  obscured = lens.hasObscuration();
  film_radius = film_radius_mm;
  ni = std::max(1, opts.radial_bins);
  min_width = film_radius_mm / (ni * 16.0);
  wedge = (std::numbers::pi / 2) / std::max(1, opts.sectors);
  r_ic = film_radius_mm;
}

Bounds buildBounds(Context& ctx) {
  // Anamorphic lenses are symmetric under x -> -x and y -> -y: bounds are built along the edges
  // of `sectors` wedges of the first quadrant and blended across each wedge.
  const int n_wedges = std::max(1, ctx.opts.sectors);
  const int n_sectors = ctx.rotational ? 1 : n_wedges + 1;
  std::vector<int> sector_nodes(size_t(n_sectors), ctx.ni);  // uniform intervals along each edge
  std::vector<double> wedge_reach(size_t(n_wedges), ctx.film_radius);
  if (const Vec2 e = ctx.opts.film_half_extent_mm; !ctx.rotational && e.x > 0 && e.y > 0)
    filmRectangleReach(ctx, n_wedges, sector_nodes, wedge_reach);
  std::atomic<long> traces{0};
  std::vector<EdgeWork> work(static_cast<size_t>(n_sectors));
  // Stage 0: each edge's uniform nodes, an edge a task.
  runTasks(work.size(), [&](size_t sec) {
    Probe probe(ctx, int(sec));
    work[sec].initial = uniformNodes(probe, sector_nodes[sec]);
    traces += probe.traces;
  });
  ctx.r_ic = imageCircleEnd(work, ctx.film_radius);
  refineAll(ctx, work, sector_nodes, traces);
  solveAllBands(ctx, work, traces);
  // Stage 3: the sampling tables of the lens's own and each band's nodes, an edge a task.
  runTasks(work.size(), [&](size_t sec) {
    EdgeWork& w = work[sec];
    Probe probe(ctx, int(sec));
    w.sets.push_back(makeSector(probe, w.done, w.scales));
    for (const std::vector<Polygon>& nodes : w.band_nodes)
      w.sets.push_back(makeSector(probe, nodes, w.scales));
    traces += probe.traces;
  });
  Bounds out;
  out.sets.assign(work[0].sets.size(), {});
  for (EdgeWork& w : work)
    for (size_t set = 0; set < w.sets.size(); ++set)
      out.sets[set].push_back(std::move(w.sets[set]));
  if (!ctx.rotational) out.wedges = checkAllWedges(ctx, out.sets[0], n_wedges, wedge_reach, traces);
  out.traces = traces;
  return out;
}

}  // namespace lensim::optics::pupil
