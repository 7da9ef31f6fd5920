// Rigid frames of a lens with tilted or decentred surfaces (SurfaceFrame, coordinate breaks): the
// 3x3 rotation arithmetic written once. A rotation is stored by rows; its columns are the turned
// frame's axes in the frame it is placed in.
#pragma once

#include <array>

#include "lensim/util/vec.h"

namespace lensim::optics::frame {

using V3 = std::array<double, 3>;
using M3 = std::array<V3, 3>;  // rows

/// m v.
inline V3 mul(const M3& m, const V3& v) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
          m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

/// a b.
inline M3 mul(const M3& a, const M3& b) {
  M3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
  return r;
}

inline M3 transpose(const M3& m) {
  return {V3{m[0][0], m[1][0], m[2][0]}, V3{m[0][1], m[1][1], m[2][1]},
          V3{m[0][2], m[1][2], m[2][2]}};
}

/// A vector given along a frame's axes, in the frame it is placed in: r v.
inline Vec3 toGlobal(const M3& r, const Vec3& v) {
  return {r[0][0] * v.x + r[0][1] * v.y + r[0][2] * v.z,
          r[1][0] * v.x + r[1][1] * v.y + r[1][2] * v.z,
          r[2][0] * v.x + r[2][1] * v.y + r[2][2] * v.z};
}

/// A vector's components along a frame's axes (r's columns): r^T v.
inline Vec3 toLocal(const M3& r, const Vec3& v) {
  return {r[0][0] * v.x + r[1][0] * v.y + r[2][0] * v.z,
          r[0][1] * v.x + r[1][1] * v.y + r[2][1] * v.z,
          r[0][2] * v.x + r[1][2] * v.y + r[2][2] * v.z};
}

}  // namespace lensim::optics::frame
