// Shared by the engineer's analyses (spots, MTF, PSF, ray fans, field curves): the wavelengths
// and their weights, the lens system to trace at each wavelength, and the bundle of rays from one
// object point (a field), aimed across the entrance pupil.
//
// Wavelengths: every analysis takes a list of wavelengths in nanometres with weights and asks
// `SpectralLens::at(nm)` for the system to trace: `spectral()` gives each wavelength the system
// with its glasses' indices at that wavelength (same stop and film plane); a non-dispersive lens
// traces the same system at every wavelength.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/focus.h"

namespace lensim::optics {

/// The d line (helium, 587.56 nm): the default design wavelength.
inline constexpr double kDLineNm = 587.56;

struct WeightedWavelength {
  double nm = kDLineNm;
  double weight = 1;
};

/// A focused lens and how to get the system to trace at a wavelength.
struct SpectralLens {
  const FocusedLens* focused = nullptr;
  std::vector<WeightedWavelength> wavelengths{{kDLineNm, 1}};
  /// The system at a wavelength (nm); empty: the focused lens's system at every wavelength.
  std::function<const LensSystem&(double nm)> lens_for;

  const LensSystem& at(double nm) const { return lens_for ? lens_for(nm) : *focused->lens; }
  /// The wavelength with the largest weight: its chief ray defines each field's image point.
  double primaryNm() const;
};

/// A SpectralLens tracing the focused lens at every wavelength.
SpectralLens monochromatic(const FocusedLens& fl,
                           const std::vector<WeightedWavelength>& wl = {{kDLineNm, 1}});

/// A SpectralLens tracing, at each wavelength, the focused lens with its glasses' indices at that
/// wavelength (LensSystem::atWavelength; same film). Non-dispersive lenses: as monochromatic().
SpectralLens spectral(const FocusedLens& fl, const std::vector<WeightedWavelength>& wl);

/// Parses "587.56" or "486.13:1,587.56:2,656.27:1" (nm, optional weights). Throws lensim::Error.
std::vector<WeightedWavelength> parseWavelengths(const std::string& text,
                                                 const std::string& option);

/// The rays from one object point: the real chief ray of the primary wavelength from a film
/// point, the object point on it at the focus distance (or a parallel bundle from infinity),
/// and rays toward points of the entrance-pupil plane.
class FieldBundle {
 public:
  /// nullopt when the film point has no chief ray (outside the image circle).
  static std::optional<FieldBundle> fromFilmHeight(const FocusedLens& fl, const LensSystem& lens,
                                                   double film_height_mm);

  /// The ray from the object toward the entrance-pupil plane point pupil_centre + offset.
  Ray sceneRay(Vec2 offset_mm) const;
  /// Where a traced ray meets the plane z = film_z (nullopt: blocked or not toward the film).
  static std::optional<Vec2> hitPlane(const LensSystem& lens, const Ray& scene_ray,
                                      double film_z_mm, Vec3* direction = nullptr);

  /// A circle on the entrance-pupil plane (centre offset, radius) containing every point whose
  /// ray gets through `lens`: the boundary is bisected along 64 directions from a passing point,
  /// then widened by 3%. nullopt if no ray gets through.
  std::optional<std::pair<Vec2, double>> pupilCircle(const LensSystem& lens) const;

  /// The region of the entrance-pupil plane whose rays get through `lens`, as seen from a point
  /// inside it: the boundary distance along `directions` equally spaced azimuths (bisection).
  struct PupilRegion {
    Vec2 centre;
    std::vector<double> radius;
    /// Boundary distance at azimuth phi (linear interpolation between the directions).
    double radiusAt(double phi) const;
  };
  std::optional<PupilRegion> pupilRegion(const LensSystem& lens, int directions = 256) const;

  double film_height_mm = 0;   ///< of the chief ray on the nominal film
  double field_angle_deg = 0;  ///< chief ray angle in object space
  Ray chief_scene;             ///< entering the lens (toward +z), through the stop centre
  Vec3 pupil_centre;           ///< chief ray on the paraxial entrance-pupil plane
  std::optional<Vec3> object;  ///< object point; nullopt: at infinity
  double pupil_radius_mm = 0;  ///< paraxial entrance-pupil radius
};

/// A point of the entrance-pupil plane with its share of the pupil's area.
struct PupilPoint {
  Vec2 offset_mm;  ///< from the bundle's pupil centre
  double weight = 0;
  int ring = 0, index = 0;
};

/// Hexapolar sampling of a pupil region mapped onto a unit disc (radius r at azimuth phi goes to
/// r R(phi)): `rings` rings at the Gauss-Legendre nodes in radius, ring k (innermost 1) with 6k
/// points, each weighted by its share of the ring's quadrature weight times R(phi)^2 (the
/// mapping's area element). Equally weighted points on rings out to the rim over-weight the rim
/// (an error of order 1/rings, the 6% of a 48x48 square grid); this quadrature is exact in
/// radius for polynomial aberrations of degree < 2 rings. 3 rings (rings + 1) points.
std::vector<PupilPoint> hexapolarPupil(const FieldBundle::PupilRegion& region, int rings);

/// Film-plane point where the chief ray of the bundle meets z = film_z (the image point that
/// spots, PSFs and fans are measured from).
std::optional<Vec2> chiefImagePoint(const LensSystem& lens, const FieldBundle& b, double film_z_mm);

}  // namespace lensim::optics
