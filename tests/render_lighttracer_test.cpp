// The light tracer against the path tracer: the two estimate the same image (camera.h's
// measurement convention), so renders of a small diffuse box must agree within noise for every
// camera: a per-block z-test (lensim compare's, Bonferroni-corrected) with the light tracer's
// noise from two seeds and the path tracer's from a render at fewer samples, and the image means
// within a few standard errors. The path tracer is the independent reference: it uses the
// cameras' generateRay and weights, the light tracer their importance and sampleWi.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "lensim/render/image_compare.h"
#include "lighttracer_test_util.h"
#include "render_test_util.h"

using namespace lensim;
using lensim::io::Image;
using lensim::render::RenderOptions;
using lensim::testutil::renderText;

namespace {

/// A diffuse box (white floor, ceiling and back wall, red and green side walls, a blue sphere)
/// lit by a square light under the ceiling, seen by `camera` (the lines after LookAt).
std::string box(const std::string& camera, const std::string& integrator, int res = 32,
                const char* wall = "0.7 0.1 0.1") {
  return fmt::format(R"(
LookAt 0 1 -3.2  0 1 0  0 1 0
{}
Film "rgb" "integer xresolution" {} "integer yresolution" {} "string filename" "b.exr"
PixelFilter "box"
Sampler "independent"
Integrator "{}" "integer maxdepth" 5
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [6 6 6]
  Shape "trianglemesh" "point3 P" [-0.3 1.99 -0.3  0.3 1.99 -0.3  0.3 1.99 0.3  -0.3 1.99 0.3]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.7 0.7 0.7]
Shape "trianglemesh" "point3 P" [-1 0 -1  1 0 -1  1 0 1  -1 0 1  -1 2 -1  1 2 -1  1 2 1  -1 2 1]
  "integer indices" [0 2 1 0 3 2  4 5 6 4 6 7  3 7 6 3 6 2]
Material "diffuse" "rgb reflectance" [{}]
Shape "trianglemesh" "point3 P" [-1 0 -1  -1 0 1  -1 2 1  -1 2 -1] "integer indices" [0 2 1 0 3 2]
Material "diffuse" "rgb reflectance" [0.1 0.7 0.1]
Shape "trianglemesh" "point3 P" [1 0 -1  1 0 1  1 2 1  1 2 -1] "integer indices" [0 1 2 0 2 3]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.8]
AttributeBegin
  Translate 0.3 0.35 0.2
  Shape "sphere" "float radius" 0.35
AttributeEnd
)",
                     camera, res, res, integrator, wall);
}

using testutil::LtComparison;
using testutil::compareLightTracer;

void expectAgree(const LtComparison& c, const std::string& what) {
  std::printf("%s: %s\n", what.c_str(), c.summary().c_str());
  EXPECT_EQ(c.result.z_failures, 0) << what << "\n" << render::formatCompare(c.result);
  EXPECT_LT(std::abs(c.mean_z), 4.0) << what << ": " << c.summary();
}

}  // namespace

TEST(LightTracer, PinholeAgreesWithPath) {
  const std::string cam = R"(Camera "perspective" "float fov" 45)";
  expectAgree(compareLightTracer([&](const char* i) { return box(cam, i); }, 8, 64),
              "pinhole");
}

TEST(LightTracer, ThinLensAgreesWithPath) {
  const std::string cam =
      R"(Camera "perspective" "float fov" 45 "float lensradius" 0.08 "float focaldistance" 3)";
  expectAgree(compareLightTracer([&](const char* i) { return box(cam, i); }, 8, 64),
              "thin lens");
}

TEST(LightTracer, OrthographicAgreesWithPath) {
  const std::string cam =
      R"(Camera "orthographic" "float screenwindow" [-0.9 0.9 -0.9 0.9])";
  expectAgree(compareLightTracer([&](const char* i) { return box(cam, i); }, 8, 64),
              "orthographic");
  const std::string thin =
      R"(Camera "orthographic" "float screenwindow" [-0.9 0.9 -0.9 0.9] "float lensradius" 0.1 "float focaldistance" 3)";
  expectAgree(compareLightTracer([&](const char* i) { return box(thin, i); }, 8, 64),
              "orthographic thin lens");
}

TEST(LightTracer, SphericalAgreesWithPath) {
  // The camera inside the box, so that most directions see a wall.
  auto inside = [](const std::string& mapping, const char* integrator) {
    std::string s = box(R"(Camera "spherical" "string mapping" ")" + mapping + "\"", integrator);
    // Up along +x: the poles (where the equirectangular density diverges) face the side walls.
    s.replace(s.find("LookAt 0 1 -3.2  0 1 0  0 1 0"), 29, "LookAt 0 1 -0.5  0 1 1  1 0 0");
    return s;
  };
  expectAgree(
      compareLightTracer([&](const char* i) { return inside("equirectangular", i); }, 8, 64),
      "spherical equirectangular");
  expectAgree(compareLightTracer([&](const char* i) { return inside("equalarea", i); }, 8, 64),
              "spherical equal-area");
}

// The comparison can fail: a wall of another colour is found.
TEST(LightTracer, ComparisonFindsADifferentScene) {
  const std::string cam = R"(Camera "perspective" "float fov" 45)";
  const LtComparison c = compareLightTracer(
      [&](const char* i) {
        return box(cam, i, 32, std::string(i) == "lighttracer" ? "0.7 0.7 0.7" : "0.7 0.1 0.1");
      },
      8, 64);
  std::printf("white wall vs red: %s\n", c.summary().c_str());
  EXPECT_GT(c.result.z_failures, 0);
}

// A Gaussian filter (wider than a pixel, reaching past the image edge): splats are filtered as
// the path tracer's samples are.
TEST(LightTracer, GaussianFilterAgreesWithPath) {
  const std::string cam = R"(Camera "perspective" "float fov" 45)";
  expectAgree(compareLightTracer(
                  [&](const char* i) {
                    std::string s = box(cam, i);
                    s.replace(s.find("PixelFilter \"box\""), 17, "PixelFilter \"gaussian\"");
                    return s;
                  },
                  8, 64),
              "gaussian filter");
}

// Deterministic whatever the number of threads (exact fixed-point splat sums).
TEST(LightTracer, SameImageWithAnyThreadCount) {
  const std::string s = box(R"(Camera "perspective" "float fov" 45)", "lighttracer", 16);
  RenderOptions o;
  o.spp = 4;
  o.threads = 1;
  const Image a = renderText(s, o).image;
  o.threads = 3;
  const Image b = renderText(s, o).image;
  EXPECT_EQ(a.pixels, b.pixels);
}

// What a light tracer cannot do is refused with a clear error.
TEST(LightTracer, RefusesTilesAndCheckpoints) {
  const std::string s = box(R"(Camera "perspective" "float fov" 45)", "lighttracer", 16);
  RenderOptions o;
  o.spp = 1;
  o.tile = {{0, 2}};
  try {
    renderText(s, o);
    FAIL() << "a tile of a light-traced render was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--tile"), std::string::npos) << e.what();
  }
}

