// Animated transforms for motion blur, as pbrt-v4's AnimatedTransform (src/pbrt/util/transform.h
// and transform.cpp): a start and an end transform at two times, each decomposed as
// M = T R S (translation, rotation as a unit quaternion, the symmetric rest "scale" by polar
// decomposition); in between, T and S are interpolated linearly and R by quaternion slerp, so a
// rotation turns at a constant rate about a fixed axis (the matrices themselves are not
// interpolated). Before the start time the start transform holds, after the end time the end one.
#pragma once

#include "lensim/util/transform.h"

namespace lensim {

/// A unit quaternion (v, w) for a rotation by angle a about unit axis n: v = n sin(a/2),
/// w = cos(a/2) (pbrt-v4's Quaternion, src/pbrt/util/vecmath.h).
struct Quaternion {
  Vec3 v{0, 0, 0};
  double w = 1;
};

double dot(const Quaternion& a, const Quaternion& b);
/// The rotation of a proper rotation matrix (its upper 3x3; pbrt-v4's Quaternion(const Transform&),
/// src/pbrt/util/transform.cpp).
Quaternion quaternionFromMatrix(const Transform::Matrix& m);
/// The rotation matrix of a unit quaternion (pbrt-v4's Transform(Quaternion), transform.cpp).
Transform rotationTransform(const Quaternion& q);
/// Spherical linear interpolation by t in [0,1] along the shorter arc from a to b when dot >= 0
/// (pbrt-v4's Slerp, src/pbrt/util/vecmath.h); normalised linear interpolation for nearly equal
/// rotations.
Quaternion slerp(double t, const Quaternion& a, const Quaternion& b);

/// pbrt-v4's Transform::Decompose: translation T (the last column), rotation R (polar
/// decomposition of the upper 3x3 by averaging it with its inverse transpose until it stops
/// changing) and S = R^-1 M (upper 3x3, symmetric for a proper M). lensim iterates to 1e-13
/// instead of pbrt's 1e-4, so R is orthonormal to double precision.
struct Decomposition {
  Vec3 translation;
  Quaternion rotation;
  Transform::Matrix scale{};  ///< 4x4 with the last row and column (0, 0, 0, 1)
};
Decomposition decompose(const Transform& m);

class AnimatedTransform {
 public:
  /// The identity, not animated.
  AnimatedTransform() = default;
  /// A transform that is `start` until start_time and `end` from end_time on.
  AnimatedTransform(const Transform& start, double start_time, const Transform& end,
                    double end_time);
  /// A static transform.
  explicit AnimatedTransform(const Transform& t) : start_(t), end_(t) {}

  /// False when the start and end transforms are equal (or the times are).
  bool isAnimated() const { return animated_; }
  const Transform& start() const { return start_; }
  const Transform& end() const { return end_; }
  double startTime() const { return start_time_; }
  double endTime() const { return end_time_; }
  /// The decomposed parts (start: 0, end: 1); identity parts for a static transform.
  const Decomposition& part(int i) const { return parts_[i]; }

  /// The transform at `time` (pbrt-v4's AnimatedTransform::Interpolate):
  /// Translate(lerp T) * Rotate(slerp R) * (lerp S).
  Transform interpolate(double time) const;
  /// The transform at `time` by reference: the start transform itself when not animated (no
  /// copy), else `scratch` filled with interpolate(time).
  const Transform& at(double time, Transform& scratch) const {
    if (!animated_) return start_;
    scratch = interpolate(time);
    return scratch;
  }

  /// A box containing the moving box b at every time in [t0, t1] (conservative; the transform is
  /// constant outside [startTime, endTime]). Exact (the union of the two ends) without rotation;
  /// with rotation the interval is cut into pieces of at most 0.25 degrees of turn, each bounded
  /// by its two ends padded by 4 sin(turn / 2) times the largest |S x| of the box's corners x (a
  /// rotation by at most `turn` moves a point by at most 2 sin(turn / 2) of its distance from
  /// the axis, once for the path and once for the end point; derivation in the .cpp). pbrt-v4
  /// finds the extremes exactly (BoundPointMotion); this bound is slightly larger and simpler.
  Bounds3 motionBounds(const Bounds3& b, double t0, double t1) const;

 private:
  Transform start_, end_;
  double start_time_ = 0, end_time_ = 1;
  bool animated_ = false;
  Decomposition parts_[2];
};

}  // namespace lensim
