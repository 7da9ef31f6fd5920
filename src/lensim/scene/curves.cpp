#include "lensim/scene/curves.h"

#include <array>
#include <cmath>
#include <numbers>

namespace lensim::scene {

namespace {

using Bezier = std::array<Vec3, 4>;

Bezier elevate(const Vec3& a, const Vec3& b, const Vec3& c) {
  return {a, a + (b - a) * (2.0 / 3.0), c + (b - c) * (2.0 / 3.0), c};
}

}  // namespace

int curveSegmentCount(bool bspline, int degree, size_t count) {
  if (degree != 2 && degree != 3) return -1;
  const size_t d = size_t(degree);
  if (bspline) return count >= d + 1 ? int(count - d) : -1;
  if (count < d + 1 || (count - 1 - d) % d != 0) return -1;
  return int((count - 1) / d);
}

Curve makeCurve(CurveKind kind, bool bspline, int degree, const std::vector<Vec3>& P, double width0,
                double width1, const std::vector<Vec3>& normals) {
  Curve c;
  c.kind = kind;
  const int n = curveSegmentCount(bspline, degree, P.size());
  for (int seg = 0; seg < n; ++seg) {
    Bezier b;
    if (!bspline) {
      const size_t o = size_t(seg * degree);
      b = degree == 2 ? elevate(P[o], P[o + 1], P[o + 2])
                      : Bezier{P[o], P[o + 1], P[o + 2], P[o + 3]};
    } else {
      const size_t o = size_t(seg);
      if (degree == 2) {
        // Uniform quadratic B-spline segment -> quadratic Bézier (midpoints), then cubic.
        b = elevate((P[o] + P[o + 1]) * 0.5, P[o + 1], (P[o + 1] + P[o + 2]) * 0.5);
      } else {
        const Vec3 &q0 = P[o], &q1 = P[o + 1], &q2 = P[o + 2], &q3 = P[o + 3];
        b = {(q0 + q1 * 4.0 + q2) / 6.0, (q1 * 2.0 + q2) / 3.0, (q1 + q2 * 2.0) / 3.0,
             (q1 + q2 * 4.0 + q3) / 6.0};
      }
    }
    const double wa = width0 + (width1 - width0) * seg / n;
    const double wb = width0 + (width1 - width0) * (seg + 1) / n;
    for (int k = 0; k < 4; ++k) {
      c.cp.push_back(b[size_t(k)]);
      // Bézier control values equally spaced between wa and wb give a width linear in u.
      c.width.push_back(wa + (wb - wa) * k / 3.0);
      if (!normals.empty()) {
        const Vec3 nn = normals[size_t(seg)] * (1 - k / 3.0) + normals[size_t(seg) + 1] * (k / 3.0);
        c.normal.push_back(length(nn) > 0 ? normalize(nn) : normals[size_t(seg)]);
      }
    }
  }
  return c;
}

Vec3 curvePoint(const Curve& c, size_t seg, double u) {
  const Vec3* b = &c.cp[4 * seg];
  const double s = 1 - u;
  return b[0] * (s * s * s) + b[1] * (3 * s * s * u) + b[2] * (3 * s * u * u) + b[3] * (u * u * u);
}

Vec3 curveTangent(const Curve& c, size_t seg, double u) {
  const Vec3* b = &c.cp[4 * seg];
  const double s = 1 - u;
  return (b[1] - b[0]) * (3 * s * s) + (b[2] - b[1]) * (6 * s * u) + (b[3] - b[2]) * (3 * u * u);
}

double curveWidth(const Curve& c, size_t seg, double u) {
  return c.width[4 * seg] + (c.width[4 * seg + 3] - c.width[4 * seg]) * u;
}

double curveArea(const Curve& c) {
  // 16-point Gauss–Legendre on each of 8 sub-intervals of every segment.
  static constexpr double x[8] = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274,
                                  0.6178762444026438, 0.7554044083550030, 0.8656312023878318,
                                  0.9445750230732326, 0.9894009349916499};
  static constexpr double w[8] = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025,
                                  0.1495959888165767, 0.1246289712555339, 0.0951585116824928,
                                  0.0622535239386479, 0.0271524594117541};
  double area = 0;
  for (size_t seg = 0; seg < c.segments(); ++seg)
    for (int sub = 0; sub < 8; ++sub) {
      const double a = sub / 8.0, h = 1 / 16.0;  // half-width of the sub-interval
      for (int i = 0; i < 8; ++i)
        for (double sgn : {-1.0, 1.0}) {
          const double u = a + h + sgn * h * x[i];
          area += w[i] * h * length(curveTangent(c, seg, u)) * curveWidth(c, seg, u);
        }
    }
  return c.kind == CurveKind::Cylinder ? std::numbers::pi * area : area;
}

}  // namespace lensim::scene
