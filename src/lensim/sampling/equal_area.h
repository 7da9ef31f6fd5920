// Clarberg's equal-area octahedral mapping between the unit square and the unit sphere
// ("Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD", JGT 13(3), 2008), as pbrt-v4 uses
// for environment maps, goniometric images and the spherical camera.
#pragma once

#include "lensim/util/vec.h"

namespace lensim::sampling {

/// The unit direction for a point of [0,1]^2; equal areas map to equal solid angles.
Vec3 equalAreaSquareToSphere(Vec2 p);
/// The inverse: the point of [0,1]^2 for a unit direction.
Vec2 equalAreaSphereToSquare(const Vec3& d);

}  // namespace lensim::sampling
