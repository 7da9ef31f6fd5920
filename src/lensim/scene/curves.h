// pbrt's `curve` shape as cubic Bézier segments for Embree's native curve primitives.
//
// pbrt-v4 (Curve::Create, src/pbrt/shapes.cpp) turns every input into cubic Bézier segments:
// quadratic Béziers are degree-elevated, uniform B-splines (quadratic or cubic) converted segment
// by segment; segment i gets the width lerp(i/n, width0, width1) at its start and
// lerp((i+1)/n, ...) at its end, and ribbon normals N[i], N[i+1]; u runs over [0, 1] on each
// segment. lensim does the same conversion (our code) and hands the Bézier segments to Embree
// (RTC_GEOMETRY_TYPE_FLAT_BEZIER_CURVE for "flat", ROUND_BEZIER for "cylinder",
// NORMAL_ORIENTED_BEZIER for "ribbon"); `splitdepth` is pbrt's own refinement and is ignored.
#pragma once

#include <vector>

#include "lensim/util/vec.h"

namespace lensim::scene {

enum class CurveKind { Flat, Cylinder, Ribbon };

/// Cubic Bézier segments, 4 control points each (not shared), in object space.
struct Curve {
  CurveKind kind = CurveKind::Flat;
  std::vector<Vec3> cp;       ///< 4 per segment
  std::vector<double> width;  ///< per control point: linear in u along each segment
  std::vector<Vec3> normal;   ///< ribbon: per control point (normalised), else empty
  size_t segments() const { return cp.size() / 4; }
};

/// Converts pbrt's control points (`basis` "bezier" or "bspline", `degree` 2 or 3) to a Curve;
/// `normals` are the ribbon's nSegments + 1 normals or empty. The caller has checked the counts
/// (curveSegmentCount).
Curve makeCurve(CurveKind kind, bool bspline, int degree, const std::vector<Vec3>& P, double width0,
                double width1, const std::vector<Vec3>& normals);
/// The number of segments pbrt makes of `count` control points, or -1 if the count is invalid
/// (Bézier: degree + 1 + k degree; B-spline: at least degree + 1).
int curveSegmentCount(bool bspline, int degree, size_t count);

/// Point and derivative dp/du of segment `seg` at u in [0, 1].
Vec3 curvePoint(const Curve& c, size_t seg, double u);
Vec3 curveTangent(const Curve& c, size_t seg, double u);
/// Width of segment `seg` at u.
double curveWidth(const Curve& c, size_t seg, double u);
/// Surface area: the integral of |dp/du| w(u) du over all segments for flat curves and ribbons
/// (a band of that width), times pi for cylinders (a tube of diameter w).
double curveArea(const Curve& c);

}  // namespace lensim::scene
