// Animated transforms (see animated_transform.h). The decomposition and interpolation follow
// pbrt-v4 (src/pbrt/util/transform.cpp: Transform::Decompose, the AnimatedTransform constructor,
// AnimatedTransform::Interpolate; src/pbrt/util/vecmath.h: Slerp); the motion bound is lensim's.
#include "lensim/util/animated_transform.h"

#include <algorithm>
#include <cmath>

namespace lensim {

namespace {

using Matrix = Transform::Matrix;

Quaternion operator*(const Quaternion& q, double s) {
  return {q.v * s, q.w * s};
}
Quaternion operator+(const Quaternion& a, const Quaternion& b) {
  return {a.v + b.v, a.w + b.w};
}
Quaternion operator-(const Quaternion& a, const Quaternion& b) {
  return {a.v - b.v, a.w - b.w};
}
Quaternion normalized(const Quaternion& q) {
  const double n = std::sqrt(dot(q, q));
  return n > 0 ? q * (1 / n) : Quaternion{};
}

Matrix upper3x3(const Matrix& m) {
  Matrix r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[i][j] = m[i][j];
  r[3][3] = 1;
  return r;
}

}  // namespace

double dot(const Quaternion& a, const Quaternion& b) {
  return a.v.x * b.v.x + a.v.y * b.v.y + a.v.z * b.v.z + a.w * b.w;
}

Quaternion quaternionFromMatrix(const Matrix& m) {
  // Shepperd's method: from the trace when w is not small, else from the largest diagonal
  // element (as pbrt-v4's Quaternion(const Transform&)).
  const double trace = m[0][0] + m[1][1] + m[2][2];
  Quaternion q;
  if (trace > 0) {
    double s = std::sqrt(trace + 1);
    q.w = s / 2;
    s = 0.5 / s;
    q.v = {(m[2][1] - m[1][2]) * s, (m[0][2] - m[2][0]) * s, (m[1][0] - m[0][1]) * s};
  } else {
    int i = 0;
    if (m[1][1] > m[0][0]) i = 1;
    if (m[2][2] > m[i][i]) i = 2;
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    double s = std::sqrt(std::max(0.0, m[i][i] - (m[j][j] + m[k][k]) + 1));
    double c[3];
    c[i] = s / 2;
    if (s != 0) s = 0.5 / s;
    q.w = (m[k][j] - m[j][k]) * s;
    c[j] = (m[j][i] + m[i][j]) * s;
    c[k] = (m[k][i] + m[i][k]) * s;
    q.v = {c[0], c[1], c[2]};
  }
  return q;
}

Transform rotationTransform(const Quaternion& q) {
  const double x = q.v.x, y = q.v.y, z = q.v.z, w = q.w;
  Matrix m{};
  m[0] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 0};
  m[1] = {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 0};
  m[2] = {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), 0};
  m[3] = {0, 0, 0, 1};
  // A rotation's inverse is its transpose.
  Matrix mt{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) mt[i][j] = m[j][i];
  return Transform(m, mt);
}

Quaternion slerp(double t, const Quaternion& a, const Quaternion& b) {
  const double c = dot(a, b);
  if (c > 0.9995) return normalized(a * (1 - t) + b * t);
  const double theta = std::acos(std::clamp(c, -1.0, 1.0));
  const Quaternion perp = normalized(b - a * c);
  return a * std::cos(theta * t) + perp * std::sin(theta * t);
}

Decomposition decompose(const Transform& t) {
  const Matrix& m = t.matrix();
  Decomposition d;
  d.translation = {m[0][3], m[1][3], m[2][3]};
  const Matrix M = upper3x3(m);
  // Polar decomposition M = R S: R_{i+1} = (R_i + R_i^-T) / 2 converges to the orthogonal
  // factor (Higham 1986; pbrt-v4 stops at a change of 1e-4, lensim at 1e-13).
  Transform R(M);
  for (int count = 0; count < 100; ++count) {
    const Matrix& r = R.matrix();
    const Matrix& ri = R.inverseMatrix();  // R^-1; its transpose is R^-T
    Matrix next{};
    double norm = 0;
    for (int i = 0; i < 3; ++i) {
      double row = 0;
      for (int j = 0; j < 3; ++j) {
        next[i][j] = 0.5 * (r[i][j] + ri[j][i]);
        row += std::abs(next[i][j] - r[i][j]);
      }
      norm = std::max(norm, row);
    }
    next[3][3] = 1;
    if (!(norm == norm)) break;  // singular: NaN
    R = Transform(next);
    if (norm <= 1e-13) break;
  }
  d.rotation = quaternionFromMatrix(R.matrix());
  // S = R^-1 M.
  const Matrix& ri = R.inverseMatrix();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += ri[i][k] * M[k][j];
      d.scale[i][j] = s;
    }
  return d;
}

