#include "lensim/util/transform.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <utility>

#include "lensim/util/error.h"

namespace lensim {

void Bounds3::extend(const Vec3& p) {
  min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
  max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
}

void Bounds3::extend(const Bounds3& b) {
  if (b.empty()) return;
  extend(b.min);
  extend(b.max);
}

namespace {

Transform::Matrix identityMatrix() {
  Transform::Matrix m{};
  for (int i = 0; i < 4; ++i) m[i][i] = 1;
  return m;
}

Transform::Matrix multiply(const Transform::Matrix& a, const Transform::Matrix& b) {
  Transform::Matrix r{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) r[i][j] += a[i][k] * b[k][j];
  return r;
}

Transform::Matrix transposed(const Transform::Matrix& m) {
  Transform::Matrix r{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r[i][j] = m[j][i];
  return r;
}

// Gauss-Jordan elimination with partial pivoting; nullopt if singular.
std::optional<Transform::Matrix> invert(const Transform::Matrix& m) {
  Transform::Matrix a = m, inv = identityMatrix();
  for (int col = 0; col < 4; ++col) {
    int pivot = col;
    for (int r = col + 1; r < 4; ++r)
      if (std::abs(a[r][col]) > std::abs(a[pivot][col])) pivot = r;
    if (std::abs(a[pivot][col]) < 1e-300) return std::nullopt;
    std::swap(a[col], a[pivot]);
    std::swap(inv[col], inv[pivot]);
    double s = 1 / a[col][col];
    for (int j = 0; j < 4; ++j) a[col][j] *= s, inv[col][j] *= s;
    for (int r = 0; r < 4; ++r) {
      if (r == col || a[r][col] == 0) continue;
      double f = a[r][col];
      for (int j = 0; j < 4; ++j) a[r][j] -= f * a[col][j], inv[r][j] -= f * inv[col][j];
    }
  }
  return inv;
}

}  // namespace

Transform::Transform() : m_(identityMatrix()), inv_(identityMatrix()) {}

Transform::Transform(const Matrix& m) : m_(m) {
  auto inv = invert(m);
  if (inv) {
    inv_ = *inv;
  } else {
    for (auto& row : inv_) row.fill(std::numeric_limits<double>::quiet_NaN());
  }
}

bool Transform::isSingular() const {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if (std::isnan(inv_[i][j]) || std::isnan(m_[i][j])) return true;
  return false;
}

Transform Transform::operator*(const Transform& o) const {
  return Transform(multiply(m_, o.m_), multiply(o.inv_, inv_));
}

bool Transform::isIdentity() const {
  return m_ == identityMatrix();
}

bool Transform::swapsHandedness() const {
  const Matrix& m = m_;
  double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
               m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  return det < 0;
}

Vec3 Transform::applyPoint(const Vec3& p) const {
  const Matrix& m = m_;
  double x = m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3];
  double y = m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3];
  double z = m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3];
  double w = m[3][0] * p.x + m[3][1] * p.y + m[3][2] * p.z + m[3][3];
  return w == 1 ? Vec3{x, y, z} : Vec3{x / w, y / w, z / w};
}

Vec3 Transform::applyVector(const Vec3& v) const {
  const Matrix& m = m_;
  return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
          m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
          m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}

Vec3 Transform::applyNormal(const Vec3& n) const {
  const Matrix& mi = inv_;
  return {mi[0][0] * n.x + mi[1][0] * n.y + mi[2][0] * n.z,
          mi[0][1] * n.x + mi[1][1] * n.y + mi[2][1] * n.z,
          mi[0][2] * n.x + mi[1][2] * n.y + mi[2][2] * n.z};
}

Bounds3 Transform::applyBounds(const Bounds3& b) const {
  Bounds3 r;
  if (b.empty()) return r;
  for (int i = 0; i < 8; ++i)
    r.extend(applyPoint(
        {(i & 1) ? b.max.x : b.min.x, (i & 2) ? b.max.y : b.min.y, (i & 4) ? b.max.z : b.min.z}));
  return r;
}

Transform Transform::translate(const Vec3& d) {
  Matrix m = identityMatrix(), mi = identityMatrix();
  m[0][3] = d.x, m[1][3] = d.y, m[2][3] = d.z;
  mi[0][3] = -d.x, mi[1][3] = -d.y, mi[2][3] = -d.z;
  return Transform(m, mi);
}

Transform Transform::scale(double x, double y, double z) {
  Matrix m = identityMatrix();
  m[0][0] = x, m[1][1] = y, m[2][2] = z;
  return Transform(m);
}

Transform Transform::rotate(double angle_deg, const Vec3& axis) {
  Vec3 a = normalize(axis);
  double theta = angle_deg * std::numbers::pi / 180;
  double s = std::sin(theta), c = std::cos(theta);
  Matrix m = identityMatrix();
  m[0][0] = a.x * a.x + (1 - a.x * a.x) * c;
  m[0][1] = a.x * a.y * (1 - c) - a.z * s;
  m[0][2] = a.x * a.z * (1 - c) + a.y * s;
  m[1][0] = a.x * a.y * (1 - c) + a.z * s;
  m[1][1] = a.y * a.y + (1 - a.y * a.y) * c;
  m[1][2] = a.y * a.z * (1 - c) - a.x * s;
  m[2][0] = a.x * a.z * (1 - c) - a.y * s;
  m[2][1] = a.y * a.z * (1 - c) + a.x * s;
  m[2][2] = a.z * a.z + (1 - a.z * a.z) * c;
  return Transform(m, transposed(m));
}

Transform Transform::lookAt(const Vec3& eye, const Vec3& look, const Vec3& up) {
  Vec3 dir = look - eye;
  if (length(dir) == 0) throw Error("LookAt: the eye and look-at points coincide");
  dir = normalize(dir);
  Vec3 upn = normalize(up);
  if (length(cross(upn, dir)) < 1e-12)
    throw Error("LookAt: the up vector and the viewing direction are parallel");
  Vec3 right = normalize(cross(upn, dir));
  Vec3 newUp = cross(dir, right);
  // Columns of world-from-camera: right, up, dir, eye.
  Matrix worldFromCamera = identityMatrix();
  for (int i = 0; i < 3; ++i) {
    worldFromCamera[i][0] = right[i];
    worldFromCamera[i][1] = newUp[i];
    worldFromCamera[i][2] = dir[i];
    worldFromCamera[i][3] = eye[i];
  }
  Transform wc(worldFromCamera);
  return inverse(wc);
}

Transform Transform::fromPbrt(const std::array<double, 16>& v) {
  Matrix m{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m[i][j] = v[j * 4 + i];
  return Transform(m);
}

Transform inverse(const Transform& t) {
  return Transform(t.inverseMatrix(), t.matrix());
}

Transform transpose(const Transform& t) {
  return Transform(transposed(t.matrix()), transposed(t.inverseMatrix()));
}

}  // namespace lensim
