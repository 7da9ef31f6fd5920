// Loop subdivision on flat arrays (scene/loop_subdivision) against a small independent
// implementation on ordered maps and sets, written here from Loop's rules (Loop 1987; pbrt-v3
// src/shapes/loopsubdiv.cpp for the boundary and limit rules), and against invariants.
#include "lensim/scene/loop_subdivision.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <utility>
#include <vector>

namespace lensim::scene {
namespace {

struct Mesh {
  std::vector<Vec3> P;
  std::vector<int> idx;
};

// The reference: edges in an ordered map keyed by (smaller, larger) end, so the new edge
// vertices are numbered in that order (the order loopSubdivide documents); one-rings in
// ordered sets, summed in ascending index.
Mesh reference(Mesh m, int levels) {
  struct EdgeInfo {
    std::vector<int> opposite;  // third vertex of each triangle on the edge, in triangle order
    int vertex = -1;
  };
  auto betaOf = [](double n) { return n == 3 ? 3.0 / 16 : 3.0 / (8.0 * n); };
  auto topology = [](const Mesh& mesh, std::map<std::pair<int, int>, EdgeInfo>& edges,
                     std::vector<std::set<int>>& ring, std::vector<std::vector<int>>& bnd) {
    for (size_t f = 0; f < mesh.idx.size(); f += 3)
      for (int k = 0; k < 3; ++k) {
        int a = mesh.idx[f + size_t(k)], b = mesh.idx[f + size_t((k + 1) % 3)];
        edges[{std::min(a, b), std::max(a, b)}].opposite.push_back(
            mesh.idx[f + size_t((k + 2) % 3)]);
      }
    ring.assign(mesh.P.size(), {});
    bnd.assign(mesh.P.size(), {});
    for (auto& [e, info] : edges) {
      ring[size_t(e.first)].insert(e.second);
      ring[size_t(e.second)].insert(e.first);
      if (info.opposite.size() == 1) {
        bnd[size_t(e.first)].push_back(e.second);
        bnd[size_t(e.second)].push_back(e.first);
      }
    }
  };
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, EdgeInfo> edges;
    std::vector<std::set<int>> ring;
    std::vector<std::vector<int>> bnd;
    topology(m, edges, ring, bnd);
    Mesh out;
    for (size_t v = 0; v < m.P.size(); ++v) {
      const double n = double(ring[v].size());
      if (bnd[v].size() == 2) {
        out.P.push_back(m.P[v] * 0.75 + (m.P[size_t(bnd[v][0])] + m.P[size_t(bnd[v][1])]) * 0.125);
      } else if (!bnd[v].empty() || n == 0) {
        out.P.push_back(m.P[v]);
      } else {
        Vec3 s;
        for (int u : ring[v]) s += m.P[size_t(u)];
        out.P.push_back(m.P[v] * (1 - n * betaOf(n)) + s * betaOf(n));
      }
    }
    for (auto& [e, info] : edges) {
      info.vertex = int(out.P.size());
      const Vec3 ab = m.P[size_t(e.first)] + m.P[size_t(e.second)];
      if (info.opposite.size() == 2)
        out.P.push_back(ab * 0.375 +
                        (m.P[size_t(info.opposite[0])] + m.P[size_t(info.opposite[1])]) * 0.125);
      else
        out.P.push_back(ab * 0.5);
    }
    auto mid = [&](int a, int b) { return edges.at({std::min(a, b), std::max(a, b)}).vertex; };
    for (size_t f = 0; f < m.idx.size(); f += 3) {
      int a = m.idx[f], b = m.idx[f + 1], c = m.idx[f + 2];
      int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      for (int i : {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca}) out.idx.push_back(i);
    }
    m = std::move(out);
  }
  if (levels == 0) return m;
  std::map<std::pair<int, int>, EdgeInfo> edges;
  std::vector<std::set<int>> ring;
  std::vector<std::vector<int>> bnd;
  topology(m, edges, ring, bnd);
  std::vector<Vec3> limit;
  for (size_t v = 0; v < m.P.size(); ++v) {
    const double n = double(ring[v].size());
    if (bnd[v].size() == 2) {
      limit.push_back(m.P[v] * 0.6 + (m.P[size_t(bnd[v][0])] + m.P[size_t(bnd[v][1])]) * 0.2);
    } else if (!bnd[v].empty() || n == 0) {
      limit.push_back(m.P[v]);
    } else {
      const double g = 1 / (n + 3 / (8 * betaOf(n)));
      Vec3 s;
      for (int u : ring[v]) s += m.P[size_t(u)];
      limit.push_back(m.P[v] * (1 - n * g) + s * g);
    }
  }
  m.P = limit;
  return m;
}

Mesh tetrahedron() {
  return {{{1, 1, 1}, {-1, -1, 1}, {-1, 1, -1}, {1, -1, -1}}, {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2}};
}

Mesh cube() {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.P.push_back({double(i & 1), double((i >> 1) & 1), double(i >> 2)});
  m.idx = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
           2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  return m;
}

// An n x n grid of quads split into triangles, heights from a smooth function: an open mesh
// with boundary edges, valence 2, 3, 4 and 6 vertices; `shuffle` permutes vertex numbers.
Mesh grid(int n, bool shuffle) {
  Mesh m;
  std::vector<int> perm(size_t((n + 1) * (n + 1)));
  for (size_t i = 0; i < perm.size(); ++i) perm[i] = int(i);
  if (shuffle)
    for (size_t i = 0; i < perm.size(); ++i)
      std::swap(perm[i], perm[(i * 7919 + 13) % perm.size()]);
  m.P.resize(perm.size());
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x)
      m.P[size_t(perm[size_t(y * (n + 1) + x)])] = {double(x), double(y),
                                                    std::sin(x * 0.7) * std::cos(y * 0.4)};
  auto v = [&](int x, int y) { return perm[size_t(y * (n + 1) + x)]; };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      for (int i : {v(x, y), v(x + 1, y), v(x + 1, y + 1)}) m.idx.push_back(i);
      for (int i : {v(x, y), v(x + 1, y + 1), v(x, y + 1)}) m.idx.push_back(i);
    }
  return m;
}

