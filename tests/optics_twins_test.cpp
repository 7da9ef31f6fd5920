// The scalar and batched surface code share one source (surface_shape.cpp's lane kernels, on one
// lane for the scalar calls): checked here against closed forms written independently in the
// test, and the one-lane and sixteen-lane intersections against each other.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>

#include "lensim/optics/surface_shape.h"

namespace {

using lensim::Vec3;
using lensim::optics::ShapeIntersector;
using lensim::optics::surfaceSag;
using lensim::optics::SurfaceShape;

// A toroid's sag from its definition: the y-z curve f(y) (a conic of curvature c and conic k plus
// sum_p a_p y^p) swept about the axis parallel to y at z = R; the point at height x on the circle
// of radius rho = R - f(y) about it lies at z = R - sgn(rho) sqrt(rho^2 - x^2).
std::optional<double> toroidReference(double c, double k, const std::vector<double>& poly,
                                      double R, double x, double y) {
  const double arg = 1 - (1 + k) * c * c * y * y;
  if (arg < 0) return std::nullopt;
  double f = c * y * y / (1 + std::sqrt(arg));
  for (size_t p = 1; p < poly.size(); ++p) f += poly[p] * std::pow(y, double(p));
  if (R == 0) return f;
  const double rho = R - f;
  if (rho * rho < x * x) return std::nullopt;
  return R - std::copysign(std::sqrt(rho * rho - x * x), rho);
}

TEST(OpticsTwins, ToroidSagMatchesItsDefinition) {
  struct Case {
    double radius, rotation, conic;
    std::vector<double> poly;
  };
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  int defined = 0, undefined = 0;
  for (const Case& cs : {Case{20, -12, 0, {}}, Case{-25, 15, -0.5, {0, 0, 0, 0, 2e-5}},
                         Case{18, 0, 0.3, {0, 0, 1e-3, 0, -1e-5}}, Case{9, 30, 0, {}}}) {
    SurfaceShape s;
    s.rotation_radius_mm = cs.rotation;
    s.conic = cs.conic;
    s.poly = cs.poly;
    const double c = 1 / cs.radius;
    for (int i = 0; i < 4000; ++i) {
      const double x = 16 * u(rng), y = 16 * u(rng);
      const auto ref = toroidReference(c, cs.conic, cs.poly, cs.rotation, x, y);
      const auto got = surfaceSag(cs.radius, s, x, y);
      ASSERT_EQ(ref.has_value(), got.has_value()) << x << " " << y << " R " << cs.rotation;
      if (!ref) {
        ++undefined;
        continue;
      }
      ++defined;
      EXPECT_NEAR(got->z, *ref, 1e-9 * (1 + std::abs(*ref)));
      // The gradient against central differences of the reference, away from the domain's rim.
      const double h = 1e-6;
      const auto px = toroidReference(c, cs.conic, cs.poly, cs.rotation, x + h, y);
      const auto mx = toroidReference(c, cs.conic, cs.poly, cs.rotation, x - h, y);
      const auto py = toroidReference(c, cs.conic, cs.poly, cs.rotation, x, y + h);
      const auto my = toroidReference(c, cs.conic, cs.poly, cs.rotation, x, y - h);
      if (!px || !mx || !py || !my) continue;
      const double gx = (*px - *mx) / (2 * h), gy = (*py - *my) / (2 * h);
      if (std::abs(gx) > 20 || std::abs(gy) > 20) continue;  // near the rim: steep, ill-conditioned
      EXPECT_NEAR(got->dzdx, gx, 1e-6 * (1 + std::abs(gx))) << x << " " << y;
      EXPECT_NEAR(got->dzdy, gy, 1e-6 * (1 + std::abs(gy))) << x << " " << y;
    }
  }
  EXPECT_GT(defined, 10000);
  EXPECT_GT(undefined, 100);  // points outside the domains, which must be refused
}

// An asphere's continued sag (ShapeIntersector::sagContinued, sagZ: the lane kernel on one lane)
// against the even asphere's closed form z = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + sum a_p r^p,
// inside the bound, and the flat continuation beyond it.
TEST(OpticsTwins, AsphereSagMatchesItsClosedForm) {
  SurfaceShape s;
  s.conic = -2.5;
  s.poly = {0, 0, 0, 0, 3e-5, 0, -2e-7};
  const double radius = 14, semi = 8, c = 1 / radius;
  const ShapeIntersector isect(radius, s, semi);
  auto closed = [&](double r) {
    double z = c * r * r / (1 + std::sqrt(1 - (1 + s.conic) * c * c * r * r));
    for (size_t p = 1; p < s.poly.size(); ++p) z += s.poly[p] * std::pow(r, double(p));
    return z;
  };
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 4000; ++i) {
    const double x = 9 * u(rng), y = 9 * u(rng), r = std::hypot(x, y);
    const double bound = 1.25 * semi;  // bound_r: inside the conic's domain here
    const double want = closed(std::min(r, bound));
    EXPECT_NEAR(isect.sagContinued(x, y).z, want, 1e-12 * (1 + std::abs(want))) << r;
    EXPECT_EQ(isect.sagZ(x, y), isect.sagContinued(x, y).z) << r;
    // The radial slope dz/dr from the closed form's derivative, by central differences.
    const double h = 1e-6, slope = (closed(r + h) - closed(r - h)) / (2 * h);
    if (r < 1e-3 || r > bound - h) continue;
    const auto g = isect.sagContinued(x, y);
    EXPECT_NEAR(g.dzdx, slope * x / r, 1e-6) << r;
    EXPECT_NEAR(g.dzdy, slope * y / r, 1e-6) << r;
  }
}

