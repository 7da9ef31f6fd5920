// Aspheric and cylindrical surfaces in the exact tracer, checked against closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/surface_shape.h"
#include "optics_test_lenses.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

constexpr double kN = 1.5;

// The plano-convex test lens (n = 1.5, 24 mm clear aperture): f = 40 mm behind the back vertex.
LensPrescription planoConvex(double conic) {
  return lensim::test::planoConvexConic(conic, kN, 24);
}

// RMS distance from the axis where collimated rays at heights up to h_max cross z_focus.
double rmsSpot(const LensSystem& lens, double z_focus, double h_max, int* through = nullptr) {
  double s2 = 0;
  int n = 0;
  for (int k = 1; k <= 200; ++k) {
    const double h = h_max * k / 200.0;
    const double phi = 2.399963 * k;  // golden angle: spread around the axis
    Ray r{{h * std::cos(phi), h * std::sin(phi), -10}, {0, 0, 1}};
    const TraceResult t = lens.tracer().traceFromScene(r);
    if (!t.ok()) continue;
    const double s = (z_focus - t.ray.origin.z) / t.ray.direction.z;
    const double x = t.ray.origin.x + s * t.ray.direction.x;
    const double y = t.ray.origin.y + s * t.ray.direction.y;
    s2 += x * x + y * y;
    ++n;
  }
  if (through) *through = n;
  return std::sqrt(s2 / std::max(n, 1));
}

}  // namespace

TEST(Asphere, HyperbolicPlanoConvexFocusesCollimatedLightToAPoint) {
  const LensSystem hyper(planoConvex(-kN * kN));
  const LensSystem sphere(planoConvex(0));
  const double z_focus = 5 + 20 / (kN - 1);
  int through = 0;
  const double rms_hyper = rmsSpot(hyper, z_focus, 11.5, &through);
  EXPECT_EQ(through, 200);  // no misses up to the rim
  EXPECT_LT(rms_hyper, 1e-6);
  const double rms_sphere = rmsSpot(sphere, z_focus, 11.5);
  EXPECT_GT(rms_sphere, 0.1);  // the sphere of the same vertex curvature does not focus
  // Paraxial data come from the vertex curvature: the same for both.
  const ParaxialData ph = computeParaxial(hyper), ps = computeParaxial(sphere);
  EXPECT_NEAR(ph.effective_focal_length_mm, 40.0, 1e-9);
  EXPECT_NEAR(ph.back_focal_length_mm, 40.0, 1e-9);
  EXPECT_DOUBLE_EQ(ph.effective_focal_length_mm, ps.effective_focal_length_mm);
}

TEST(Asphere, FloatBatchTracerCollimatesThePointAtTheFocus) {
  // Reversed: rays from the focal point on the film side leave the lens parallel to the axis,
  // through the same batched float tracer the realistic camera uses.
  const LensSystem lens(planoConvex(-kN * kN));
  const float zf = float(5 + 40);
  std::vector<RayT<float>> rays;
  for (int k = 0; k < 16; ++k) {
    const double h = 11.0 * (k + 0.5) / 16, phi = 0.7 * k;
    Vec3f to{float(h * std::cos(phi)), float(h * std::sin(phi)), 5.f};
    Vec3f from{0, 0, zf};
    rays.push_back({from, normalize(to - from)});
  }
  TraceResultT<float> res[16];
  lens.tracerFloat().traceFromFilmBatch(rays.data(), 16, res);
  for (int k = 0; k < 16; ++k) {
    ASSERT_TRUE(res[k].ok()) << k;
    EXPECT_LT(std::hypot(res[k].ray.direction.x, res[k].ray.direction.y), 2e-5f) << k;
    // The same ray through the scalar double tracer agrees.
    const Ray rd{
        {0, 0, double(zf)},
        {double(rays[k].direction.x), double(rays[k].direction.y), double(rays[k].direction.z)}};
    const TraceResult t = lens.tracer().traceFromFilm(rd);
    ASSERT_TRUE(t.ok());
    EXPECT_NEAR(t.ray.origin.x, res[k].ray.origin.x, 1e-4);
    EXPECT_LT(std::hypot(t.ray.direction.x, t.ray.direction.y), 1e-9);
  }
}

class AsphereShapes : public ::testing::TestWithParam<int> {};

