// Geometry of pbrt's shapes for the renderer: exact ray intersection of the quadrics (sphere,
// disk, cylinder, cone with partial sweeps) in their object space, their local geometry (normal,
// (u, v) and dp/du as pbrt-v4 defines them) and uniform area sampling for area lights.
//
// Object space: the quadric's axis is +z. Normals returned here are the "outward" ones of pbrt-v4
// (cross(dp/du, dp/dv)), before ReverseOrientation; lengths in scene units.
#pragma once

#include <cmath>
#include <optional>

#include "lensim/util/vec.h"

namespace lensim::scene {
struct Shape;
}

namespace lensim::render {

/// A ray o + t d, t in (0, tmax); d need not be unit length (t is then in units of |d|).
struct Ray {
  Vec3 o;
  Vec3 d;
  double tmax = INFINITY;
  double time = 0;  ///< shutter time (seconds, the camera's shutteropen..shutterclose)
};

/// Local geometry of a point on a shape, in the space it was computed in.
struct LocalGeometry {
  Vec3 p;     ///< position (scene units)
  Vec3 n;     ///< unit normal, pbrt-v4's orientation before ReverseOrientation
  Vec3 dpdu;  ///< partial derivative of p with respect to u (scene units)
  Vec2 uv;    ///< surface parameters in [0,1]^2
  /// dp/dv and the normal's derivatives dn/du, dn/dv (pbrt-v4's; for bump mapping). The cone's
  /// dn/du, dn/dv are left zero.
  Vec3 dpdv{0, 0, 0}, dndu{0, 0, 0}, dndv{0, 0, 0};
};

/// Nearest t in (tmin, tmax) at which the object-space ray hits the quadric, if any.
std::optional<double> intersectQuadric(const scene::Shape& shape, const Vec3& o, const Vec3& d,
                                       double tmin, double tmax);
/// Local geometry of the quadric at an object-space point on (or very near) its surface; the
/// point is projected onto the surface.
LocalGeometry quadricGeometry(const scene::Shape& shape, Vec3 p);
/// Surface area of the quadric in object space (scene units squared).
double quadricArea(const scene::Shape& shape);
/// A point drawn uniformly by area on the quadric, u in [0,1)^2 (object space).
std::optional<LocalGeometry> sampleQuadricArea(const scene::Shape& shape, Vec2 u);

}  // namespace lensim::render