// The same rays through intersect() one by one and intersectLanes sixteen at a time give the
// same hits, bit for bit, for a quadric (a conic, a cylinder) and a toroid, and on a quadric
// the hit lies on the surface (its implicit equation, evaluated independently).
TEST(OpticsTwins, OneLaneAndSixteenLanesAgree) {
  struct Case {
    double radius;
    SurfaceShape shape;
  };
  SurfaceShape conic, cylinder, toroid;
  conic.conic = -0.6;
  cylinder.radius_x_mm = 0.0;  // flat in x: curved in y only
  toroid.rotation_radius_mm = -30;
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u(-1, 1);
  int decided = 0;
  for (const Case& cs : {Case{25, conic}, Case{-18, cylinder}, Case{22, toroid}}) {
    const double semi = 7;
    const ShapeIntersector isect(cs.radius, cs.shape, semi);
    ASSERT_TRUE(isect.hasLanes());
    constexpr int kLanes = ShapeIntersector::kLanes;
    for (int batch = 0; batch < 200; ++batch) {
      double ox[kLanes], oy[kLanes], oz[kLanes], dx[kLanes], dy[kLanes], dz[kLanes];
      for (int j = 0; j < kLanes; ++j) {
        const Vec3 d = lensim::normalize(Vec3{0.6 * u(rng), 0.6 * u(rng), 1});
        ox[j] = 1.2 * semi * u(rng), oy[j] = 1.2 * semi * u(rng), oz[j] = -5;
        dx[j] = d.x, dy[j] = d.y, dz[j] = d.z;
      }
      double t[kLanes], nx[kLanes], ny[kLanes], nz[kLanes], status[kLanes];
      isect.intersectLanes(kLanes, ox, oy, oz, dx, dy, dz, 0, t, nx, ny, nz, status);
      for (int j = 0; j < kLanes; ++j) {
        const auto one = isect.intersect({ox[j], oy[j], oz[j]}, {dx[j], dy[j], dz[j]}, 0);
        if (status[j] == 1) {
          EXPECT_FALSE(one.has_value());
        }
        if (status[j] != 0) continue;
        ASSERT_TRUE(one.has_value());
        EXPECT_EQ(t[j], one->t);
        EXPECT_EQ(nx[j], one->normal.x);
        EXPECT_EQ(ny[j], one->normal.y);
        EXPECT_EQ(nz[j], one->normal.z);
        ++decided;
        if (!cs.shape.isToroidal()) {
          // cx x^2 + cy y^2 + (1 + k) c z^2 - 2 z = 0 (c the curved sections' curvature).
          const double px = ox[j] + t[j] * dx[j], py = oy[j] + t[j] * dy[j],
                       pz = oz[j] + t[j] * dz[j];
          const double cy = 1 / cs.radius, cx = cs.shape.radius_x_mm ? 0.0 : cy;
          const double f = cx * px * px + cy * py * py + (1 + cs.shape.conic) * cy * pz * pz -
                           2 * pz;
          EXPECT_NEAR(f, 0, 1e-12);
        }
      }
    }
  }
  EXPECT_GT(decided, 3 * 200 * 16 / 2);
}

}  // namespace
