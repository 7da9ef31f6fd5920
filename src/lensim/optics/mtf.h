// Modulation transfer function of a focused lens: diffraction MTF from the pupil function
// (wavefront.h: FFT of the complex pupil -> PSF -> FFT -> OTF) and geometric MTF from the spot
// (the Fourier transform of the ray hits), sagittal and tangential, per field, polychromatic by
// weighted wavelengths; the diffraction limit of the real on-axis cone for reference; and the
// through-focus MTF at one frequency.
//
// Directions: a field's chief ray lies in the x-z (meridional) plane. Tangential MTF: frequency
// along x (bars perpendicular to the meridional plane); sagittal: along y.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/field_rays.h"

namespace lensim::optics {

struct MtfOptions {
  std::vector<double> fields{0, 0.7, 1};  ///< fractions of the film half-diagonal
  double max_frequency = 0;               ///< cycles/mm; 0: the diffraction cutoff
  int samples = 101;                      ///< frequencies from 0 to max_frequency
  bool geometric = true;
  bool diffraction = true;
  int pupil_cells = 0;  ///< 0: automatic (256, or 512 where W changes by > 1/4 wave a cell)
  int spot_rings = 64;  ///< hexapolar rings of the geometric MTF's spot (12,481 rays)
};

struct MtfField {
  double field_fraction = 0, film_height_mm = 0, field_angle_deg = 0;
  std::vector<double> diffraction_tangential, diffraction_sagittal;
  std::vector<double> geometric_tangential, geometric_sagittal;
  int pupil_cells = 0;       ///< of the primary wavelength
  double strehl = 0;         ///< weighted over the wavelengths
  double rms_opd_waves = 0;  ///< primary wavelength
  long rays = 0;             ///< rays traced for this field (all wavelengths, both MTFs)
};

struct MtfData {
  std::vector<WeightedWavelength> wavelengths;
  std::vector<double> frequency;          ///< cycles/mm
  std::vector<double> diffraction_limit;  ///< aberration-free MTF of the on-axis real cone
  double image_space_na = 0;              ///< n' sin u of the forward beam's marginal ray
  double working_f_number = 0;            ///< 1 / (2 NA)
  double cutoff = 0;                      ///< 2 NA / lambda (primary wavelength), cycles/mm
  std::vector<MtfField> fields;           ///< fields without a chief ray are left out
};

MtfData computeMtf(const SpectralLens& lens, double film_diagonal_mm, const MtfOptions& opts);

/// Through-focus diffraction MTF at one frequency: the film moved by `defocus` (mm, + away from
/// the lens) about its position, the object fixed.
struct ThroughFocusData {
  double frequency = 0;
  std::vector<double> defocus_mm;
  std::vector<MtfField> fields;  ///< diffraction_* hold one value per defocus
  std::vector<WeightedWavelength> wavelengths;
};

/// range_mm: half-width of the defocus range; 0 picks the larger of 12 lambda N^2, 0.02 mm and
/// the defocus that blurs a point into 3 axial RMS spot radii (6 N rms).
/// Each wavelength's pupil is traced once (fixed object, nominal film); a film shift dz advances
/// each plane wave of the angular spectrum by n' gamma dz (Debye), exact for a moving film.
/// pupil_cells 0: automatic, refined (to 512) until the wavefront plus the largest defocus
/// term is not aliased.
ThroughFocusData computeThroughFocusMtf(const SpectralLens& lens, double film_diagonal_mm,
                                        const std::vector<double>& fields, double frequency,
                                        double range_mm = 0, int steps = 31, int pupil_cells = 0);

std::string mtfSvg(const FocusedLens& lens, const MtfData& d);
std::string throughFocusSvg(const FocusedLens& lens, const ThroughFocusData& d);

/// "name · f/N · focus ..." shared by the analyses' titles.
std::string analysisSubtitle(const FocusedLens& lens, const std::vector<WeightedWavelength>& wl);

}  // namespace lensim::optics
