// Stage 2 of the exit-pupil build: the wavelength bands' nodes. Each band's node is the lens's
// own node with each vertex distance the farthest of the band's lenses' boundaries along the
// vertex's direction from the node's centre (each lens's region is star-shaped about it, so that
// this is the union's), each from a predicted distance (two or three traces), times the node's
// own check factors; the intervals keep their widening. Where the centre lies outside one of the
// band's regions, or where the lens's region is empty next to one that is not (the edge of the
// image circle moves with the wavelength), the band lens's polygon is traced from scratch.
#include <algorithm>
#include <cmath>

#include "lensim/optics/pupil/build.h"

namespace lensim::optics::pupil {

namespace {

// The lenses of all bands, each once, in order of first appearance (neighbouring bands share
// their edge's lens).
std::vector<const LensSystem*> bandLenses(const ExitPupilOptions& opts) {
  std::vector<const LensSystem*> band_lens;
  for (const std::vector<const LensSystem*>& band : opts.bands)
    for (const LensSystem* L : band)
      if (std::find(band_lens.begin(), band_lens.end(), L) == band_lens.end())
        band_lens.push_back(L);
  return band_lens;
}

double xOf(const LensSystem& L) {
  return 1 / (L.wavelength_nm() * L.wavelength_nm());
}

// At a node that is not empty: each band lens's vertex distances about the node's centre
// (dist[i]; inside[i] false where the centre lies outside its region). Each is predicted from
// the distances already known at this node (the lens's own, and the band lenses' solved before,
// nearest the lens's own wavelength first), linearly in 1/lambda^2 through the two nearest
// wavelengths, and accepted from one blocked trace where the margin puts the boundary within
// kBandAccept before it (Probe::boundary: still a blocked point, so that no passing ray falls
// outside; the overshoot is at most ~0.2% of the distance).
void solveAboutCentre(Probe& probe, const Polygon& base,
                      const std::vector<const LensSystem*>& band_lens,
                      std::vector<std::vector<double>>& dist, std::vector<char>& inside) {
  const Context& ctx = probe.ctx;
  const int nd = ctx.nd;
  const double h = base.r;
  constexpr double kBandAccept = 2e-3;
  std::vector<std::pair<double, const std::vector<double>*>> known{{xOf(ctx.lens), &base.raw}};
  std::vector<double> slopes(size_t(nd), 0.0), pred(size_t(nd), 0.0);
  std::vector<size_t> order(band_lens.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return std::abs(xOf(*band_lens[a]) - xOf(ctx.lens)) <
           std::abs(xOf(*band_lens[b]) - xOf(ctx.lens));
  });
  for (size_t i : order) {
    probe.cur = {band_lens[i]};
    inside[i] = probe.passes(h, base.centre);
    dist[i].assign(size_t(nd), 0.0);
    if (!inside[i]) continue;
    const double xi = xOf(*band_lens[i]);
    std::sort(known.begin(), known.end(), [&](const auto& a, const auto& b) {
      return std::abs(a.first - xi) < std::abs(b.first - xi);
    });
    for (int j = 0; j < nd; ++j) {
      const double da = (*known[0].second)[size_t(j)];
      double d = da;
      if (known.size() > 1 && known[1].first != known[0].first) {
        const double db = (*known[1].second)[size_t(j)];
        d = da + (db - da) * (xi - known[0].first) / (known[1].first - known[0].first);
        d = std::clamp(d, 0.5 * da, 2 * da);
      }
      pred[size_t(j)] = d;
    }
    for (double& v : pred) v *= 1 + 0.5 * kBandAccept;
    std::vector<double> ls = slopes;
    probe.boundaries(h, base.centre, ctx.dirs.data(), pred.data(), nd, kBandAccept, slopes.data(),
                     dist[i].data(), ls.data());
    for (int j = 0; j < nd; ++j)
      if (ls[size_t(j)] > 0) slopes[size_t(j)] = ls[size_t(j)];
    known.push_back({xi, &dist[i]});
  }
}

// The band polygons of one node. Where a band's lens has no distances about the node's centre,
// that lens's polygon is traced from scratch, once per node, or found empty. A band is then the
// union of its lenses' polygons: empty, the one polygon that is not, or the farthest of the
// distances about the node's centre; only a band whose lenses' regions lie about different
// centres is traced from scratch as a union.
class NodeBands {
 public:
  NodeBands(Probe& probe, const std::vector<const LensSystem*>& band_lens,
            const std::vector<std::vector<double>>& dist, const std::vector<char>& inside,
            std::vector<char>& seen_empty, const std::vector<Polygon>& done, size_t k)
      : probe_(probe),
        ctx_(probe.ctx),
        band_lens_(band_lens),
        dist_(dist),
        inside_(inside),
        seen_empty_(seen_empty),
        base_(done[k]),
        h_(done[k].r),
        state_(band_lens.size(), 0),
        own_(band_lens.size()) {
    hint_ = !base_.empty                                ? &base_
            : k > 0 && !done[k - 1].empty               ? &done[k - 1]
            : k + 1 < done.size() && !done[k + 1].empty ? &done[k + 1]
                                                        : nullptr;
  }

