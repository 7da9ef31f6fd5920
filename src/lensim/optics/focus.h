// Focusing: where the film must be for an object distance, and the inverse.
//
// Focus distances are measured from the film plane to the object, in metres, as in pbrt's
// `focusdistance` (scene units are metres). Film distances are measured from the rear vertex, in
// millimetres. Infinity is std::numeric_limits<double>::infinity().
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"

namespace lensim::optics {

/// How the film distance for a focus distance is found.
enum class FocusMethod {
  Thick,  ///< thick-lens approximation from the paraxial cardinal points (pbrt-v4 FocusThickLens)
  Exact,  ///< real rays: the film plane with the smallest RMS spot of an on-axis bundle
};

/// Parses "thick" or "exact"; throws lensim::Error otherwise.
FocusMethod parseFocusMethod(const std::string& name);
const char* focusMethodName(FocusMethod m);

/// The closest focus distance (metres, from the film) the thick-lens model allows: the object
/// and its image are then 2f from the principal planes (unit magnification).
double closestFocusDistance_m(const LensSystem& lens, const ParaxialData& p);

/// Film distance (mm from the rear vertex) that focuses objects at `focus_distance_m` (from the
/// film; may be infinity). Throws lensim::Error (naming the closest possible distance) when the
/// distance is closer than the lens can focus, or when the exact method finds no rays.
double filmDistanceForFocus(const LensSystem& lens, const ParaxialData& p, double focus_distance_m,
                            FocusMethod method);

/// The object distance (metres, from the film) in focus for a film distance (mm from the rear
/// vertex). Returns infinity when the film is at or inside the infinity focus.
double focusDistanceForFilm(const LensSystem& lens, const ParaxialData& p, double film_distance_mm,
                            FocusMethod method);

/// RMS radius (mm) of the spot of an on-axis bundle from an object at `focus_distance_m` (from
/// the film) on the current film plane; aimed across 1.25x the paraxial entrance pupil, so the
/// real aperture decides which rays get through. Returns NaN if no ray gets through.
double axialRmsSpot_mm(const LensSystem& lens, const ParaxialData& p, double focus_distance_m);

}  // namespace lensim::optics

namespace lensim::optics {

/// How to set up a lens: stop, and either a focus distance or a film distance (not both).
struct LensSetup {
  std::optional<double> aperture_diameter_mm;
  std::optional<double> focus_distance_m;  ///< from the film; may be infinity
  std::optional<double> film_distance_mm;  ///< from the rear vertex
  FocusMethod focus_method = FocusMethod::Thick;
};

/// A lens system with its film placed, its paraxial data, and the distance in focus.
struct FocusedLens {
  std::unique_ptr<LensSystem> lens;
  ParaxialData paraxial;
  double focus_distance_m = 0;  ///< infinity when focused at (or beyond) infinity

  /// The prescription's diagnostics followed by the lens system's.
  std::vector<Diagnostic> allDiagnostics() const;
};

/// Group focusing (LensPrescription::focus_group): the prescription with the group moved by
/// `shift_mm` so that an object `focus_distance_m` from the film is in focus (by `method`) on a
/// film that stays where the infinity focus puts it relative to the front vertex.
struct GroupFocus {
  LensPrescription prescription;
  double shift_mm = 0;
  double film_distance_mm = 0;  ///< from the rear vertex of the moved lens
};
/// Solves the group position by bisection over the range where every moved thickness stays >= 0.
/// Throws lensim::Error when no position in that range focuses the distance.
GroupFocus focusByGroup(const LensPrescription& p, const LensSetup& setup,
                        double focus_distance_m);

/// Floating focus (LensPrescription::floating_focus): the prescription with its moved gaps at
/// vergence parameter `u_dpt`, each piecewise linear between the file's positions. Throws
/// lensim::Error when u_dpt lies outside them.
LensPrescription atFloatingFocus(const LensPrescription& p, double u_dpt);
/// Solves the vergence parameter (returned in GroupFocus::shift_mm, in dioptres) so that an
/// object `focus_distance_m` from the film is in focus (by `method`) on the film the infinity
/// position focuses, by bisection over the file's range; refuses a distance outside it.
GroupFocus focusByFloatingFocus(const LensPrescription& p, const LensSetup& setup,
                                double focus_distance_m);

/// Builds and focuses a lens. A lens with a focus group focuses a finite focus distance by
/// moving the group (focusByGroup); others move the whole lens. With neither distance given: the file's film distance if it has
/// one (last row thickness > 0), else focus at infinity. Throws lensim::Error on bad settings.
FocusedLens focusLens(LensPrescription prescription, const LensSetup& setup);

}  // namespace lensim::optics
