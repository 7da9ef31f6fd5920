// Aberration and performance data of a focused lens, and their plots (SVG):
// spot diagrams, distortion, relative illumination (vignetting) and the focus curve.
// Every computation uses the exact tracer; the numbers are returned so callers (and tests) can
// check them, and the SVG is drawn from the same numbers.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/focus.h"

namespace lensim::optics {

/// Spot diagram of one field: where the rays from one object point meet the film.
struct SpotField {
  double film_height_mm = 0;    ///< target image height (chief ray on the film)
  double field_angle_deg = 0;   ///< chief ray angle in object space
  std::vector<Vec2> points_mm;  ///< film-plane hits (x, y) relative to the centroid, all rays
  /// Indices into points_mm of a coarser hexapolar pattern (every `step`-th ring and ray), for
  /// drawing: the full set is thousands of points.
  std::vector<int> display;
  Vec2 centroid_mm;  ///< centroid on the film
  double rms_radius_mm = 0;
  int rays_traced = 0;
  int rings = 0;  ///< hexapolar rings across the pupil circle
};

/// Spot diagrams at fractions of the film half-diagonal, for the lens's current focus and stop.
/// The rays sample the region of the entrance pupil that gets through (its boundary bisected in
/// 256 directions) on hexapolar rings mapped onto it, each ray weighted by its share of the area
/// (field_rays.h: hexapolarPupil; 3 rings (rings + 1) rays), so that the centroid and RMS radius
/// converge (tests/optics_analysis_test.cpp: 48 rings are within 0.5% of 192; measured within
/// 0.06% on the ISET double Gauss and wide-angle, and 12 rings within 0.1%).
/// Fields that have no chief ray (outside the image circle) are left out.
std::vector<SpotField> computeSpots(const FocusedLens& lens, const std::vector<double>& fields,
                                    double film_diagonal_mm, int rings = 48);

/// Chief-ray image height against field angle, with the projection models.
struct DistortionData {
  std::vector<double> angle_deg;
  std::vector<double> height_mm;    ///< real chief ray on the film
  double f_reference_mm = 0;        ///< h / tan(theta) in the small-angle limit on this film
  std::vector<double> percent_tan;  ///< 100 (h - f tan) / (f tan)
  std::vector<double> percent_equidistant;  ///< relative to f theta
  std::vector<double> percent_equisolid;    ///< relative to 2 f sin(theta / 2)
};

/// Distortion from 0 to the field angle of the film corner (or the edge of the image circle).
DistortionData computeDistortion(const FocusedLens& lens, double film_diagonal_mm,
                                 int samples = 60);

/// Relative illumination across the film radius, each curve 1 at the centre.
struct VignettingData {
  std::vector<double> film_radius_mm;
  std::vector<double> unobstructed;           ///< share of the pupil region rays get through
  std::vector<double> cos4;                   ///< cos^4 of the chief ray angle at the film
  std::vector<double> relative_illumination;  ///< traced, each ray weighted by cos^4 / z^2
};

/// For each film radius, integrates the region of the rear-vertex plane through which rays get
/// through (polar integration about its centre, boundary by bisection along `grid` * 2
/// directions).
VignettingData computeVignetting(const FocusedLens& lens, double film_diagonal_mm, int samples = 40,
                                 int grid = 90);

/// Film distance against focus distance, both methods.
struct FocusCurve {
  std::vector<double> focus_distance_m;
  std::vector<double> film_distance_thick_mm;
  std::vector<double> film_distance_exact_mm;
  double infinity_thick_mm = 0, infinity_exact_mm = 0;  ///< exact: NaN if it has no solution
  double closest_m = 0;
};

/// From just beyond the closest focus to 1000 focal lengths, log spaced.
FocusCurve computeFocusCurve(const FocusedLens& lens, int samples = 48);

std::string spotSvg(const FocusedLens& lens, const std::vector<SpotField>& spots);
std::string distortionSvg(const FocusedLens& lens, const DistortionData& d, bool fisheye_models);
std::string vignettingSvg(const FocusedLens& lens, const VignettingData& v);
std::string focusSvg(const FocusedLens& lens, const FocusCurve& c);

}  // namespace lensim::optics
