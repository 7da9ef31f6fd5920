// Small fixed-size vector types used throughout lensim.
#pragma once

#include <cmath>

namespace lensim {

/// A 2-vector of T (film positions, pupil positions).
template <typename T>
struct Vec2T {
  T x{}, y{};
  constexpr Vec2T() = default;
  constexpr Vec2T(T x_, T y_) : x(x_), y(y_) {}
  constexpr Vec2T operator+(const Vec2T& o) const { return {x + o.x, y + o.y}; }
  constexpr Vec2T operator-(const Vec2T& o) const { return {x - o.x, y - o.y}; }
  constexpr Vec2T operator*(T s) const { return {x * s, y * s}; }
  constexpr bool operator==(const Vec2T&) const = default;
};

/// A 3-vector of T. In lens space: millimetres, z along the optical axis toward the film.
template <typename T>
struct Vec3T {
  T x{}, y{}, z{};
  constexpr Vec3T() = default;
  constexpr Vec3T(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  template <typename U>
  constexpr explicit Vec3T(const Vec3T<U>& o) : x(T(o.x)), y(T(o.y)), z(T(o.z)) {}

  constexpr Vec3T operator+(const Vec3T& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3T operator-(const Vec3T& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3T operator-() const { return {-x, -y, -z}; }
  constexpr Vec3T operator*(T s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3T operator/(T s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3T& operator+=(const Vec3T& o) {
    x += o.x, y += o.y, z += o.z;
    return *this;
  }
  constexpr bool operator==(const Vec3T&) const = default;
  constexpr T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

template <typename T>
constexpr Vec3T<T> operator*(T s, const Vec3T<T>& v) {
  return v * s;
}
template <typename T>
constexpr T dot(const Vec3T<T>& a, const Vec3T<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <typename T>
constexpr Vec3T<T> cross(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T>
T length(const Vec3T<T>& v) {
  return std::sqrt(dot(v, v));
}
template <typename T>
Vec3T<T> normalize(const Vec3T<T>& v) {
  return v / length(v);
}

using Vec2 = Vec2T<double>;
using Vec3 = Vec3T<double>;
using Vec3f = Vec3T<float>;

}  // namespace lensim
