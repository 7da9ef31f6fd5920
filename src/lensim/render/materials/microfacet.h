// Trowbridge-Reitz (GGX) microfacet distribution with visible-normal sampling.
//
// Directions live in the local shading frame (+z = shading normal). References:
// Trowbridge & Reitz 1975; Walter et al. 2007 ("Microfacet models for refraction through rough
// surfaces"); Heitz 2014 ("Understanding the masking-shadowing function"); Heitz 2018
// ("Sampling the GGX distribution of visible normals", JCGT 7(4)).
#pragma once

#include <algorithm>
#include <cmath>

#include "lensim/util/vec.h"

namespace lensim::render {

/// Local-frame trigonometry of a unit direction w (z = normal).
inline double cosTheta(const Vec3& w) {
  return w.z;
}
inline double cos2Theta(const Vec3& w) {
  return w.z * w.z;
}
inline double absCosTheta(const Vec3& w) {
  return std::abs(w.z);
}
inline double sin2Theta(const Vec3& w) {
  return std::max(0.0, 1.0 - cos2Theta(w));
}
inline double sinTheta(const Vec3& w) {
  return std::sqrt(sin2Theta(w));
}
inline double tan2Theta(const Vec3& w) {
  return sin2Theta(w) / cos2Theta(w);
}
inline double cosPhi(const Vec3& w) {
  const double s = sinTheta(w);
  return s == 0 ? 1.0 : std::clamp(w.x / s, -1.0, 1.0);
}
inline double sinPhi(const Vec3& w) {
  const double s = sinTheta(w);
  return s == 0 ? 0.0 : std::clamp(w.y / s, -1.0, 1.0);
}
inline bool sameHemisphere(const Vec3& a, const Vec3& b) {
  return a.z * b.z > 0;
}

/// pbrt-v4's roughness remapping ("remaproughness"): alpha = sqrt(roughness).
inline double roughnessToAlpha(double roughness) {
  return std::sqrt(std::max(0.0, roughness));
}

/// Anisotropic Trowbridge-Reitz distribution with widths alpha_x, alpha_y (unitless).
class TrowbridgeReitz {
 public:
  TrowbridgeReitz(double alpha_x, double alpha_y);
  /// True when the surface is so smooth it is treated as a perfect specular interface.
  bool effectivelySmooth() const { return std::max(ax_, ay_) < 1e-3; }
  /// Microfacet normal density D(wm) (sr^-1, projected: integral of D cos = 1).
  double D(const Vec3& wm) const;
  /// Smith's auxiliary Lambda(w), masking G1(w), and height-correlated masking-shadowing G.
  double lambda(const Vec3& w) const;
  double G1(const Vec3& w) const { return 1.0 / (1.0 + lambda(w)); }
  double G(const Vec3& wo, const Vec3& wi) const { return 1.0 / (1.0 + lambda(wo) + lambda(wi)); }
  /// Density of normals visible from w: G1(w) max(0, w.wm) D(wm) / |cos theta(w)| (sr^-1).
  double D(const Vec3& w, const Vec3& wm) const;
  /// Pdf of sampleWm (the visible-normal density).
  double pdf(const Vec3& w, const Vec3& wm) const { return D(w, wm); }
  /// Samples a visible microfacet normal for direction w (Heitz 2018); u in [0,1)^2.
  Vec3 sampleWm(const Vec3& w, Vec2 u) const;

 private:
  double ax_, ay_;
};

}  // namespace lensim::render
