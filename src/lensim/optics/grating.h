// The vector grating equation: a ray through a ruled diffraction grating (LensSurface::grating),
// for the non-coaxial tracer (placed_lens.cpp).
//
// A grating whose lines are the traces of equally spaced planes y = k d (local frame) adds the
// phase 2 pi m y / d; along the surface its gradient is (2 pi m / d) q with q = y - (y . N) N,
// local y projected into the tangent plane at the hit point (unit normal N). Phase matching
// across the surface gives, for unit directions s (in, index n) and s' (out, index n'),
//   n' (s' - (s' . N) N) = n (s - (s . N) N) + (m lambda / d) q,
// the tangential part; the normal part follows from |s'| = 1: s' . N keeps the sign of s . N
// when the ray is transmitted and flips when it is reflected (then n' = n). With m = 0 this is
// Snell's law or the law of reflection. When the tangential part is longer than n' the order is
// evanescent: no ray leaves.
#pragma once

#include <cmath>

#include "lensim/util/vec.h"

namespace lensim::optics {

/// Diffracts the unit direction d at a grating point with unit normal n (either orientation) and
/// the grating's ruling axis y (unit, local y: the lines run along local x). k = order *
/// wavelength_um * lines_per_um. eta_i, eta_t: the indices before and after (a reflecting
/// grating: both the index it sits in). Returns false for an evanescent order (d unchanged).
inline bool diffract(Vec3& d, Vec3 n, const Vec3& y, double eta_i, double eta_t, double k,
                     bool reflect) {
  if (dot(d, n) < 0) n = -n;  // the normal along the direction of travel
  const Vec3 q = y - n * dot(y, n);
  const Vec3 tangential = (d - n * dot(d, n)) * eta_i + q * k;
  const double eta_out = reflect ? eta_i : eta_t;
  const double sin2 = dot(tangential, tangential) / (eta_out * eta_out);
  if (!(sin2 < 1)) return false;
  const double cos_out = std::sqrt(1 - sin2);
  d = tangential * (1 / eta_out) + n * (reflect ? -cos_out : cos_out);
  return true;
}

}  // namespace lensim::optics
