// Paths of the data the tests use.
#pragma once

#include <cmath>
#include <string>

#include "lensim/optics/lens_system.h"

namespace lensim::test {

/// A lens shipped in the repository's lenses/ folder.
inline std::string lensPath(const std::string& name) {
  return std::string(LENSIM_SOURCE_DIR) + "/lenses/" + name;
}
/// A file under tests/data/.
inline std::string dataPath(const std::string& name) {
  return std::string(LENSIM_SOURCE_DIR) + "/tests/data/" + name;
}
/// The four classic lenses of the assignment.
inline const char* const kClassicLenses[] = {"dgauss.50mm.dat", "fisheye.10mm.dat", "wide.22mm.dat",
                                             "telephoto.250mm.dat"};

/// sin of the half-angle of the cone of real rays that reach the film centre through the lens:
/// the marginal ray found by bisection on its aim height at the rear-vertex plane.
inline double realMarginalSin(const optics::LensSystem& lens) {
  double lo = 0, hi = 1.5 * lens.interfaces().back().semi_aperture_mm;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (lens.traceFromFilmPoint({0, 0}, {mid, 0}).ok() ? lo : hi) = mid;
  }
  return lo / std::hypot(lo, lens.filmDistance_mm());
}

}  // namespace lensim::test
