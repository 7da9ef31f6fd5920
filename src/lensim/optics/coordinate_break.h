// Zemax coordinate breaks (`TYPE COORDBRK`) resolved into an equivalent coaxial prescription.
//
// A coordinate break moves the local frame in which the following surfaces sit (OpticStudio
// User Guide, "Coordinate Break"): PARM 1, 2 decentre x, y (lens units); PARM 3, 4, 5 tilt
// about x, y, z (degrees); PARM 6 the order flag: 0 decentres first, then tilts about x, then
// the new y, then the new z; any other value applies the inverse order (z, y, x tilts, then the
// decentres). Its thickness then moves along the new z axis, like any surface's.
//
// lensim models rotationally symmetric systems traced along one axis. A system with coordinate
// breaks is accepted when it is such a system folded by plane mirrors: each surface is placed in
// space by composing the breaks, the plane mirrors are undone by reflecting everything after each
// of them in its plane (an isometry), and every other surface must then sit on one straight axis,
// perpendicular to it. The result is written in Zemax's own coaxial convention (a mirror normal
// to the axis, thicknesses negative after an odd number of mirrors), which the tracers model
// exactly; the first-order data of the fold are those of this twin. Anything else (a decentred or
// tilted lens, a tilted powered mirror, a tilted image) is refused at the break that causes it.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"

namespace lensim::optics {

/// One Zemax surface as the fold resolution needs it (object first, image last).
struct FoldSurface {
  int number = 0;                     ///< the SURF number (for messages)
  FileLoc loc;                        ///< the SURF line
  bool coordbrk = false;              ///< TYPE COORDBRK
  std::array<double, 6> parm{};       ///< PARM 1..6 of a coordinate break
  std::array<FileLoc, 6> parm_loc{};  ///< their places (invalid: not in the file)
  double thickness = 0;               ///< DISZ (lens units); the object's is ignored
  bool mirror = false;                ///< GLAS MIRROR
  bool plane = false;                 ///< no sag at all (curvature and every sag term zero)
  bool symmetric = true;              ///< rotationally symmetric (shape and aperture)
  /// Valid when the surface's aperture is decentred (Zemax OBDC): the lens is then not coaxial
  /// even without breaks.
  FileLoc decentred_aperture_loc;
};

/// A tilted plane mirror's circular aperture seen along the axis: an ellipse, its semi-axes the
/// semi-diameter times scale_x, scale_y.
struct FoldMirrorAperture {
  size_t index = 0;  ///< in the kept surfaces
  double scale_x = 1, scale_y = 1;
};

struct UnfoldedSystem {
  bool any_break = false;
  std::vector<size_t> kept;      ///< indices of the surfaces that remain (no breaks)
  std::vector<double> thickness; ///< their coaxial thicknesses (lens units), per kept surface
  std::vector<FoldMirrorAperture> tilted_mirrors;
};

/// The right-handed rotation by `deg` degrees about axis 0 (x), 1 (y) or 2 (z) with which a
/// break turns its frame (rows; its columns are the turned axes).
std::array<std::array<double, 3>, 3> axisRotation(int axis, double deg);

/// Every surface's frame in space, breaks composed (a break's own frame is the one after its
/// decentres and tilts); surface 0 (the object) and surface 1 sit at the origin, unturned.
/// Throws Error at the break (or surface) after which a vertex would lie at a non-finite place.
std::vector<SurfaceFrame> placeSurfaces(const std::vector<FoldSurface>& surfs);

/// The coordinate breaks resolved either way: into the coaxial twin (a fold by plane mirrors, or
/// no break), or, when no single axis holds the surfaces, into every surface's frame in space
/// with the reason the twin was refused (unfoldCoordinateBreaks's error, at its break).
struct PlacedSystem {
  bool coaxial = true;
  UnfoldedSystem unfolded;           ///< coaxial: the twin
  std::vector<SurfaceFrame> frames;  ///< non-coaxial: placeSurfaces's
  std::optional<Error> refusal;      ///< non-coaxial: why
};

/// Throws Error for a break as the object or image surface, or at a non-finite place.
PlacedSystem placeCoordinateBreaks(const std::vector<FoldSurface>& surfs);

/// Resolves the coordinate breaks of `surfs`; throws Error at the break (or surface) that leaves
/// the system non-coaxial. Without breaks, returns every surface with its own thickness.
UnfoldedSystem unfoldCoordinateBreaks(const std::vector<FoldSurface>& surfs);

}  // namespace lensim::optics
