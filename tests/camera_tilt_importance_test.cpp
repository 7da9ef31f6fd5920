// Camera importance of a tilted and shifted realistic lens (docs/zoom.md, "Tilt and shift"): the
// light tracer (sampleWi, importance) and bdpt (their densities: rayPdf, pdfWiPos, in its MIS
// weights) render what the path tracer renders (generateRay and its weights, checked on its own
// against an independent quadrature in camera_tilt_shift_test.cpp), per block of pixels within
// noise, for a flat field and a point-lit wall through the double Gauss tilted 8 degrees,
// shifted 5 mm, and both; and camera rays traced backward land on their own film points.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "lensim/camera/camera.h"
#include "lensim/render/image_compare.h"
#include "lighttracer_test_util.h"
#include "render_test_util.h"
#include "scene_test_util.h"
#include "test_paths.h"

using namespace lensim;

namespace {

struct Placement {
  const char* name;
  double tilt_x, tilt_y, shift_x, shift_y;
};
// Tilted 8 degrees, shifted 5 mm, and both (the shift's 5 mm along a diagonal).
constexpr Placement kPlacements[] = {
    {"tilt 8 deg", 8, 0, 0, 0}, {"shift 5 mm", 0, 0, 5, 0}, {"tilt and shift", 0, 8, 3, -4}};

std::string cameraText(const Placement& p) {
  return fmt::format(
      R"(Camera "realistic" "string lensfile" "{}" "float focusdistance" 3
  "float aperturediameter" 12 "float lenstilt" [{} {}] "float lensshift" [{} {}])",
      lensim::test::lensPath("dgauss.50mm.dat"), p.tilt_x, p.tilt_y, p.shift_x, p.shift_y);
}

// A wall of radiance 1 filling the view (a flat field), or a diffuse wall lit by a point light
// 1 m in front of it, off the axis (a lit patch whose falloff shows where the image lies).
std::string sceneText(const std::string& cam, const char* integrator, bool point_light) {
  const std::string world = point_light
                                ? R"(LightSource "point" "rgb I" [2 2 2] "point3 from" [0.25 0.15 2]
Material "diffuse" "rgb reflectance" [0.8 0.8 0.8]
Shape "trianglemesh" "point3 P" [-3 -3 3  3 -3 3  3 3 3  -3 3 3] "integer indices" [0 2 1 0 3 2]
)"
                                : R"(AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "trianglemesh" "point3 P" [-3 -3 3  3 -3 3  3 3 3  -3 3 3] "integer indices" [0 2 1 0 3 2]
AttributeEnd
)";
  return fmt::format(R"(
LookAt 0 0 0  0 0 1  0 1 0
{}
Film "rgb" "integer xresolution" 16 "integer yresolution" 12 "float diagonal" 43.3
PixelFilter "box" "float xradius" 0.5 "float yradius" 0.5
Sampler "independent"
Integrator "{}" "integer maxdepth" 1
WorldBegin
{})",
                     cam, integrator, world);
}

void expectAgree(const testutil::LtComparison& c, const std::string& what) {
  std::printf("%s: %s\n", what.c_str(), c.summary().c_str());
  // The light tracer's pixels are correlated (one light path splats into several): as in
  // render_lighttracer_test.cpp, one block may pass the Bonferroni bound.
  EXPECT_LE(c.result.z_failures, 1) << what << "\n" << render::formatCompare(c.result);
  EXPECT_LT(std::abs(c.mean_z), 4.0) << what << ": " << c.summary();
}

