// The perspective, orthographic and spherical cameras: geometry of the rays they generate.
#include <gtest/gtest.h>

#include <cmath>

#include "lensim/camera/camera.h"
#include "lensim/camera/projective.h"
#include "scene_test_util.h"

using lensim::Vec2;
using lensim::Vec3;
using lensim::camera::CameraSample;

namespace {

std::unique_ptr<lensim::camera::Camera> cameraOf(const std::string& text,
                                                 lensim::scene::Scene* keep) {
  *keep = lensim::testutil::buildText(text + "\nWorldBegin\n");
  return lensim::camera::makeCamera(*keep);
}

double angleDeg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(dot(normalize(a), normalize(b)), -1.0, 1.0)) * 180 / M_PI;
}

}  // namespace

TEST(PerspectiveCamera, FovSpansTheShorterAxis) {
  lensim::scene::Scene s;
  auto cam = cameraOf(R"(LookAt 1 2 3  1 2 4  0 1 0
Camera "perspective" "float fov" 50
Film "rgb" "integer xresolution" 200 "integer yresolution" 100)",
                      &s);
  const auto centre = cam->generateRay({Vec2{100, 50}});
  ASSERT_TRUE(centre);
  EXPECT_NEAR(length(centre->origin - Vec3{1, 2, 3}), 0, 1e-12);
  EXPECT_NEAR(angleDeg(centre->direction, {0, 0, 1}), 0, 1e-9);
  // The shorter (vertical) axis spans 50 degrees: the top edge is 25 degrees up.
  const auto top = cam->generateRay({Vec2{100, 0}});
  EXPECT_NEAR(angleDeg(top->direction, {0, 0, 1}), 25, 1e-9);
  EXPECT_GT(top->direction.y, 0);  // raster y down is world up
  // The right edge: tan(half angle) = 2 tan(25 degrees); +x in camera space is world +x here
  // (pbrt's LookAt: right = up x dir).
  const auto right = cam->generateRay({Vec2{200, 50}});
  EXPECT_NEAR(std::tan(angleDeg(right->direction, {0, 0, 1}) * M_PI / 180),
              2 * std::tan(25 * M_PI / 180), 1e-9);
  EXPECT_GT(right->direction.x, 0);
  EXPECT_EQ(centre->weight, 1);
}

TEST(PerspectiveCamera, ThinLensRaysMeetOnThePlaneOfFocus) {
  lensim::scene::Scene s;
  auto cam = cameraOf(R"(Camera "perspective" "float fov" 40 "float lensradius" 0.1
  "float focaldistance" 3
Film "rgb" "integer xresolution" 64 "integer yresolution" 64)",
                      &s);
  for (Vec2 raster : {Vec2{32, 32}, Vec2{5, 60}}) {
    Vec3 first;
    for (int i = 0; i < 8; ++i) {
      CameraSample cs{raster, Vec2{(i + 0.5) / 8, std::fmod(i * 0.618, 1.0)}};
      const auto r = cam->generateRay(cs);
      ASSERT_TRUE(r);
      EXPECT_NEAR(r->origin.z, 0, 1e-12);
      const Vec3 p = r->origin + r->direction * ((3 - r->origin.z) / r->direction.z);
      if (i == 0) first = p;
      EXPECT_NEAR(length(p - first), 0, 1e-9);
    }
  }
}

TEST(OrthographicCamera, ParallelRaysOverTheScreenWindow) {
  lensim::scene::Scene s;
  auto cam = cameraOf(R"(Camera "orthographic" "float screenwindow" [-2 2 -1 1]
Film "rgb" "integer xresolution" 40 "integer yresolution" 20)",
                      &s);
  const auto a = cam->generateRay({Vec2{0, 0}}), b = cam->generateRay({Vec2{40, 20}});
  EXPECT_NEAR(length(a->direction - Vec3{0, 0, 1}), 0, 1e-12);
  EXPECT_NEAR(length(b->direction - Vec3{0, 0, 1}), 0, 1e-12);
  EXPECT_NEAR(length(a->origin - Vec3{-2, 1, 0}), 0, 1e-12);
  EXPECT_NEAR(length(b->origin - Vec3{2, -1, 0}), 0, 1e-12);
}

TEST(SphericalCamera, CoversEveryDirection) {
  lensim::scene::Scene s;
  auto cam = cameraOf(R"(Camera "spherical" "string mapping" "equirectangular"
Film "rgb" "integer xresolution" 40 "integer yresolution" 20)",
                      &s);
  // Top row: the camera's +y pole; bottom: -y; middle row: the horizon.
  EXPECT_NEAR(cam->generateRay({Vec2{10, 0}})->direction.y, 1, 1e-12);
  EXPECT_NEAR(cam->generateRay({Vec2{10, 20}})->direction.y, -1, 1e-12);
  // Uniform raster samples weighted by sin(theta) cover the sphere uniformly: the mean
  // direction is 0.
  Vec3 sum{0, 0, 0};
  double wsum = 0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 400; ++x) {
      const auto r = cam->generateRay({Vec2{(x + 0.5) / 10, (y + 0.5) / 10}});
      const double w = std::sin(M_PI * (y + 0.5) / 200);
      sum += r->direction * w;
      wsum += w;
    }
  EXPECT_NEAR(length(sum) / wsum, 0, 1e-6);
}

TEST(CameraFactory, RejectsImpossibleSettingsWithTheirLocation) {
  lensim::scene::Scene s;
  try {
    cameraOf("Camera \"perspective\" \"float fov\" 0", &s);
    FAIL() << "fov 0 accepted";
  } catch (const lensim::Error& e) {
    EXPECT_EQ(e.loc().line, 1);
    EXPECT_NE(std::string(e.what()).find("fov"), std::string::npos);
  }
}

TEST(SphericalCamera, EqualAreaMappingCoversEveryDirectionUniformly) {
  lensim::scene::Scene s;
  auto cam = cameraOf(R"(Camera "spherical"
Film "rgb" "integer xresolution" 32 "integer yresolution" 32)",
                      &s);
  // Equal raster areas are equal solid angles: the mean of unweighted directions is 0 and the
  // mean of y^2 is 1/3 (uniform on the sphere).
  Vec3 sum{0, 0, 0};
  double yy = 0;
  int n = 0;
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) {
      const auto r = cam->generateRay({Vec2{(x + 0.5) / 8, (y + 0.5) / 8}});
      sum += r->direction;
      yy += r->direction.y * r->direction.y;
      ++n;
    }
  EXPECT_NEAR(length(sum) / n, 0, 1e-3);
  EXPECT_NEAR(yy / n, 1.0 / 3, 2e-3);
  EXPECT_NE(cam->describe().find("equal-area"), std::string::npos);
}
