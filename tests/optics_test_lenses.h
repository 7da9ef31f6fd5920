// Synthetic lenses shared by the optics tests.
#pragma once

#include "lensim/optics/prescription.h"

namespace lensim::test {

/// Plano-convex singlet, flat side to the scene: a plane at z = 0, then 5 mm of glass of index n
/// and a convex back surface of vertex radius -20 mm (centre toward the scene) with conic k, both
/// of clear diameter `aperture_mm`. Collimated light enters the flat face undeviated; a conic of
/// eccentricity e = n (k = -n^2) refracting from glass into air focuses it to one point
/// (Descartes), at f = |R| / (n - 1) behind the back vertex; the sphere (k = 0) has spherical
/// aberration.
inline optics::LensPrescription planoConvexConic(double conic, double n, double aperture_mm) {
  optics::LensPrescription p;
  p.path = "plano-convex";
  p.format = "lensim-json";
  optics::LensSurface a;
  a.radius_mm = 0;
  a.stop_flag = false;
  a.thickness_mm = 5;
  a.ior = n;
  a.aperture_diameter_mm = aperture_mm;
  optics::LensSurface b;
  b.radius_mm = -20;
  b.stop_flag = false;
  b.thickness_mm = 40;
  b.ior = 1;
  b.aperture_diameter_mm = aperture_mm;
  b.shape.conic = conic;
  p.surfaces = {a, b};
  return p;
}

}  // namespace lensim::test
