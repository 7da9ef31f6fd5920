// Loop subdivision (Loop 1987) of triangle meshes, as pbrt's `loopsubdiv` shape defines it.
#pragma once

#include <vector>

#include "lensim/util/vec.h"

namespace lensim::scene {

/// Subdivides the triangle mesh (positions P, three indices a triangle) `levels` times, then
/// moves every vertex to its limit position as pbrt does. Interior vertices use Loop's rules
/// (beta = 3/16 for valence 3, else 3/(8n)); boundary vertices and edges follow the cubic
/// B-spline rules; vertices with other than two boundary neighbours keep their position.
/// Normals are not computed.
///
/// Numbering: the old vertices keep their indices; the new vertex of each edge follows, in
/// the order of the edges' (smaller index, larger index) pairs; each triangle (v0 v1 v2)
/// becomes (v0 e01 e20) (v1 e12 e01) (v2 e20 e12) (e01 e12 e20). Neighbour sums run in
/// ascending vertex index, so the result is deterministic.
///
/// The topology is kept in flat arrays (edges found by a counting sort on their smaller
/// vertex); figures in docs/performance.md.
void loopSubdivide(std::vector<Vec3>& P, std::vector<int>& idx, int levels);

}  // namespace lensim::scene
