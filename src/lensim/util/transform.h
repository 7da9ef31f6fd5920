// 4x4 affine/projective transforms in double precision, with pbrt's conventions: points are
// column vectors, `a * b` applies b first, and the scene-file directives (Translate, Rotate,
// LookAt, ...) post-multiply the current transformation matrix.
#pragma once

#include <array>

#include "lensim/util/vec.h"

namespace lensim {

/// An axis-aligned box; empty when min > max.
struct Bounds3 {
  Vec3 min{1e300, 1e300, 1e300};
  Vec3 max{-1e300, -1e300, -1e300};

  bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
  void extend(const Vec3& p);
  void extend(const Bounds3& b);
};

/// A 4x4 matrix m[row][col] and its inverse. Units are those of the space it maps from/to.
class Transform {
 public:
  using Matrix = std::array<std::array<double, 4>, 4>;

  /// Identity.
  Transform();
  /// From a matrix; computes the inverse. A singular matrix gets a NaN inverse (isSingular()),
  /// as in pbrt-v4 (src/pbrt/util/transform.h, Transform(const SquareMatrix<4>&)): scene files
  /// may hold singular transforms that nothing rendered uses.
  explicit Transform(const Matrix& m);
  Transform(const Matrix& m, const Matrix& inverse) : m_(m), inv_(inverse) {}

  const Matrix& matrix() const { return m_; }
  const Matrix& inverseMatrix() const { return inv_; }
  double operator()(int row, int col) const { return m_[row][col]; }

  Transform operator*(const Transform& o) const;
  bool operator==(const Transform& o) const { return m_ == o.m_; }
  bool isIdentity() const;
  /// True if the matrix (or its inverse) is singular: the inverse (or matrix) holds NaNs.
  bool isSingular() const;
  /// True if the transform changes a right-handed frame into a left-handed one.
  bool swapsHandedness() const;

  Vec3 applyPoint(const Vec3& p) const;
  Vec3 applyVector(const Vec3& v) const;
  /// Transforms a surface normal (by the inverse transpose); not normalised.
  Vec3 applyNormal(const Vec3& n) const;
  Bounds3 applyBounds(const Bounds3& b) const;

  static Transform translate(const Vec3& d);
  static Transform scale(double x, double y, double z);
  /// Rotation by angle_deg degrees about axis (right-handed, as pbrt).
  static Transform rotate(double angle_deg, const Vec3& axis);
  /// pbrt's LookAt: the camera-from-world transform of a camera at eye looking at look.
  static Transform lookAt(const Vec3& eye, const Vec3& look, const Vec3& up);
  /// From 16 values in the scene file's order (pbrt's Transform directive: the transpose).
  static Transform fromPbrt(const std::array<double, 16>& v);

 private:
  Matrix m_;
  Matrix inv_;
};

Transform inverse(const Transform& t);
Transform transpose(const Transform& t);

}  // namespace lensim