TEST_P(AsphereShapes, HitsLieOnTheSurfaceWithTheSagGradientAsNormal) {
  // An even asphere with r^2, r^4 and r^6 terms; an odd one (Zemax ODDASPH) with r^1, r^3, r^5
  // terms on an oblate conic; random rays, many near the rim.
  SurfaceShape shape;
  shape.conic = GetParam() == 0 ? -0.6 : 0.4;
  shape.poly = GetParam() == 0 ? std::vector<double>{0, 0, 0.001, 0, 2e-5, 0, -3e-8}
                               : std::vector<double>{0, 2e-4, 0, -3e-5, 0, 4e-7};
  const double R = 18, semi = 9;
  const ShapeIntersector isect(R, shape, semi);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0;
  for (int k = 0; k < 2000; ++k) {
    const double x0 = semi * u(rng), y0 = semi * u(rng);
    Vec3 o{x0, y0, -30};
    Vec3 d = normalize(Vec3{0.2 * u(rng), 0.2 * u(rng), 1});
    auto h = isect.intersect(o, d, 0);
    ASSERT_TRUE(h.has_value()) << k;  // the continued surface covers the plane: never a miss
    const Vec3 p = o + d * h->t;
    const auto g = surfaceSag(R, shape, p.x, p.y);
    if (p.x * p.x + p.y * p.y > 1.25 * 1.25 * semi * semi) continue;
    ASSERT_TRUE(g.has_value());
    EXPECT_NEAR(p.z, g->z, 1e-10);
    const Vec3 n = normalize(Vec3{g->dzdx, g->dzdy, -1});
    EXPECT_NEAR(dot(n, h->normal), 1.0, 1e-12);
    ++hits;
  }
  EXPECT_GT(hits, 1500);
}

INSTANTIATE_TEST_SUITE_P(EvenAndOdd, AsphereShapes, ::testing::Values(0, 1));

TEST(Asphere, FirstCrossingIsTaken) {
  // A steep concave-to-the-ray conic: a ray that crosses the surface twice must stop at the
  // first crossing, seen from either side.
  SurfaceShape shape;
  shape.conic = -1;  // paraboloid z = r^2 / (2 R)
  const double R = 5;
  const ShapeIntersector isect(R, shape, 8);
  // Ray parallel to x at height z = 2: crosses z = r^2/10 at x = -sqrt(20) and +sqrt(20).
  Vec3 o{-20, 0, 2};
  auto h = isect.intersect(o, Vec3{1, 0, 0}, 0);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(o.x + h->t, -std::sqrt(20.0), 1e-9);
  Vec3 o2{0, 0, 2};  // starting inside: the next crossing ahead
  h = isect.intersect(o2, Vec3{1, 0, 0}, 1e-9);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->t, std::sqrt(20.0), 1e-9);
}

TEST(Asphere, SphericalLensesKeepTheQuadraticPath) {
  // A conic of k = 0 without polynomial terms is the sphere: the shape reports it, and the
  // general solver agrees with the sphere's closed form.
  SurfaceShape s;
  EXPECT_TRUE(s.isSpherical());
  s.poly = {0, 0, 0, 0, 0};
  EXPECT_TRUE(s.isSpherical());
  s.poly[4] = 1e-9;
  EXPECT_FALSE(s.isSpherical());
  const ShapeIntersector isect(30, SurfaceShape{.conic = 1e-300}, 10);
  for (double h : {0.0, 3.0, 7.0, 9.9}) {
    auto hit = isect.intersect(Vec3{h, 0, -5}, Vec3{0, 0, 1}, 0);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(hit->t - 5, sphericalSag(30, h), 1e-11) << h;
  }
}

TEST(Cylinder, SeparatePowersInXAndY) {
  // A cylinder curved in x only (radius_x 25 mm, flat in y) between air and glass.
  SurfaceShape cyl;
  cyl.radius_x_mm = 25.0;
  EXPECT_NEAR(vertexCurvatureX(0, cyl), 1 / 25.0, 1e-15);
  EXPECT_EQ(vertexCurvatureY(0, cyl), 0.0);
  const ShapeIntersector isect(0, cyl, 10);
  // Along y the surface is flat: hits at z = 0.
  auto h = isect.intersect(Vec3{0, 7, -3}, Vec3{0, 0, 1}, 0);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->t, 3.0, 1e-12);
  // Along x it is the circle of radius 25.
  h = isect.intersect(Vec3{7, 0, -3}, Vec3{0, 0, 1}, 0);
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->t - 3, sphericalSag(25, 7), 1e-11);
}
