// Loop subdivision on flat arrays: edges are the half-edges bucketed by their smaller vertex
// (a counting sort) and sorted by the larger one within each bucket; vertex one-rings are a
// compressed row table filled in edge order, which leaves each row in ascending order.
#include "lensim/scene/loop_subdivision.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace lensim::scene {

namespace {

struct Topology {
  // Unique edges in (lo, hi) order.
  std::vector<int> edge_lo, edge_hi;
  std::vector<int> edge_faces;            // triangles on the edge
  std::vector<int> opp0, opp1;            // opposite vertices of the first two triangles
  std::vector<int> edge_of;               // corner 3f+e -> edge (v_e, v_e+1) of triangle f
  std::vector<size_t> ring_start;         // one-ring of v: ring[ring_start[v], ring_start[v+1])
  std::vector<int> ring;                  // ascending vertex indices
  std::vector<int> boundary_count;        // boundary edges at the vertex (counted per end)
  std::vector<int> boundary0, boundary1;  // the first two neighbours across boundary edges

  // `full`: also the per-edge data a subdivision step needs (opposite vertices, edge_of).
  Topology(size_t nv, const std::vector<int>& idx, bool full) {
    const size_t nh = idx.size() / 3 * 3;
    auto other = [&](size_t h, int k) { return idx[h / 3 * 3 + (h % 3 + k) % 3]; };
    // Half-edges bucketed by their smaller end (stable: ascending half-edge index).
    std::vector<size_t> start(nv + 1, 0);
    for (size_t h = 0; h < nh; ++h) ++start[static_cast<size_t>(std::min(idx[h], other(h, 1))) + 1];
    for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
    std::vector<uint32_t> order(nh);
    {
      std::vector<size_t> fill(start.begin(), start.end() - 1);
      for (size_t h = 0; h < nh; ++h)
        order[fill[static_cast<size_t>(std::min(idx[h], other(h, 1)))]++] =
            static_cast<uint32_t>(h);
    }
    auto hiOf = [&](uint32_t h) { return std::max(idx[h], other(h, 1)); };
    if (full) {
      edge_of.resize(nh);
      opp0.reserve(nh / 2 + 1);
      opp1.reserve(nh / 2 + 1);
    }
    edge_lo.reserve(nh / 2 + 1);
    edge_hi.reserve(nh / 2 + 1);
    edge_faces.reserve(nh / 2 + 1);
    for (size_t v = 0; v < nv; ++v) {
      auto b = order.begin() + static_cast<std::ptrdiff_t>(start[v]);
      auto e = order.begin() + static_cast<std::ptrdiff_t>(start[v + 1]);
      std::sort(b, e, [&](uint32_t x, uint32_t y) {
        int hx = hiOf(x), hy = hiOf(y);
        return hx != hy ? hx < hy : x < y;
      });
      for (auto run = b; run != e;) {
        const int hi = hiOf(*run);
        auto end = run;
        while (end != e && hiOf(*end) == hi) ++end;
        const int id = static_cast<int>(edge_lo.size());
        edge_lo.push_back(static_cast<int>(v));
        edge_hi.push_back(hi);
        edge_faces.push_back(static_cast<int>(end - run));
        if (full) {
          opp0.push_back(other(*run, 2));
          opp1.push_back(end - run >= 2 ? other(*(run + 1), 2) : -1);
          for (auto h = run; h != end; ++h) edge_of[*h] = id;
        }
        run = end;
      }
    }
    order = {};
    // One-rings: edges in (lo, hi) order append hi to lo's row and lo to hi's row; a row of v
    // gets its smaller neighbours (from edges (u, v), u < v, in ascending u) before its larger
    // ones (edges (v, w) in ascending w), so it is sorted.
    const size_t ne = edge_lo.size();
    ring_start.assign(nv + 1, 0);
    for (size_t i = 0; i < ne; ++i) {
      ++ring_start[static_cast<size_t>(edge_lo[i]) + 1];
      if (edge_hi[i] != edge_lo[i]) ++ring_start[static_cast<size_t>(edge_hi[i]) + 1];
    }
    for (size_t v = 0; v < nv; ++v) ring_start[v + 1] += ring_start[v];
    ring.resize(ring_start[nv]);
    boundary_count.assign(nv, 0);
    boundary0.assign(nv, -1);
    boundary1.assign(nv, -1);
    std::vector<size_t> fill(ring_start.begin(), ring_start.end() - 1);
    auto addBoundary = [&](int v, int u) {
      int& c = boundary_count[static_cast<size_t>(v)];
      if (c == 0) boundary0[static_cast<size_t>(v)] = u;
      if (c == 1) boundary1[static_cast<size_t>(v)] = u;
      ++c;
    };
    for (size_t i = 0; i < ne; ++i) {
      const int a = edge_lo[i], b = edge_hi[i];
      ring[fill[static_cast<size_t>(a)]++] = b;
      if (a != b) ring[fill[static_cast<size_t>(b)]++] = a;
      if (edge_faces[i] == 1) {
        addBoundary(a, b);
        addBoundary(b, a);
      }
    }
  }