// Three triangles on one edge (non-manifold), a dangling triangle sharing one vertex, and a
// vertex no triangle uses.
Mesh nonManifold() {
  return {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {2, 1, 0}, {2, 0, 1}, {5, 5, 5}},
          {0, 1, 2, 1, 0, 3, 0, 1, 4, 1, 5, 6}};
}

void expectSame(const Mesh& in, int levels) {
  Mesh ref = reference(in, levels);
  std::vector<Vec3> P = in.P;
  std::vector<int> idx = in.idx;
  loopSubdivide(P, idx, levels);
  ASSERT_EQ(idx, ref.idx);
  ASSERT_EQ(P.size(), ref.P.size());
  for (size_t i = 0; i < P.size(); ++i) {
    // Same rules, same summation order: bit-identical.
    EXPECT_EQ(P[i].x, ref.P[i].x) << i;
    EXPECT_EQ(P[i].y, ref.P[i].y) << i;
    EXPECT_EQ(P[i].z, ref.P[i].z) << i;
  }
}

TEST(LoopSubdivision, MatchesAnIndependentImplementationBitForBit) {
  for (int levels = 0; levels <= 3; ++levels) {
    SCOPED_TRACE(levels);
    expectSame(tetrahedron(), levels);
    expectSame(cube(), levels);
    expectSame(grid(5, false), levels);
    expectSame(grid(6, true), levels);
    expectSame(nonManifold(), levels);
  }
}

// Euler characteristic V - E + F is a topological invariant; each level gives V' = V + E,
// F' = 4F (E counted as the unique edges of the triangle list).
TEST(LoopSubdivision, KeepsTheEulerCharacteristic) {
  auto euler = [](const std::vector<Vec3>& P, const std::vector<int>& idx, long& E) {
    std::set<std::pair<int, int>> edges;
    for (size_t f = 0; f < idx.size(); f += 3)
      for (int k = 0; k < 3; ++k) {
        int a = idx[f + size_t(k)], b = idx[f + size_t((k + 1) % 3)];
        edges.insert({std::min(a, b), std::max(a, b)});
      }
    E = long(edges.size());
    return long(P.size()) - E + long(idx.size() / 3);
  };
  // Closed surfaces of genus 0 have chi = 2, a disk chi = 1.
  for (auto [m, expected] : {std::pair{tetrahedron(), 2L}, {cube(), 2L}, {grid(4, true), 1L}}) {
    long E0 = 0;
    const long chi = euler(m.P, m.idx, E0);
    EXPECT_EQ(chi, expected);
    std::vector<Vec3> P = m.P;
    std::vector<int> idx = m.idx;
    loopSubdivide(P, idx, 2);
    long E = 0;
    EXPECT_EQ(euler(P, idx, E), chi);
    const long V1 = long(m.P.size()) + E0, F1 = long(m.idx.size() / 3) * 4,
               E1 = 2 * E0 + 3 * long(m.idx.size() / 3);
    EXPECT_EQ(long(P.size()), V1 + E1);
    EXPECT_EQ(long(idx.size() / 3), 4 * F1);
  }
}

// Closed forms: Loop's weights sum to one, so a planar mesh stays in its plane; on a regular
// grid of the plane z = 0.3x - 0.2y + 1 every limit position lies on the plane, and an interior
// vertex of valence 6 whose ring is symmetric about it keeps its position.
TEST(LoopSubdivision, ReproducesAPlane) {
  Mesh m = grid(4, false);
  for (Vec3& p : m.P) p.z = 0.3 * p.x - 0.2 * p.y + 1;
  std::vector<Vec3> P = m.P;
  std::vector<int> idx = m.idx;
  loopSubdivide(P, idx, 3);
  for (const Vec3& p : P) EXPECT_NEAR(p.z, 0.3 * p.x - 0.2 * p.y + 1, 1e-12);
  // Vertex (2, 2) of the 4 x 4 grid is interior with the symmetric ring (±1, 0), (0, ±1),
  // ±(1, 1); after subdivision and the limit rule it stays at (2, 2).
  EXPECT_NEAR(P[12].x, 2, 1e-12);
  EXPECT_NEAR(P[12].y, 2, 1e-12);
}

}  // namespace
}  // namespace lensim::scene