AnimatedTransform::AnimatedTransform(const Transform& start, double start_time,
                                     const Transform& end, double end_time)
    : start_(start), end_(end), start_time_(start_time), end_time_(end_time) {
  animated_ = !(start == end) && end_time > start_time;
  if (!animated_) return;
  parts_[0] = decompose(start);
  parts_[1] = decompose(end);
  // The shorter way round (pbrt-v4: R[1] = -R[1] if Dot(R[0], R[1]) < 0).
  if (dot(parts_[0].rotation, parts_[1].rotation) < 0)
    parts_[1].rotation = parts_[1].rotation * -1.0;
}

Transform AnimatedTransform::interpolate(double time) const {
  if (!animated_ || time <= start_time_) return start_;
  if (time >= end_time_) return end_;
  const double dt = (time - start_time_) / (end_time_ - start_time_);
  const Decomposition &a = parts_[0], &b = parts_[1];
  const Vec3 tr = a.translation * (1 - dt) + b.translation * dt;
  const Quaternion q = slerp(dt, a.rotation, b.rotation);
  Matrix s{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) s[i][j] = (1 - dt) * a.scale[i][j] + dt * b.scale[i][j];
  return Transform::translate(tr) * rotationTransform(q) * Transform(s);
}

// The bound. In the interpolation parameter s, a corner x moves as p(s) = T(s) + R(s) q(s) with
// T and q(s) = S(s) x linear in s and R(s) a rotation about a fixed axis at a constant rate (a
// slerp; the normalised lerp used for nearly equal rotations also keeps the axis). On a piece
// [sa, sb] turning by at most D: R(s) = R(sa) E(s), E a turn by at most D about a fixed axis, so
// p(s) = L(s) + R(sa) (E(s) - I) q(s) with L(s) = T(s) + R(sa) q(s) linear, L(sa) = p(sa) and
// |L(sb) - p(sb)| <= 2 sin(D/2) |q(sb)|; |(E - I) q| <= 2 sin(D/2) |q|. So p(s) lies within
// 4 sin(D/2) max|q| of the segment p(sa) p(sb), and |q(s)| <= max(|S(0) x|, |S(1) x|).
Bounds3 AnimatedTransform::motionBounds(const Bounds3& b, double t0, double t1) const {
  if (b.empty()) return b;
  if (!animated_) return start_.applyBounds(b);
  const auto param = [&](double t) {
    return std::clamp((t - start_time_) / (end_time_ - start_time_), 0.0, 1.0);
  };
  const double s0 = param(std::min(t0, t1)), s1 = param(std::max(t0, t1));
  const auto at = [&](double s) {
    return interpolate(start_time_ + s * (end_time_ - start_time_));
  };
  const double c = std::clamp(std::abs(dot(parts_[0].rotation, parts_[1].rotation)), 0.0, 1.0);
  const double turn = 2 * std::acos(c) * (s1 - s0);  // radians over [s0, s1]
  if (turn == 0 || s1 == s0) {
    Bounds3 r = at(s0).applyBounds(b);
    r.extend(at(s1).applyBounds(b));
    return r;
  }
  constexpr double kMaxPieceTurn = 0.25 * M_PI / 180;
  const int pieces = std::clamp(static_cast<int>(std::ceil(turn / kMaxPieceTurn)), 1, 4096);
  double qmax = 0;
  for (int i = 0; i < 8; ++i) {
    const Vec3 x{(i & 1) ? b.max.x : b.min.x, (i & 2) ? b.max.y : b.min.y,
                 (i & 4) ? b.max.z : b.min.z};
    for (const Decomposition& d : parts_)
      qmax = std::max(qmax, length(Transform(d.scale).applyVector(x)));
  }
  const double pad = 4 * std::sin(0.5 * turn / pieces) * qmax;
  Bounds3 r;
  for (int k = 0; k <= pieces; ++k) r.extend(at(s0 + (s1 - s0) * k / pieces).applyBounds(b));
  r.min = r.min - Vec3{pad, pad, pad};
  r.max = r.max + Vec3{pad, pad, pad};
  return r;
}

}  // namespace lensim
