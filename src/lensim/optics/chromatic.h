// Chromatic aberration on the workbench: the lens at other wavelengths, longitudinal colour
// (best focus against wavelength), lateral colour (image height at F and C minus d against
// field) and spot diagrams per wavelength, with their plots (SVG).
//
// The lens stays focused where it was set up (focus is solved at the primary wavelength); at
// another wavelength only the indices change (LensSystem::atWavelength), so the film and stop
// are the same and every difference is the glass's dispersion.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/focus.h"
#include "lensim/optics/plots.h"

namespace lensim::optics {

/// The focused lens at another wavelength: same film position, stop and focus distance; the
/// indices and the paraxial data at lambda_nm.
FocusedLens focusedAtWavelength(const FocusedLens& fl, double lambda_nm);

/// Longitudinal colour: where the image of the focused object lies at each wavelength, as film
/// distances behind the rear vertex (mm), paraxial (thick-lens, from the cardinal points at
/// that wavelength) and real (the plane of the smallest RMS spot of the axial bundle).
struct ChromaticFocus {
  std::vector<double> wavelength_nm;
  std::vector<double> paraxial_mm;  ///< film distance of the paraxial image
  std::vector<double> real_mm;      ///< film distance of the real best focus (NaN: none)
  double primary_nm = 0;
  double paraxial_primary_mm = 0, real_primary_mm = 0;
  double paraxial_F_mm = 0, paraxial_C_mm = 0;  ///< at the F and C lines
};
ChromaticFocus computeChromaticFocus(const FocusedLens& fl, double from_nm = 400,
                                     double to_nm = 700, int samples = 31);

/// Lateral colour: the real chief ray's image height on the film at a short and a long
/// wavelength (default F and C) minus that at the primary wavelength, against field angle.
struct LateralColor {
  double short_nm = kLineF_nm, long_nm = kLineC_nm, primary_nm = kLineD_nm;
  std::vector<double> field_deg;
  std::vector<double> height_primary_mm;
  std::vector<double> short_minus_primary_mm;
  std::vector<double> long_minus_primary_mm;
};
/// From 0 to the field angle of the film corner (or the edge of the image circle).
LateralColor computeLateralColor(const FocusedLens& fl, double film_diagonal_mm, int samples = 30,
                                 double short_nm = kLineF_nm, double long_nm = kLineC_nm);
/// The image height (mm) of the real chief ray at field angle `field_deg` at the wavelength;
/// NaN if there is none.
double chiefRayHeightAt(const FocusedLens& fl, double field_deg, double lambda_nm);

/// Spot diagrams of one object point at several wavelengths: the object point is the primary
/// wavelength's (the chief ray to the field's film height); the spots are relative to the
/// primary wavelength's centroid, so lateral colour shows as shifted spots.
struct ColorSpotField {
  double film_height_mm = 0, field_angle_deg = 0;
  std::vector<double> wavelength_nm;
  std::vector<std::vector<Vec2>> points_mm;  ///< per wavelength, relative to the primary centroid
  std::vector<Vec2> centroid_mm;             ///< per wavelength, on the film
  std::vector<double> rms_radius_mm;         ///< per wavelength, about its own centroid
};
std::vector<ColorSpotField> computeSpotsAtWavelengths(const FocusedLens& fl,
                                                      const std::vector<double>& fields,
                                                      double film_diagonal_mm,
                                                      const std::vector<double>& wavelengths_nm,
                                                      int grid = 40);

/// An sRGB colour ("#rrggbb") that stands for a visible wavelength on plots.
std::string wavelengthColor(double lambda_nm);

std::string chromaticFocusSvg(const FocusedLens& fl, const ChromaticFocus& c);
std::string lateralColorSvg(const FocusedLens& fl, const LateralColor& c);
std::string colorSpotSvg(const FocusedLens& fl, const std::vector<ColorSpotField>& spots);

}  // namespace lensim::optics
