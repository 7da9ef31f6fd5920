// Real chief rays: the exact ray through the centre of the aperture stop for a given film point
// or a given field angle. Distortion, field of view and lens diagrams use them.
#pragma once

#include <optional>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"

namespace lensim::optics {

/// A chief ray found by the exact tracer.
struct ChiefRay {
  Ray scene_ray;           ///< the ray on the scene side (leaving the front surface toward -z,
                           ///< or entering it toward +z), lens space
  Ray film_ray;            ///< the ray on the film side
  double field_angle_deg;  ///< angle of the scene-side ray to the axis
  double film_height_mm;   ///< height where the film-side ray meets the film plane
};

/// The chief ray from the film point (h, 0) (h >= 0, mm). Apertures are ignored, so the result
/// exists wherever the surfaces refract the ray through the stop centre; nullopt otherwise.
std::optional<ChiefRay> chiefRayFromFilm(const LensSystem& lens, const ParaxialData& p,
                                         double film_height_mm);

/// The chief ray of a parallel bundle from the scene at `field_angle_deg` (0 <= angle < 90): the
/// bundle travels in the x-z plane with direction (sin, 0, cos), i.e. it comes from an object on
/// the -x side, so a positive lens images it at +x. Apertures are ignored; nullopt if the
/// surfaces cannot bring such a ray through the stop centre.
std::optional<ChiefRay> chiefRayFromScene(const LensSystem& lens, const ParaxialData& p,
                                          double field_angle_deg);

/// A point on the rear-vertex plane toward which a ray from the film point (h, 0) gets through
/// every clear aperture: the real chief ray's crossing if it gets through, else the first of
/// grids over the exit pupil and over the rear element. nullopt: the film point sees nothing.
std::optional<Vec2> passingRearAim(const LensSystem& lens, const ParaxialData& p,
                                   double film_height_mm);
/// The same for any film point (x, y): the chief ray is tried only on the x axis (y = 0).
std::optional<Vec2> passingRearAim(const LensSystem& lens, const ParaxialData& p, Vec2 film_mm);

/// True if at least one ray from the film point (h, 0) gets through the lens.
bool filmPointSeesScene(const LensSystem& lens, const ParaxialData& p, double film_height_mm);
/// True if at least one ray from the film point (x, y) gets through the lens.
bool filmPointSeesScene(const LensSystem& lens, const ParaxialData& p, Vec2 film_mm);

/// Field of view for a film diagonal. A film point is inside the image circle when some ray from
/// it gets through the lens; its field angle is that of its chief ray (on the x axis). For a lens
/// that is not rotationally symmetric (anamorphic: symmetric under x -> -x and y -> -y) a film
/// radius is covered when the film points at azimuths 0, 15, .., 90 degrees all see the scene,
/// so that the image circle is the largest circle inside the image area, whose extent differs
/// along x and y.
struct FieldOfView {
  double paraxial_deg = 0;                         ///< 2 atan(diagonal / 2 / EFL)
  std::optional<double> real_deg;                  ///< from the real chief ray to the film corner
  std::optional<double> image_circle_diameter_mm;  ///< set when the corner sees nothing: the
                                                   ///< largest film circle that sees the scene
  std::optional<double> real_max_deg;              ///< the field angle at that image circle
};

FieldOfView fieldOfView(const LensSystem& lens, const ParaxialData& p, double film_diagonal_mm);

}  // namespace lensim::optics
