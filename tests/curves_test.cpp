// pbrt's `curve` shape on Embree's curve primitives: conversion of pbrt's bases to cubic Bézier
// segments against the bases' closed forms, widths, areas, hits with their normals and (u, v), and
// a render whose image mean has a closed form (black curves against a uniform sky).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "lensim/render/shapes/accel.h"
#include "lensim/scene/curves.h"
#include "render_test_util.h"

namespace lensim::scene {
namespace {

constexpr double kPi = std::numbers::pi;

// Uniform B-spline segment bases, written from their textbook definitions.
Vec3 cubicBSpline(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, double t) {
  const double s = 1 - t;
  return (a * (s * s * s) + b * (3 * t * t * t - 6 * t * t + 4) +
          c * (-3 * t * t * t + 3 * t * t + 3 * t + 1) + d * (t * t * t)) /
         6.0;
}
Vec3 quadraticBSpline(const Vec3& a, const Vec3& b, const Vec3& c, double t) {
  return (a * ((1 - t) * (1 - t)) + b * (-2 * t * t + 2 * t + 1) + c * (t * t)) / 2.0;
}
Vec3 quadraticBezier(const Vec3& a, const Vec3& b, const Vec3& c, double t) {
  return a * ((1 - t) * (1 - t)) + b * (2 * t * (1 - t)) + c * (t * t);
}

TEST(Curve, SegmentCountsFollowPbrt) {
  EXPECT_EQ(curveSegmentCount(false, 3, 4), 1);
  EXPECT_EQ(curveSegmentCount(false, 3, 7), 2);
  EXPECT_EQ(curveSegmentCount(false, 3, 6), -1);
  EXPECT_EQ(curveSegmentCount(false, 2, 5), 2);
  EXPECT_EQ(curveSegmentCount(true, 3, 6), 3);
  EXPECT_EQ(curveSegmentCount(true, 2, 3), 1);
  EXPECT_EQ(curveSegmentCount(true, 3, 3), -1);
  EXPECT_EQ(curveSegmentCount(false, 4, 5), -1);
}

TEST(Curve, BasesConvertExactlyToCubicBezier) {
  const std::vector<Vec3> P = {{0, 0, 0}, {1, 2, 0}, {2, -1, 1}, {3, 0, 2}, {4, 3, 0}};
  const Curve cb = makeCurve(CurveKind::Flat, true, 3, P, 1, 1, {});
  ASSERT_EQ(cb.segments(), 2u);
  const Curve qb = makeCurve(CurveKind::Flat, true, 2, P, 1, 1, {});
  ASSERT_EQ(qb.segments(), 3u);
  const Curve qz = makeCurve(CurveKind::Flat, false, 2, P, 1, 1, {});
  ASSERT_EQ(qz.segments(), 2u);
  double worst = 0;
  for (double t = 0; t <= 1.0; t += 0.125) {
    for (size_t s = 0; s < 2; ++s)
      worst = std::max(worst, length(curvePoint(cb, s, t) -
                                     cubicBSpline(P[s], P[s + 1], P[s + 2], P[s + 3], t)));
    for (size_t s = 0; s < 3; ++s)
      worst = std::max(
          worst, length(curvePoint(qb, s, t) - quadraticBSpline(P[s], P[s + 1], P[s + 2], t)));
    for (size_t s = 0; s < 2; ++s)
      worst = std::max(worst, length(curvePoint(qz, s, t) -
                                     quadraticBezier(P[2 * s], P[2 * s + 1], P[2 * s + 2], t)));
  }
  EXPECT_LT(worst, 1e-12);
  // The tangent against a central difference.
  const Vec3 fd = (curvePoint(cb, 1, 0.3 + 1e-6) - curvePoint(cb, 1, 0.3 - 1e-6)) / 2e-6;
  EXPECT_LT(length(fd - curveTangent(cb, 1, 0.3)), 1e-6);
}

TEST(Curve, WidthIsLinearFromWidth0ToWidth1AcrossSegments) {
  const std::vector<Vec3> P = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0},
                               {4, 0, 0}, {5, 0, 0}, {6, 0, 0}};
  const Curve c = makeCurve(CurveKind::Flat, false, 3, P, 1, 3, {});
  EXPECT_NEAR(curveWidth(c, 0, 0), 1, 1e-12);
  EXPECT_NEAR(curveWidth(c, 0, 0.5), 1.5, 1e-12);
  EXPECT_NEAR(curveWidth(c, 1, 1), 3, 1e-12);
  // A straight band of length 6 and mean width 2: area 12; a tube of the same: 12 pi.
  EXPECT_NEAR(curveArea(c), 12, 1e-9);
  const Curve tube = makeCurve(CurveKind::Cylinder, false, 3, P, 1, 3, {});
  EXPECT_NEAR(curveArea(tube), 12 * kPi, 1e-8);
  // A quarter circle of radius 1 (quadratic Bézier is not a circle; use the arc length of the
  // parabola y = x^2 from 0 to 1 instead: (2 sqrt5 + asinh 2)/4), width 0.1.
  const Curve para =
      makeCurve(CurveKind::Flat, false, 2, {{0, 0, 0}, {0.5, 0, 0}, {1, 1, 0}}, 0.1, 0.1, {});
  EXPECT_NEAR(curveArea(para), 0.1 * (2 * std::sqrt(5.0) + std::asinh(2.0)) / 4, 1e-9);
}

