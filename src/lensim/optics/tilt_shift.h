// Tilt and shift: a lens placed on the film off its axis (shift) and turned against it (tilt),
// as on a tilt-shift lens or a view camera, and where such a film is sharp (Scheimpflug and
// Merklinger's hinge rule).
//
// Conventions (lens space, optics/lens_system.h: mm, +z from the scene toward the film). The
// film frame is the film's own: its origin at the film's centre, x and y along its edges, z
// along its normal, oriented as lens space is when nothing is tilted or shifted. The lens is
// first shifted by (shift_x, shift_y) in the film's plane, so its axis meets the film at that
// point, then turned about that point by the rotation R = Ry(tilt_y) Rx(tilt_x) (right-handed
// rotations about the film's x and y axes). So a film-frame point p maps to lens space as
//   p_lens = R^T (p - s) + (0, 0, z_film),   s = (shift_x, shift_y, 0),
// and the film's axial point stays where focusing put it: `focusdistance` sets the film
// distance along the lens axis, and the tilted plane of focus then follows from Scheimpflug.
// A positive tilt_x turns the lens axis (toward the scene) to +y of the film frame, a positive
// tilt_y to -x; the hinge line, and the near part of the plane of focus, lie on the side the
// axis is turned to (tilt the lens down, tilt_x < 0 with +y up, for a table or a street).
#pragma once

#include "lensim/optics/paraxial.h"
#include "lensim/util/vec.h"

namespace lensim::optics {

/// Where the lens sits against the film (see the file comment).
struct TiltShift {
  Vec2 tilt_deg{0, 0};  ///< rotation about the film's x axis, then about its y axis (degrees)
  Vec2 shift_mm{0, 0};  ///< the lens axis's meeting with the film, in film coordinates (mm)
  bool tilted() const { return tilt_deg.x != 0 || tilt_deg.y != 0; }
  bool shifted() const { return shift_mm.x != 0 || shift_mm.y != 0; }
  bool any() const { return tilted() || shifted(); }
};

/// The rigid map between the film frame and lens space for a TiltShift and a film whose axial
/// point lies at z_film (lens space).
class FilmPlacement {
 public:
  FilmPlacement() = default;
  FilmPlacement(const TiltShift& ts, double z_film_mm);
  /// Lens-space point of a film point (film-frame x, y; on the film, z = 0).
  Vec3 lensFromFilm(Vec2 film_mm) const;
  /// Lens-space point / direction of a film-frame point / direction.
  Vec3 lensFromFilmPoint(const Vec3& p) const;
  Vec3 lensFromFilmVector(const Vec3& v) const;
  Vec3 filmFromLensPoint(const Vec3& p) const;
  Vec3 filmFromLensVector(const Vec3& v) const;
  /// The film's unit normal in lens space (toward +z, away from the lens).
  Vec3 filmNormal() const { return lensFromFilmVector({0, 0, 1}); }
  /// Where the line o + t d (lens space) meets the film plane: film-frame x, y and t.
  /// false if the line runs parallel to the film.
  bool intersectFilm(const Vec3& o, const Vec3& d, Vec2* film_mm, double* t) const;
  const TiltShift& tiltShift() const { return ts_; }
  double filmZ_mm() const { return z_film_; }

 private:
  TiltShift ts_;
  double z_film_ = 0;
  Vec3 r_[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  ///< rows of R (film from lens rotation)
};

/// The first-order (thick-lens, paraxial) sharp plane of a tilted film.
struct ScheimpflugData {
  double tilt_deg = 0;           ///< the angle between the film and the lens's principal planes
  double hinge_distance_mm = 0;  ///< J = f / sin(tilt): front nodal point to the hinge line
  /// The hinge line: the point of it nearest the front nodal point, and its direction (lens
  /// space); it lies in the front focal plane, in the plane through the front nodal point
  /// parallel to the film (Merklinger).
  Vec3 hinge_point_mm, hinge_direction;
  /// The Scheimpflug line: where the film plane meets the rear principal plane, carried to the
  /// front principal plane (unit magnification); a point of it and its direction.
  Vec3 scheimpflug_point_mm, scheimpflug_direction;
  /// The plane of sharp focus: a unit normal (lens space) and where it meets the lens axis
  /// (z; -infinity for a film in the rear focal plane).
  Vec3 focus_plane_normal;
  double focus_plane_axis_z_mm = 0;
  /// The plane of focus's angle to the film plane and to the lens axis's normal plane (deg).
  double focus_plane_to_film_deg = 0, focus_plane_to_lens_plane_deg = 0;
  /// Axial distances: rear principal plane to the film (v) and front principal plane to the
  /// axial point in focus (u; infinite when the film sits in the rear focal plane).
  double image_distance_mm = 0, object_distance_mm = 0;
};

/// The sharp plane for a film placed by `placement` behind a lens of paraxial data p: the
/// plane through the hinge line and the Scheimpflug line (closed forms, thick lens in air).
/// Requires a tilt (throws lensim::Error without one, or for a film in front of the rear
/// principal plane).
ScheimpflugData scheimpflug(const ParaxialData& p, const FilmPlacement& placement);

/// Whether a lens-space point lies on the plane of focus (signed distance, mm).
double distanceToFocusPlane(const ScheimpflugData& s, const Vec3& p_lens_mm);

}  // namespace lensim::optics
