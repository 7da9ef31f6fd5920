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

#include "lensim/camera/camera.h"
#include "lensim/render/image_compare.h"
#include "lighttracer_test_util.h"
#include "render_test_util.h"
#include "test_paths.h"

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

using testutil::compareLightTracer;
using testutil::LtComparison;

/// The z-test passes (at most max_fail blocks beyond the Bonferroni bound) and the image means
/// agree within 4 standard errors.
void expectAgree(const LtComparison& c, const std::string& what, int max_fail = 0) {
  std::printf("%s: %s\n", what.c_str(), c.summary().c_str());
  EXPECT_LE(c.result.z_failures, max_fail) << what << "\n" << render::formatCompare(c.result);
  EXPECT_LT(std::abs(c.mean_z), 4.0) << what << ": " << c.summary();
}

}  // namespace

TEST(LightTracer, PinholeAgreesWithPath) {
  const std::string cam = R"(Camera "perspective" "float fov" 45)";
  expectAgree(compareLightTracer([&](const char* i) { return box(cam, i); }, 8, 64), "pinhole");
}

TEST(LightTracer, ThinLensAgreesWithPath) {
  const std::string cam =
      R"(Camera "perspective" "float fov" 45 "float lensradius" 0.08 "float focaldistance" 3)";
  expectAgree(compareLightTracer([&](const char* i) { return box(cam, i); }, 8, 64), "thin lens");
}

TEST(LightTracer, OrthographicAgreesWithPath) {
  const std::string cam = R"(Camera "orthographic" "float screenwindow" [-0.9 0.9 -0.9 0.9])";
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

namespace {

/// The realistic camera with a lens of ../shared/lenses at full aperture (the stop's diameter;
/// pbrt-v4's default is 1 mm), focused at 3 m.
std::string realisticCamera(const std::string& lens) {
  const double stop = lens == "dgauss.50mm.dat"    ? 17.1
                      : lens == "wide.22mm.dat"    ? 8.756
                      : lens == "fisheye.10mm.dat" ? 6.08
                                                   : 40.5;  // telephoto.250mm.dat
  return fmt::format(
      R"(Camera "realistic" "string lensfile" "{}" "float focusdistance" 3 "float aperturediameter" {})",
      lensim::test::lensPath(lens), stop);
}

/// Mean of the RGB average over a square of side n pixels at (x0, y0).
double squareMean(const Image& im, int x0, int y0, int n) {
  double s = 0;
  for (int y = y0; y < y0 + n; ++y)
    for (int x = x0; x < x0 + n; ++x)
      for (int c = 0; c < 3; ++c) s += im.at(x, y, c) / 3;
  return s / (n * n);
}

}  // namespace

// The realistic camera through the four classic lenses: light tracing (sampleWi through the
// lens backward, importance T / A_film in the etendue measure) and path tracing (generateRay,
// weight T cos^4 A / z^2) agree within noise. The film diagonal is 35 mm, the box at 3.2 m. The
// light tracer's noise through a lens is far from normal at these sample counts (a lens's narrow
// view sees few light-path vertices, and its half-images' per-pixel variances are heavy-tailed),
// so one block of 16 may pass the Bonferroni bound; the path tracer's noise is heavy-tailed too
// where the fisheye sees the small light directly (two 8192-spp path renders differ by 2.8%).
// Longer renders agree closer: double Gauss 6 x 256 spp light tracing against 8192 spp path,
// ratio 0.998 +- 0.003; fisheye 3 x 512 spp against 8192 spp, 0.996-0.999.
// That the comparison can fail: RealisticWrongExposureIsFound.
TEST(LightTracer, RealisticLensesAgreeWithPath) {
  for (const char* lens :
       {"dgauss.50mm.dat", "wide.22mm.dat", "fisheye.10mm.dat", "telephoto.250mm.dat"}) {
    SCOPED_TRACE(lens);
    const std::string cam = realisticCamera(lens);
    expectAgree(compareLightTracer([&](const char* i) { return box(cam, i, 16); }, 32, 128, 4),
                std::string("realistic ") + lens, 1);
  }
}

// Vignetting seen by both: an emitting wall (radiance 1) filling the view of the double
// Gauss at full aperture; the corners get less light than the centre (the lens's cos^4 and its
// mechanical vignetting), by the same amount in the light-traced and the path-traced image.
TEST(LightTracer, RealisticVignettingInBoth) {
  auto wall = [](const char* integrator) {
    return fmt::format(R"(
LookAt 0 0 0  0 0 1  0 1 0
{}
Film "rgb" "integer xresolution" 24 "integer yresolution" 24 "float diagonal" 43.3
PixelFilter "box"
Sampler "independent"
Integrator "{}" "integer maxdepth" 1
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "trianglemesh" "point3 P" [-1.6 -1.6 3  1.6 -1.6 3  1.6 1.6 3  -1.6 1.6 3]
    "integer indices" [0 2 1 0 3 2]
AttributeEnd
)",
                       realisticCamera("dgauss.50mm.dat"), integrator);
  };
  const LtComparison c = compareLightTracer(wall, 8, 64);
  expectAgree(c, "realistic vignetting", 1);
  RenderOptions o;
  o.spp = 32;
  o.seed = 5;
  const Image lt = renderText(wall("lighttracer"), o).image;
  const Image pt = renderText(wall("path"), o).image;
  for (const Image* im : {&lt, &pt}) {
    const double centre = squareMean(*im, 10, 10, 4), corner = squareMean(*im, 0, 0, 4);
    std::printf("vignetting (%s): corner / centre %.3f\n", im == &lt ? "light tracer" : "path",
                corner / centre);
    EXPECT_GT(centre, 0);
    EXPECT_LT(corner, 0.85 * centre);
  }
}