const char* kHeader = R"(LookAt 0 0 5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-2 2 -2 2]
Film "rgb" "integer xresolution" 64 "integer yresolution" 64 "string filename" "c.exr"
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
)";

TEST(Curve, HitsLieOnTheCurveWithPbrtNormals) {
  const Scene s = testutil::buildText(std::string(kHeader) + R"(
Shape "curve" "point3 P" [-1 0 0  -0.3333333 0 0  0.3333333 0 0  1 0 0] "float width" 0.2
Shape "curve" "point3 P" [-1 1 0  -0.3333333 1 0  0.3333333 1 0  1 1 0] "float width" 0.2
  "string type" "cylinder"
Shape "curve" "point3 P" [-1 -1 0  -0.3333333 -1 0  0.3333333 -1 0  1 -1 0] "float width" 0.2
  "string type" "ribbon" "normal N" [0 0.6 0.8  0 0.6 0.8]
)");
  ASSERT_EQ(testutil::errorsOf(s), "");
  for (const Diagnostic& d : s.diagnostics) ADD_FAILURE() << d.str();
  render::Accel accel(s);
  // Flat: seen from above at y = 0.05 (inside the half-width 0.1), the normal faces the ray.
  auto h = accel.intersect({{0.5, 0.05, 3}, {0, 0, -1}, INFINITY});
  ASSERT_TRUE(h);
  EXPECT_EQ(h->shape, 0);
  EXPECT_NEAR(h->p.z, 0, 1e-4);
  EXPECT_NEAR(dot(h->ng, Vec3{0, 0, 1}), 1, 1e-6);
  EXPECT_NEAR(h->uv.x, 0.75, 1e-3);
  EXPECT_NEAR(std::abs(h->uv.y - 0.5), 0.25, 0.02);  // 0.05 of the half-width 0.1 off the middle
  EXPECT_NEAR(length(h->dpdu - Vec3{2, 0, 0}), 0, 1e-3);
  EXPECT_NEAR(length(h->dpdv), 0.2, 1e-6);
  EXPECT_FALSE(accel.intersect({{0.5, 0.12, 3}, {0, 0, -1}, INFINITY}));
  // Cylinder of radius 0.1 about y = 1: at y offset 0.05 the tube's top is at z = sqrt(0.0075)
  // with normal (0, 0.5, sqrt(0.75)).
  h = accel.intersect({{0.2, 1.05, 3}, {0, 0, -1}, INFINITY});
  ASSERT_TRUE(h);
  EXPECT_EQ(h->shape, 1);
  EXPECT_NEAR(h->p.z, std::sqrt(0.0075), 2e-3);
  EXPECT_NEAR(std::abs(dot(h->ng, Vec3{0, 0.5, std::sqrt(0.75)})), 1, 1e-3);
  // Ribbon tilted by its normal (0, 0.6, 0.8): seen from above its band spans 0.2 * 0.8 in y.
  h = accel.intersect({{0, -1.05, 3}, {0, 0, -1}, INFINITY});
  ASSERT_TRUE(h);
  EXPECT_EQ(h->shape, 2);
  EXPECT_NEAR(std::abs(dot(h->ng, Vec3{0, 0.6, 0.8})), 1, 1e-3);
  // The ribbon plane through (0, -1, 0) with normal (0, 0.6, 0.8).
  EXPECT_NEAR(dot(h->p - Vec3{0, -1, 0}, Vec3{0, 0.6, 0.8}), 0, 1e-3);
  EXPECT_FALSE(accel.intersect({{0, -1.09, 3}, {0, 0, -1}, INFINITY}));
}