  // The node of a band (not empty) of lenses `band`.
  Polygon bandPolygon(const std::vector<const LensSystem*>& band);

 private:
  // Per band lens: 0 not yet traced, 1 distances about the node's centre (dist), 2 empty, 3 a
  // polygon of its own (own_[i]).
  char lensState(size_t i);
  // The node's check factors, which every band polygon traced here takes over.
  double nodeF(int j) const { return base_.empty ? 1.0 : base_.node_f[size_t(j)]; }
  // The polygon of the union of the band lenses `lenses` (indices), from `from`.
  Polygon scratch(const std::vector<size_t>& lenses, const Polygon* from);
  // About the centre of one lens's own polygon, where the others' regions hold it too (the union
  // is star-shaped about it): the farthest of their distances; nullopt where no centre does.
  std::optional<Polygon> unionAboutOwn(const std::vector<size_t>& own_poly,
                                       const std::vector<size_t>& seeing);

  Probe& probe_;
  const Context& ctx_;
  const std::vector<const LensSystem*>& band_lens_;
  const std::vector<std::vector<double>>& dist_;
  const std::vector<char>& inside_;
  // The band lenses found to see nothing at a node of this task: at its farther nodes they see
  // nothing either (past the edge of their image circle, as stage 0 takes the lens's own), so
  // that the search that finds a region empty (a grid and pattern searches, ~400 traces) runs
  // once per lens and task rather than at every node of the zone where the edge of the image
  // circle moves with the wavelength.
  std::vector<char>& seen_empty_;
  const Polygon& base_;
  const double h_;
  const Polygon* hint_;
  std::vector<char> state_;
  std::vector<Polygon> own_;
};

Polygon NodeBands::scratch(const std::vector<size_t>& lenses, const Polygon* from) {
  Polygon np;
  np.r = h_;
  if (!from) return np;
  probe_.cur.clear();
  for (size_t i : lenses) probe_.cur.push_back(band_lens_[i]);
  const std::vector<Vec2> pts = probe_.boundaryPoints(h_, ctx_.nd, 0.0, &np.centre, from);
  if (pts.empty()) return np;
  np.empty = false;
  for (int j = 0; j < ctx_.nd; ++j) {
    const Vec2 q = pts[size_t(j)];
    np.radius.push_back(std::hypot(q.x - np.centre.x, q.y - np.centre.y) * nodeF(j));
  }
  return np;
}

char NodeBands::lensState(size_t i) {
  if (state_[i] == 0) {
    if (!base_.empty && inside_[i]) {
      state_[i] = 1;
    } else {
      // From the nearest wavelength's polygon of its own where there is one (its centre usually
      // lies inside this lens's region too).
      const Polygon* from = hint_;
      for (size_t d = 1; d < band_lens_.size() && from == hint_; ++d)
        for (size_t n : {i - d, i + d})
          if (n < band_lens_.size() && state_[n] == 3) {
            from = &own_[n];
            break;
          }
      if (!seen_empty_[i]) own_[i] = scratch(std::vector<size_t>{i}, from);
      state_[i] = seen_empty_[i] || own_[i].empty ? 2 : 3;
      seen_empty_[i] = state_[i] == 2;
    }
  }
  return state_[i];
}

std::optional<Polygon> NodeBands::unionAboutOwn(const std::vector<size_t>& own_poly,
                                                const std::vector<size_t>& seeing) {
  const int nd = ctx_.nd;
  for (size_t a : own_poly) {
    const Polygon& pa = own_[a];
    std::vector<double> far = pa.radius;
    bool ok = true;
    for (size_t i : seeing) {
      if (i == a) continue;
      probe_.cur = {band_lens_[i]};
      if (!probe_.passes(h_, pa.centre)) {
        ok = false;
        break;
      }
      // From this polygon's own distances (the other lens's region is much like it).
      std::vector<double> g(static_cast<size_t>(nd)), d(static_cast<size_t>(nd));
      for (int j = 0; j < nd; ++j) g[size_t(j)] = pa.radius[size_t(j)] / nodeF(j);
      probe_.boundaries(h_, pa.centre, ctx_.dirs.data(), g.data(), nd, 0.0, nullptr, d.data(),
                        nullptr);
      for (int j = 0; j < nd; ++j)
        far[size_t(j)] = std::max(far[size_t(j)], d[size_t(j)] * nodeF(j));
    }
    if (!ok) continue;
    Polygon node = pa;
    node.radius = far;
    return node;
  }
  return std::nullopt;
}

Polygon NodeBands::bandPolygon(const std::vector<const LensSystem*>& band) {
  std::vector<size_t> about_centre, own_poly, seeing;  // indices into band_lens_
  for (const LensSystem* L : band) {
    const size_t i =
        size_t(std::find(band_lens_.begin(), band_lens_.end(), L) - band_lens_.begin());
    const char st = lensState(i);
    if (st == 1) about_centre.push_back(i);
    if (st == 3) own_poly.push_back(i);
    if (st != 2) seeing.push_back(i);
  }
  if (seeing.empty()) {
    Polygon node;
    node.r = h_;
    return node;
  }
  if (own_poly.empty()) {
    Polygon node = base_;
    for (int j = 0; j < ctx_.nd; ++j) {
      double d = 0;
      for (size_t i : about_centre) d = std::max(d, dist_[i][size_t(j)]);
      node.radius[size_t(j)] = d * base_.node_f[size_t(j)];
    }
    return node;
  }
  if (seeing.size() == 1) return own_[own_poly[0]];
  // Lenses that see something about different centres.
  if (std::optional<Polygon> node = unionAboutOwn(own_poly, seeing)) return *node;
  return scratch(seeing, hint_);
}

}  // namespace

void solveBandNodes(Probe& probe, const std::vector<Polygon>& done, size_t k0, size_t k1,
                    std::vector<std::vector<Polygon>>& band_nodes) {
  const ExitPupilOptions& opts = probe.ctx.opts;
  const std::vector<const LensSystem*> band_lens = bandLenses(opts);
  std::vector<std::vector<double>> dist(band_lens.size());
  std::vector<char> inside(band_lens.size());
  std::vector<char> seen_empty(band_lens.size(), 0);
  for (size_t k = k0; k < k1 && !opts.bands.empty(); ++k) {
    if (!done[k].empty) solveAboutCentre(probe, done[k], band_lens, dist, inside);
    NodeBands node_bands(probe, band_lens, dist, inside, seen_empty, done, k);
    for (size_t b = 0; b < opts.bands.size(); ++b)
      if (!opts.bands[b].empty()) band_nodes[b][k] = node_bands.bandPolygon(opts.bands[b]);
  }
}

}  // namespace lensim::optics::pupil