// bdpt (two renders of spp) against path (4 spp, its noise from a third render of spp), by the
// per-block z-test.
render::CompareResult bdptAgainstPath(const std::string& cam, bool point_light, int spp) {
  render::RenderOptions o;
  o.spp = spp;
  o.seed = 41;
  const io::Image a = testutil::renderText(sceneText(cam, "bdpt", point_light), o).image;
  o.seed = 42;
  const io::Image b = testutil::renderText(sceneText(cam, "bdpt", point_light), o).image;
  o.seed = 43;
  o.spp = 4 * spp;
  const io::Image ref = testutil::renderText(sceneText(cam, "path", point_light), o).image;
  o.seed = 44;
  o.spp = spp;
  const io::Image ref_low = testutil::renderText(sceneText(cam, "path", point_light), o).image;
  render::CompareOptions co;
  co.block = 4;
  co.second = &b;
  co.spp = spp;
  co.reference_spp = 4 * spp;
  co.reference_low = &ref_low;
  co.reference_low_spp = spp;
  return render::compareImages(a, ref, co);
}

}  // namespace

// Each placement: the light tracer (8 x 32 spp) against path (128 spp), and bdpt (2 x 32 spp)
// against path (128 spp), by blocks of 4 x 4 pixels.
void agreeThrough(const Placement& p) {
  const std::string cam = cameraText(p);
  for (bool point_light : {false, true}) {
    const std::string what =
        fmt::format("{}, {}", p.name, point_light ? "point light" : "flat field");
    SCOPED_TRACE(what);
    expectAgree(testutil::compareLightTracer(
                    [&](const char* i) { return sceneText(cam, i, point_light); }, 32, 128, 4),
                "light tracer, " + what);
    const render::CompareResult r = bdptAgainstPath(cam, point_light, 32);
    std::printf("bdpt, %s: %s", what.c_str(), render::formatCompare(r).c_str());
    EXPECT_LE(r.z_failures, 1) << render::formatCompare(r);
    EXPECT_EQ(r.outliers, 0) << render::formatCompare(r);
    EXPECT_NEAR(r.mean_ratio, 1.0, 0.03) << render::formatCompare(r);
  }
}

TEST(TiltShiftImportance, CentredAgreesWithPath) {
  agreeThrough({"centred", 0, 0, 0, 0});
}
TEST(TiltShiftImportance, TiltedAgreesWithPath) {
  agreeThrough({"tilt 8 deg", 8, 0, 0, 0});
}
TEST(TiltShiftImportance, ShiftedAgreesWithPath) {
  agreeThrough({"shift 5 mm", 0, 0, 5, 0});
}
TEST(TiltShiftImportance, TiltedAndShiftedAgreesWithPath) {
  agreeThrough({"tilt and shift", 0, 8, 3, -4});
  // "simpleweighting" (weights and importance scaled by z^2 / A0): the flat field.
  const std::string cam = cameraText({"", 0, 8, 3, -4}) + " \"bool simpleweighting\" true";
  expectAgree(testutil::compareLightTracer([&](const char* i) { return sceneText(cam, i, false); },
                                           32, 128, 4),
              "light tracer, tilt and shift, simple weighting, flat field");
}

// The comparison can fail: the light tracer through the shifted lens against the path tracer
// through the centred one (the lit patch lies 5 mm, about 4 pixels, elsewhere on the film).
TEST(TiltShiftImportance, UnshiftedReferenceIsFound) {
  const std::string lt = cameraText(kPlacements[1]), pt = cameraText({"centred", 0, 0, 0, 0});
  const testutil::LtComparison c = testutil::compareLightTracer(
      [&](const char* i) { return sceneText(std::string(i) == "lighttracer" ? lt : pt, i, true); },
      32, 128, 4);
  std::printf("shifted against centred: %s\n", c.summary().c_str());
  EXPECT_GT(c.result.z_failures, 1);
}