// Backward through the lens what generateRay traced forward: importance() of a camera ray finds
// the film point the ray was generated from (within float precision), and sampleWi from a point
// on that ray finds the same film point.
TEST(LightTracer, ImportanceRetracesCameraRays) {
  for (const char* lens :
       {"dgauss.50mm.dat", "wide.22mm.dat", "fisheye.10mm.dat", "telephoto.250mm.dat"}) {
    SCOPED_TRACE(lens);
    const scene::Scene s = testutil::buildText(
        "LookAt 0 1 -3.2  0 1 0  0 1 0\n" + realisticCamera(lens) +
            "\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n",
        "retrace.pbrt");
    const auto cam = camera::makeCamera(s);
    ASSERT_TRUE(cam->supportsImportance());
    int n_rays = 0, n_found = 0, n_outside = 0;
    double worst = 0;
    for (int i = 0; i < 400; ++i) {
      camera::CameraSample cs;
      cs.film_raster = {32 * ((i * 0.618034) - std::floor(i * 0.618034)),
                        32 * ((i * 0.754878) - std::floor(i * 0.754878))};
      cs.lens = {(i * 0.569840 + 0.1) - std::floor(i * 0.569840 + 0.1),
                 (i * 0.324718 + 0.3) - std::floor(i * 0.324718 + 0.3)};
      const auto ray = cam->generateRay(cs);
      if (!ray) continue;
      ++n_rays;
      Vec2 raster;
      const double w = cam->importance(ray->origin, ray->direction, 0, &raster, ray->time);
      if (w > 0) {
        ++n_found;
        worst =
            std::max(worst, std::hypot(raster.x - cs.film_raster.x, raster.y - cs.film_raster.y));
      }
      // sampleWi from points on the ray (3 m and 1 m out) can pick the ray's front point.
      for (double t : {3.0, 1.0})
        n_outside +=
            cam->pdfWiPos(ray->origin + ray->direction * t, ray->origin, ray->time) > 0 ? 0 : 1;
    }
    std::printf(
        "%s: %d of %d camera rays retraced, worst raster error %.2g px, %d of %d front "
        "points outside sampleWi's region\n",
        lens, n_found, n_rays, worst, n_outside, 2 * n_rays);
    EXPECT_GT(n_rays, 100);
    // The float tracer may stop a ray grazing a clear aperture's edge one way and not the
    // other: at most 1%.
    EXPECT_GE(n_found, n_rays - n_rays / 100);
    EXPECT_LT(worst, 0.01);
    EXPECT_EQ(n_outside, 0) << "camera rays whose front point sampleWi cannot pick";
  }
}

// The comparison of realistic renders can fail: the light tracer through the double Gauss at
// full aperture against the path tracer at 14 mm (2/3 of the exposure) is found.
TEST(LightTracer, RealisticWrongExposureIsFound) {
  const std::string lt = realisticCamera("dgauss.50mm.dat");
  std::string pt = lt;
  pt.replace(pt.find("aperturediameter\" 17.1"), 22, "aperturediameter\" 14.0");
  const LtComparison c = compareLightTracer(
      [&](const char* i) { return box(std::string(i) == "lighttracer" ? lt : pt, i, 16); }, 32, 128,
      4);
  std::printf("full aperture vs 14 mm: %s\n", c.summary().c_str());
  EXPECT_GT(c.result.z_failures, 1);
  EXPECT_GT(std::abs(c.mean_z), 4.0);
}
