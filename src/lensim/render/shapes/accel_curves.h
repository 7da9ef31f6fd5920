// pbrt curves on Embree's native curve primitives (used by Accel): the scene's cubic Bézier
// segments (scene/curves.h) in the accelerator's space as Embree FLAT_BEZIER (pbrt "flat"),
// ROUND_BEZIER ("cylinder") and NORMAL_ORIENTED_BEZIER ("ribbon") curves, and the local geometry
// of a hit as pbrt-v4 defines it (Curve::InteractionFromIntersection): u along the segment,
// v across it in [0, 1] (its side taken from the ray, as pbrt-v4 does), dp/du the curve's tangent,
// dp/dv across with the curve's width, and the normal cross(dp/du, dp/dv) — facing the ray for flat
// curves, the ribbon's normal for ribbons, the tube's surface normal for cylinders.
#pragma once

#include <embree3/rtcore.h>

#include <vector>

#include "lensim/scene/curves.h"
#include "lensim/util/transform.h"
#include "lensim/util/vec.h"

namespace lensim::render {

/// A curve's control points, ribbon normals and radii in the accelerator's space.
struct CurveInSpace {
  std::vector<Vec3> p, n;
  std::vector<double> radius;
  Bounds3 bounds;
};
/// Transforms the curve; widths scale by the cube root of the transform's |determinant|.
CurveInSpace curveInSpace(const scene::Curve& curve, const Transform& space_from_object);
/// A new (uncommitted) Embree curve geometry with one primitive per Bézier segment.
RTCGeometry newCurveGeometry(RTCDevice device, const scene::Curve& curve, const CurveInSpace& c);

struct CurveHitGeometry {
  Vec3 p, n, dpdu, dpdv;
  Vec2 uv;
};
/// Local geometry of Embree's hit (segment, u, v, Ng) at the point p on a ray of direction d.
CurveHitGeometry curveHitGeometry(const scene::Curve& curve, const CurveInSpace& c, size_t seg,
                                  double u, double v, Vec3 embree_ng, Vec3 p, Vec3 d);

}  // namespace lensim::render
