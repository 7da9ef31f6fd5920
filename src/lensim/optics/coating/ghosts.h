// Two-reflection ghosts of a lens: for every pair of surfaces a < b, the light of an axial point
// at infinity that reflects at b (going back toward the scene) and then at a (going toward the
// film again) forms a ghost image. Its geometry is traced paraxially (the y-nu trace of
// paraxial.h, with the signed indices of mirrors at the two reflections: the first-order ghost
// matrices of Lee & Eisemann 2013), its energy from the coatings' reflectance and transmittance
// at normal incidence (lens_coatings.h).
#pragma once

#include <span>
#include <vector>

#include "lensim/optics/coating/lens_coatings.h"

namespace lensim::optics {

class LensSystem;

/// One ghost: reflection first at surface b, then at surface a (a < b).
struct Ghost {
  int a = 0, b = 0;
  /// Its energy relative to the direct image's (both for the same axial point at infinity),
  /// averaged over the wavelengths; includes the clear apertures' clipping of its beam.
  double relative_intensity = 0;
  /// Per wavelength (in the order given).
  std::vector<double> relative_intensity_per_wavelength;
  /// The fraction of the entrance beam's area that the clear apertures let through the ghost
  /// path (the paraxial beam's radius limited on every pass, squared).
  double aperture_fraction = 0;
  /// Where the ghost focuses (lens space z, mm); infinite when its beam leaves collimated.
  double focus_z_mm = 0;
  /// Focus minus film z (mm; + behind the film).
  double defocus_mm = 0;
  /// Diameter of the ghost's disc on the film (mm).
  double film_diameter_mm = 0;
};

struct GhostAnalysis {
  /// The direct image's transmittance per wavelength (reflection losses only).
  std::vector<double> direct_transmittance;
  std::vector<double> wavelengths_nm;
  /// Every two-reflection ghost, brightest first (C(N,2) pairs of the surfaces that reflect).
  std::vector<Ghost> ghosts;
};

/// The ghosts of an axial point at infinity at the given wavelengths (their mean intensity
/// ranks them); geometry at the lens's current wavelength. Throws lensim::Error for a lens with
/// mirrors (ghosts of catadioptric lenses are not modelled).
GhostAnalysis analyseGhosts(const LensSystem& lens, const LensCoatings& coatings,
                            std::span<const double> wavelengths_nm);

}  // namespace lensim::optics