  size_t valence(size_t v) const { return ring_start[v + 1] - ring_start[v]; }
  Vec3 ringSum(const std::vector<Vec3>& P, size_t v) const {
    Vec3 sum;
    for (size_t i = ring_start[v]; i < ring_start[v + 1]; ++i)
      sum += P[static_cast<size_t>(ring[i])];
    return sum;
  }
};

double beta(size_t n) {
  return n == 3 ? 3.0 / 16 : 3.0 / (8.0 * static_cast<double>(n));
}

}  // namespace

void loopSubdivide(std::vector<Vec3>& P, std::vector<int>& idx, int levels) {
  for (int level = 0; level < levels; ++level) {
    const size_t nv = P.size();
    std::vector<int> newIdx;
    std::vector<Vec3> newP;
    {
      const Topology topo(nv, idx, true);
      const size_t ne = topo.edge_lo.size();
      newP.resize(nv + ne);
      // Even (old) vertices.
      for (size_t v = 0; v < nv; ++v) {
        const int nb = topo.boundary_count[v];
        const size_t n = topo.valence(v);
        if (nb != 0 || n == 0) {
          newP[v] = nb == 2 ? P[v] * 0.75 + (P[static_cast<size_t>(topo.boundary0[v])] +
                                             P[static_cast<size_t>(topo.boundary1[v])]) *
                                                0.125
                            : P[v];
          continue;
        }
        newP[v] = P[v] * (1 - static_cast<double>(n) * beta(n)) + topo.ringSum(P, v) * beta(n);
      }
      // Odd (edge) vertices.
      for (size_t i = 0; i < ne; ++i) {
        const Vec3& a = P[static_cast<size_t>(topo.edge_lo[i])];
        const Vec3& b = P[static_cast<size_t>(topo.edge_hi[i])];
        newP[nv + i] = topo.edge_faces[i] == 2
                           ? (a + b) * 0.375 + (P[static_cast<size_t>(topo.opp0[i])] +
                                                P[static_cast<size_t>(topo.opp1[i])]) *
                                                   0.125
                           : (a + b) * 0.5;
      }
      const size_t nf = idx.size() / 3;
      newIdx.resize(nf * 12);
      const int base = static_cast<int>(nv);
      for (size_t f = 0; f < nf; ++f) {
        const int v0 = idx[3 * f], v1 = idx[3 * f + 1], v2 = idx[3 * f + 2];
        const int e01 = base + topo.edge_of[3 * f], e12 = base + topo.edge_of[3 * f + 1],
                  e20 = base + topo.edge_of[3 * f + 2];
        const int t[12] = {v0, e01, e20, v1, e12, e01, v2, e20, e12, e01, e12, e20};
        std::copy(t, t + 12, newIdx.begin() + static_cast<std::ptrdiff_t>(12 * f));
      }
    }
    P = std::move(newP);
    idx = std::move(newIdx);
  }
  if (levels == 0) return;
  // Limit positions: interior (1 - n g) v + g sum, g = 1 / (n + 3 / (8 beta));
  // boundary 3/5 v + 1/5 (b0 + b1).
  const Topology topo(P.size(), idx, false);
  std::vector<Vec3> limit(P.size());
  for (size_t v = 0; v < P.size(); ++v) {
    const int nb = topo.boundary_count[v];
    const size_t n = topo.valence(v);
    if (nb != 0 || n == 0) {
      limit[v] = nb == 2 ? P[v] * 0.6 + (P[static_cast<size_t>(topo.boundary0[v])] +
                                         P[static_cast<size_t>(topo.boundary1[v])]) *
                                            0.2
                         : P[v];
      continue;
    }
    const double g = 1 / (static_cast<double>(n) + 3 / (8 * beta(n)));
    limit[v] = P[v] * (1 - static_cast<double>(n) * g) + topo.ringSum(P, v) * g;
  }
  P = std::move(limit);
}

}  // namespace lensim::scene
