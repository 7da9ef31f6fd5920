// Reader for PLY triangle/quad meshes: ASCII and binary (little and big endian), optionally
// gzip-compressed (`.ply.gz`), with optional normals and texture coordinates.
//
// Debian 12 packages no maintained C++ PLY library (`apt-cache search ply` finds only
// python3-rply), and the header-only ones (tinyply, happly, miniply) are not packaged, so lensim
// has its own small reader, tested in tests/io_ply_test.cpp.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::io {

/// A polygon mesh read from a PLY file, in the file's units and coordinates.
struct PlyMesh {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;             ///< empty or one per vertex
  std::vector<std::array<float, 2>> uvs;  ///< empty or one per vertex
  std::vector<int> triangles;             ///< 3 vertex indices per triangle
  std::vector<int> quads;         ///< 4 vertex indices per quad (pbrt-v4 bilinear patch order)
  std::vector<int> face_indices;  ///< optional per-face `face_indices` values
};

/// Reads a PLY file (gzip-compressed or not: detected from its content). Polygons with more than
/// four vertices are split into a triangle fan. Throws lensim::Error with the path on failure.
PlyMesh readPly(const std::string& path);

/// Parses PLY data already in memory; `name` is used in error messages.
PlyMesh parsePly(const std::string& data, const std::string& name);

}  // namespace lensim::io