TEST(Curve, BlackCurvesAgainstAUniformSkyCoverLengthTimesWidth) {
  // Straight curves that cross the whole screen (4 x 4), so their ends are outside it: each
  // covers 4 w (flat, cylinder; a ribbon facing the camera likewise).
  auto mean = [](const std::string& shape) {
    const std::string text = std::string(kHeader) + R"(LightSource "infinite" "rgb L" [1 1 1]
Material "diffuse" "rgb reflectance" [0 0 0]
)" + shape + "\n";
    const io::Image im = testutil::renderText(text).image;
    return testutil::regionMean(im, 1, 0, 64, 0, 64);
  };
  const double sky = mean("");
  ASSERT_GT(sky, 0.1);
  const std::string P = R"("point3 P" [-3 0.3 0  -1 0.3 0  1 0.3 0  3 0.3 0] "float width" 0.5)";
  EXPECT_NEAR(mean("Shape \"curve\" " + P) / sky, 1 - 4 * 0.5 / 16, 4e-3);
  EXPECT_NEAR(mean("Shape \"curve\" \"string type\" \"cylinder\" " + P) / sky, 1 - 4 * 0.5 / 16,
              4e-3);
  EXPECT_NEAR(
      mean("Shape \"curve\" \"string type\" \"ribbon\" \"normal N\" [0 0 1  0 0 1] " + P) / sky,
      1 - 4 * 0.5 / 16, 4e-3);
  // A B-spline of the same line with width0 0.2 to width1 0.6 (mean 0.4 over the screen, whose
  // part of the curve is the middle of three equal segments).
  EXPECT_NEAR(mean(R"(Shape "curve" "string basis" "bspline" "float width0" 0.2 "float width1" 0.6
      "point3 P" [-5 0 0  -3 0 0  -1 0 0  1 0 0  3 0 0  5 0 0])") /
                  sky,
              1 - 4 * 0.4 / 16, 4e-3);
}

TEST(Curve, BadCurvesAreErrors) {
  auto err = [](const std::string& shape) {
    try {
      return testutil::errorsOf(testutil::buildText("WorldBegin\n" + shape + "\n"));
    } catch (const Error& e) {
      return std::string(e.what());
    }
  };
  EXPECT_NE(err(R"(Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0])").find("needs 4 + n * 3"),
            std::string::npos);
  EXPECT_NE(err(R"(Shape "curve" "string type" "ribbon" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0])")
                .find("normals"),
            std::string::npos);
  EXPECT_NE(err(R"(Shape "curve" "integer degree" 4 "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0 4 0 0])")
                .find("degree 4"),
            std::string::npos);
  EXPECT_NE(err(R"(Shape "curve" "string basis" "hermite" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0])")
                .find("hermite"),
            std::string::npos);
}

}  // namespace
}  // namespace lensim::scene

namespace lensim::scene {
namespace {

TEST(Curve, TestSceneLoadsAndRendersWithoutDiagnostics) {
  const Scene s =
      build(parseFile(std::string(LENSIM_SOURCE_DIR) + "/tests/data/shapes/curves.pbrt"));
  for (const Diagnostic& d : s.diagnostics) ADD_FAILURE() << d.str();
  ASSERT_EQ(s.curves.size(), 3u);
  EXPECT_EQ(s.curves[0].kind, CurveKind::Flat);
  EXPECT_EQ(s.curves[1].kind, CurveKind::Cylinder);
  EXPECT_EQ(s.curves[1].segments(), 2u);
  EXPECT_EQ(s.curves[2].kind, CurveKind::Ribbon);
  EXPECT_EQ(s.curves[2].normal.size(), 4u);
  const render::RenderResult r = render::render(s, {});
  const double mean = testutil::regionMean(r.image, 1, 0, 32, 0, 24);
  EXPECT_TRUE(std::isfinite(mean));
  EXPECT_GT(mean, 0.05);
}

}  // namespace
}  // namespace lensim::scene
