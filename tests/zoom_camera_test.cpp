// The realistic camera's zoom parameters: "integer configuration" and "float focallength".
#include <gtest/gtest.h>

#include "lensim/camera/camera.h"
#include "lensim/camera/realistic.h"
#include "scene_test_util.h"
#include "test_paths.h"

namespace {

using lensim::camera::RealisticCamera;

std::unique_ptr<lensim::camera::Camera> zoomCamera(const std::string& params,
                                                   lensim::scene::Scene* keep) {
  *keep = lensim::testutil::buildText(
      "Camera \"realistic\" \"string lensfile\" \"" +
      lensim::test::dataPath("lenses/nikon_zoom_80_200.zmx") + "\" " + params +
      "\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n");
  return lensim::camera::makeCamera(*keep);
}

double eflOf(const lensim::camera::Camera& c) {
  const auto* r = dynamic_cast<const RealisticCamera*>(&c);
  EXPECT_NE(r, nullptr);
  return r ? r->lens().paraxial.effective_focal_length_mm : 0;
}

TEST(ZoomCamera, FocalLengthAndConfiguration) {
  lensim::scene::Scene s;
  // The requested focal length is reached (interpolation solved on the paraxial EFL).
  EXPECT_NEAR(eflOf(*zoomCamera("\"float focallength\" [100]", &s)), 100.0, 1e-6);
  // Configuration 3: 200.3069 mm by a y-nu trace of the published table (docs/zoom.md).
  EXPECT_NEAR(eflOf(*zoomCamera("\"integer configuration\" [3]", &s)), 200.3069, 1e-3);
  // Without either: the file's surface data (its active configuration, 1: 80.0886 mm).
  EXPECT_NEAR(eflOf(*zoomCamera("", &s)), 80.0886, 1e-3);
}

TEST(ZoomCamera, RefusalsNameTheParameter) {
  lensim::scene::Scene s;
  for (const char* p : {"\"float focallength\" [300]", "\"integer configuration\" [4]",
                        "\"integer configuration\" [2] \"float focallength\" [100]",
                        "\"float focallength\" [-5]"}) {
    // The scene builder collects parameter errors; the camera factory throws the lens's.
    std::string message;
    try {
      zoomCamera(p, &s);
      message = lensim::testutil::errorsOf(s);
    } catch (const lensim::Error& e) {
      message = e.what();
    }
    EXPECT_EQ(message.rfind("test.pbrt:1:", 0), 0u) << p << ": " << message;
    EXPECT_NE(message.find("error"), std::string::npos) << p << ": " << message;
  }
}

}  // namespace
