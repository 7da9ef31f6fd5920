// Equal-area octahedral mapping; see equal_area.h.
#include "lensim/sampling/equal_area.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace lensim::sampling {

Vec3 equalAreaSquareToSphere(Vec2 p) {
  const double u = 2 * p.x - 1, v = 2 * p.y - 1;
  const double up = std::abs(u), vp = std::abs(v);
  const double signed_distance = 1 - (up + vp);
  const double d = std::abs(signed_distance);
  const double r = 1 - d;
  const double phi = (r == 0 ? 1 : (vp - up) / r + 1) * M_PI / 4;
  const double z = std::copysign(1 - r * r, signed_distance);
  const double cos_phi = std::copysign(std::cos(phi), u);
  const double sin_phi = std::copysign(std::sin(phi), v);
  const double s = r * std::sqrt(std::max(0.0, 2 - r * r));
  return {cos_phi * s, sin_phi * s, z};
}

Vec2 equalAreaSphereToSquare(const Vec3& d) {
  const double x = std::abs(d.x), y = std::abs(d.y), z = std::abs(d.z);
  const double r = std::sqrt(std::max(0.0, 1 - z));
  const double a = std::max(x, y);
  double b = std::min(x, y);
  b = a == 0 ? 0 : b / a;
  double phi = std::atan(b) * 2 / M_PI;
  if (x < y) phi = 1 - phi;
  double v = phi * r;
  double u = r - v;
  if (d.z < 0) {
    std::swap(u, v);
    u = 1 - u;
    v = 1 - v;
  }
  u = std::copysign(u, d.x);
  v = std::copysign(v, d.y);
  return {(u + 1) / 2, (v + 1) / 2};
}

}  // namespace lensim::sampling
