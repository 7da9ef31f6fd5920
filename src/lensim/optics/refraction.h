// Snell's law in vector form, shared by the coaxial tracers (lens_system.cpp) and the
// non-coaxial one (placed_lens.cpp).
#pragma once

#include <algorithm>
#include <cmath>

#include "lensim/util/vec.h"

namespace lensim::optics {

// Refracts unit direction d at a surface with unit normal n (either orientation), going from
// index eta_i to eta_t. Returns false on total internal reflection.
// sin2_out: where given, receives sin^2 of the refracted angle (>= 1: total internal
// reflection); left alone between equal indices.
template <typename T>
[[gnu::always_inline]] inline bool refract(Vec3T<T>& d, Vec3T<T> n, T eta_i, T eta_t,
                                           T* sin2_out = nullptr) {
  if (eta_i == eta_t) return true;
  T cos_i = -dot(n, d);
  if (cos_i < 0) {  // make the normal face the incoming ray
    n = -n;
    cos_i = -cos_i;
  }
  T eta = eta_i / eta_t;
  T sin2_t = eta * eta * std::max(T(0), T(1) - cos_i * cos_i);
  if (sin2_out) *sin2_out = sin2_t;
  if (sin2_t >= T(1)) return false;
  T cos_t = std::sqrt(T(1) - sin2_t);
  // Unit length for unit d and n (|eta d_tangential|^2 + cos_t^2 = 1); not renormalised.
  d = d * eta + n * (eta * cos_i - cos_t);
  return true;
}

}  // namespace lensim::optics