// Backward through the lens what generateRay traced forward: importance() of a camera ray finds
// the film point the ray was generated from, its densities are positive, and sampleWi from
// points on the ray can pick its front point.
TEST(TiltShiftImportance, ImportanceRetracesCameraRays) {
  for (const Placement& p : kPlacements) {
    SCOPED_TRACE(p.name);
    const scene::Scene s = testutil::buildText(
        "LookAt 0 0 0  0 0 1  0 1 0\n" + cameraText(p) +
            "\nFilm \"rgb\" \"integer xresolution\" 36 \"integer yresolution\" 24\nWorldBegin\n",
        "retrace.pbrt");
    const auto cam = camera::makeCamera(s);
    ASSERT_TRUE(cam->supportsImportance());
    int n_rays = 0, n_found = 0, n_outside = 0, n_pdf = 0;
    double worst = 0;
    for (int i = 0; i < 600; ++i) {
      camera::CameraSample cs;
      cs.film_raster = {36 * ((i * 0.618034) - std::floor(i * 0.618034)),
                        24 * ((i * 0.754878) - std::floor(i * 0.754878))};
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
      const camera::CameraRayPdf pdf = cam->rayPdf(ray->origin, ray->direction, 0, ray->time);
      n_pdf += pdf.pdf_pos > 0 && pdf.pdf_dir > 0 ? 1 : 0;
      for (double t : {3.0, 1.0})
        n_outside +=
            cam->pdfWiPos(ray->origin + ray->direction * t, ray->origin, ray->time) > 0 ? 0 : 1;
    }
    std::printf(
        "%s: %d of %d camera rays retraced (%d with densities), worst raster error %.2g "
        "px, %d of %d front points outside sampleWi's region\n",
        p.name, n_found, n_rays, n_pdf, worst, n_outside, 2 * n_rays);
    EXPECT_GT(n_rays, 150);
    EXPECT_GE(n_found, n_rays - n_rays / 100);
    EXPECT_GE(n_pdf, n_rays - n_rays / 100);
    EXPECT_LT(worst, 0.01);
    EXPECT_EQ(n_outside, 0) << "camera rays whose front point sampleWi cannot pick";
  }
}

// A ray held in the lens's frame meets the film exactly the shift farther (in raster units, the
// raster's x running along -x of the film): camera rays of the centred lens, moved with the lens
// by the shift, give the shifted camera's importance() that raster point.
TEST(TiltShiftImportance, ShiftMovesTheImportanceRasterByTheShift) {
  auto make = [](const Placement& p) {
    return camera::makeCamera(testutil::buildText(
        "LookAt 0 0 0  0 0 1  0 1 0\n" + cameraText(p) +
            "\nFilm \"rgb\" \"integer xresolution\" 36 \"integer yresolution\" 24 \"float "
            "diagonal\" 43.3\nWorldBegin\n",
        "shift.pbrt"));
  };
  const Vec2 s{2.5, -1.5};  // mm: small enough that the bounds of both cameras hold the rays
  const auto centred = make({"centred", 0, 0, 0, 0});
  const auto shifted = make({"shifted", 0, 0, s.x, s.y});
  const double pitch = 43.3 / std::hypot(36.0, 24.0);  // mm per pixel
  int checked = 0;
  double worst = 0;
  for (int i = 0; i < 300; ++i) {
    camera::CameraSample cs;
    cs.film_raster = {6 + 24 * ((i * 0.618034) - std::floor(i * 0.618034)),
                      4 + 16 * ((i * 0.754878) - std::floor(i * 0.754878))};
    cs.lens = {(i * 0.569840 + 0.1) - std::floor(i * 0.569840 + 0.1),
               (i * 0.324718 + 0.3) - std::floor(i * 0.324718 + 0.3)};
    const auto ray = centred->generateRay(cs);
    if (!ray) continue;
    Vec2 r0, r1;
    if (!(centred->importance(ray->origin, ray->direction, 0, &r0, ray->time) > 0)) continue;
    const Vec3 moved = ray->origin + Vec3{s.x, s.y, 0} * 1e-3;  // the lens moved in metres
    if (!(shifted->importance(moved, ray->direction, 0, &r1, ray->time) > 0)) continue;
    worst = std::max(worst, std::hypot(r1.x - (r0.x - s.x / pitch), r1.y - (r0.y + s.y / pitch)));
    ++checked;
  }
  std::printf("%d rays: raster moved by the shift within %.2g px\n", checked, worst);
  EXPECT_GT(checked, 200);
  EXPECT_LT(worst, 1e-3);
}
