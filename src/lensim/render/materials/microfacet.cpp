#include "lensim/render/materials/microfacet.h"

#include "lensim/sampling/sampling.h"

namespace lensim::render {

using namespace lensim::sampling;

TrowbridgeReitz::TrowbridgeReitz(double alpha_x, double alpha_y)
    : ax_(std::max(alpha_x, 0.0)), ay_(std::max(alpha_y, 0.0)) {
  // Keep the numerically unstable region out of rough evaluation (the smooth path is used
  // below 1e-3 anyway).
  if (!effectivelySmooth()) {
    ax_ = std::max(ax_, 1e-4);
    ay_ = std::max(ay_, 1e-4);
  }
}

double TrowbridgeReitz::D(const Vec3& wm) const {
  const double t2 = tan2Theta(wm);
  if (std::isinf(t2) || std::isnan(t2)) return 0.0;
  const double cos4 = cos2Theta(wm) * cos2Theta(wm);
  if (cos4 < 1e-16) return 0.0;
  const double cp = cosPhi(wm), sp = sinPhi(wm);
  const double e = t2 * (cp * cp / (ax_ * ax_) + sp * sp / (ay_ * ay_));
  return 1.0 / (kPi * ax_ * ay_ * cos4 * (1 + e) * (1 + e));
}

double TrowbridgeReitz::lambda(const Vec3& w) const {
  const double t2 = tan2Theta(w);
  if (std::isinf(t2) || std::isnan(t2)) return 0.0;
  const double cp = cosPhi(w), sp = sinPhi(w);
  const double alpha2 = cp * cp * ax_ * ax_ + sp * sp * ay_ * ay_;
  return (std::sqrt(1 + alpha2 * t2) - 1) / 2;
}

double TrowbridgeReitz::D(const Vec3& w, const Vec3& wm) const {
  const double c = absCosTheta(w);
  if (c == 0) return 0.0;
  return G1(w) / c * D(wm) * std::abs(dot(w, wm));
}

Vec3 TrowbridgeReitz::sampleWm(const Vec3& w, Vec2 u) const {
  // Stretch the view direction to the hemisphere configuration (alpha = 1).
  Vec3 wh = normalize(Vec3(ax_ * w.x, ay_ * w.y, w.z));
  if (wh.z < 0) wh = -wh;
  // Orthonormal basis around wh.
  const Vec3 t1 = wh.z < 0.99999 ? normalize(cross(Vec3(0, 0, 1), wh)) : Vec3(1, 0, 0);
  const Vec3 t2 = cross(wh, t1);
  // Uniform disk point, warped to the projected visible hemisphere.
  const double r = std::sqrt(u.x), phi = 2 * kPi * u.y;
  double px = r * std::cos(phi), py = r * std::sin(phi);
  const double h = std::sqrt(std::max(0.0, 1 - px * px));
  const double s = 0.5 * (1 + wh.z);
  py = (1 - s) * h + s * py;
  const double pz = std::sqrt(std::max(0.0, 1 - px * px - py * py));
  const Vec3 nh = t1 * px + t2 * py + wh * pz;
  // Unstretch.
  return normalize(Vec3(ax_ * nh.x, ay_ * nh.y, std::max(1e-6, nh.z)));
}

}  // namespace lensim::render
