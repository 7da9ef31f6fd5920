// Renders of as-built lenses (issue 33, docs/design.md "Rendering as-built lenses"): the realistic
// camera's "string tolerances" and "integer asbuilt" render through exactly the Monte Carlo build
// that `lensim lens tolerance --write-builds` writes.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cli_run.h"
#include "lensim/camera/camera.h"
#include "lensim/camera/realistic.h"
#include "lensim/camera/realistic_placed.h"
#include "lensim/optics/lens_formats.h"
#include "scene_test_util.h"

namespace {

using lensim::camera::RealisticCamera;
namespace fs = std::filesystem;

// A singlet behind a stop, toleranced in radius, thickness and index (normal, end-point and
// uniform draws), back-focus compensated.
const char* kSinglet =
    "# singlet\n"
    "0      5    1       20\n"
    "80     4    1.5168  30  -  schott:N-BK7\n"
    "-120   90   1       30\n";

const char* kJob = R"({
  "lens": "singlet.dat",
  "fields_deg": [0, 5],
  "tolerancing": {
    "criterion": "rms_spot", "compensator": "back_focus", "monte_carlo": 20, "seed": 42,
    "tolerances": [
      {"type": "radius", "surface": 1, "delta": 2.0},
      {"type": "radius", "surface": 2, "delta": 2.0, "distribution": "normal"},
      {"type": "thickness", "surface": 1, "delta": 0.3, "distribution": "end_point"},
      {"type": "index", "surface": 1, "delta": 0.002, "distribution": "normal"}
    ]
  }
}
)";

void writeFile(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

class AsBuilt : public ::testing::Test {
 protected:
  void SetUp() override {
    writeFile(dir_.path() / "singlet.dat", kSinglet);
    writeFile(dir_.path() / "job.json", kJob);
  }
  std::string scenePath() const { return (dir_.path() / "scene.pbrt").string(); }
  // The scene's realistic camera with `params` after the lens file.
  std::unique_ptr<lensim::camera::Camera> camera(const std::string& params) {
    scene_ = lensim::testutil::buildText(
        "Camera \"realistic\" \"string lensfile\" \"singlet.dat\" \"float aperturediameter\" 10 " +
            params + "\nFilm \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\nWorldBegin\n",
        scenePath());
    const std::string errors = lensim::testutil::errorsOf(scene_);
    if (!errors.empty()) throw lensim::Error(errors);
    return lensim::camera::makeCamera(scene_);
  }
  std::string errorOf(const std::string& params) {
    try {
      camera(params);
    } catch (const lensim::Error& e) {
      return e.what();
    }
    return "no error";
  }
  lensim::testutil::TempDir dir_{"lensim-as-built"};
  lensim::scene::Scene scene_;
};

TEST_F(AsBuilt, CameraLensIsTheBuildLensTolerenceWrites) {
  const fs::path builds = dir_.path() / "builds";
  const auto r = lensim::test::runLensim("lens tolerance " + (dir_.path() / "job.json").string() +
                                         " --builds-dir " + builds.string() + " --write-builds 6");
  ASSERT_EQ(r.status, 0) << r.out;
  const lensim::optics::LensPrescription nominal =
      lensim::optics::readLensFile((dir_.path() / "singlet.dat").string());
  for (int k : {0, 5}) {
    const lensim::optics::LensPrescription written =
        lensim::optics::readLensFile((builds / fmt::format("build-{:04d}.json", k)).string());
    const auto cam = camera(fmt::format("\"string tolerances\" \"job.json\" \"integer asbuilt\" {}", k));
    const auto* rc = dynamic_cast<const RealisticCamera*>(cam.get());
    ASSERT_NE(rc, nullptr);
    const lensim::optics::LensPrescription& used = rc->lens().lens->prescription();
    ASSERT_EQ(used.surfaces.size(), written.surfaces.size());
    bool differs_from_nominal = false;
    for (size_t i = 0; i < used.surfaces.size(); ++i) {
      const auto& a = used.surfaces[i];
      const auto& b = written.surfaces[i];
      // The JSON stores doubles in shortest round-trip form: equal to the last bit.
      EXPECT_DOUBLE_EQ(a.radius_mm, b.radius_mm) << "build " << k << " row " << i;
      EXPECT_NEAR(a.thickness_mm, b.thickness_mm, 1e-9) << "build " << k << " row " << i;
      EXPECT_EQ(a.glass.n_d.has_value(), b.glass.n_d.has_value()) << "row " << i;
      if (a.glass.n_d && b.glass.n_d) {
        EXPECT_DOUBLE_EQ(*a.glass.n_d, *b.glass.n_d) << "build " << k << " row " << i;
        EXPECT_DOUBLE_EQ(a.glass.v_d.value_or(0), b.glass.v_d.value_or(0));
      }
      if (a.radius_mm != nominal.surfaces[i].radius_mm ||
          a.thickness_mm != nominal.surfaces[i].thickness_mm)
        differs_from_nominal = true;
    }
    EXPECT_TRUE(differs_from_nominal) << "build " << k;
    // The film: where the build's compensator put it (its last thickness), as no focusdistance
    // or filmdistance is given.
    EXPECT_NEAR(rc->lens().lens->filmDistance_mm(), written.surfaces.back().thickness_mm, 1e-9);
    EXPECT_GT(std::abs(written.surfaces.back().thickness_mm - nominal.surfaces.back().thickness_mm),
              1e-3);
    // The index the camera traces at the d line is the build's perturbed index.
    ASSERT_TRUE(written.surfaces[1].glass.n_d.has_value());
    EXPECT_NE(*written.surfaces[1].glass.n_d, 1.5168);
  }
  // With a focus distance the scene refocuses the build: only the film distance changes.
  const auto cam = camera("\"string tolerances\" \"job.json\" \"integer asbuilt\" 5 \"float focusdistance\" 2");
  const auto& used = dynamic_cast<const RealisticCamera&>(*cam).lens().lens->prescription();
  const auto written = lensim::optics::readLensFile((builds / "build-0005.json").string());
  EXPECT_DOUBLE_EQ(used.surfaces[1].radius_mm, written.surfaces[1].radius_mm);
  EXPECT_GT(std::abs(dynamic_cast<const RealisticCamera&>(*cam).lens().lens->filmDistance_mm() -
                     written.surfaces.back().thickness_mm),
            0.5);
}

TEST_F(AsBuilt, RefusalsNameTheParameter) {
  // A build beyond the job's Monte Carlo run.
  std::string e = errorOf("\"string tolerances\" \"job.json\" \"integer asbuilt\" 20");
  EXPECT_NE(e.find("scene.pbrt:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("asbuilt 20: expected a build index from 0 to 19"), std::string::npos) << e;
  // One without the other.
  e = errorOf("\"integer asbuilt\" 2");
  EXPECT_NE(e.find("needs \"string tolerances\""), std::string::npos) << e;
  e = errorOf("\"string tolerances\" \"job.json\"");
  EXPECT_NE(e.find("needs \"integer asbuilt\""), std::string::npos) << e;
  e = errorOf("\"string tolerances\" \"job.json\" \"integer asbuilt\" -1");
  EXPECT_NE(e.find("-1: expected a build index >= 0"), std::string::npos) << e;
  // The scene's lens must be the job's.
  writeFile(dir_.path() / "other.dat", kSinglet);
  writeFile(dir_.path() / "job2.json", std::string(kJob).replace(std::string(kJob).find("singlet.dat"), 11, "other.dat"));
  e = errorOf("\"string tolerances\" \"job2.json\" \"integer asbuilt\" 1");
  EXPECT_NE(e.find("is not the design job's lens"), std::string::npos) << e;
  // An error in the job keeps the job's line (an irregularity of 0.002 fringes is accepted; on
  // the stop row it would not be, a negative delta is not).
  writeFile(dir_.path() / "job3.json",
            std::string(kJob).replace(std::string(kJob).find("\"index\", \"surface\": 1, \"delta\": 0.002"), 37,
                                      "\"irregularity\", \"surface\": 1, \"delta\": -2"));
  e = errorOf("\"string tolerances\" \"job3.json\" \"integer asbuilt\" 1");
  EXPECT_NE(e.find("job3.json:10:"), std::string::npos) << e;
  EXPECT_NE(e.find("\"delta\" -2 fringes must be > 0"), std::string::npos) << e;
}

TEST_F(AsBuilt, DecentredBuildRendersThroughThePlacedCamera) {
  // Element 1 decentred by exactly 0.05 mm (end-point draws): the build is not coaxial, so the
  // placed camera renders it, with the film on the build's compensated image surface.
  std::string job = kJob;
  const std::string index_row = "\"type\": \"index\", \"surface\": 1, \"delta\": 0.002";
  job.replace(job.find(index_row), index_row.size(),
              "\"type\": \"decentre\", \"axis\": \"x\", \"element\": 1, \"delta\": 0.05, "
              "\"distribution\": \"end_point\"");
  writeFile(dir_.path() / "job4.json", job);
  const auto cam = camera("\"string tolerances\" \"job4.json\" \"integer asbuilt\" 1");
  const auto* placed = dynamic_cast<const lensim::camera::PlacedRealisticCamera*>(cam.get());
  ASSERT_NE(placed, nullptr) << cam->describe();
  EXPECT_EQ(placed->filmOffset_mm(), 0.0);
  // Camera rays from the film centre get through the decentred lens (aimed at the whole rear
  // surface, 30 mm across, of which the 10 mm stop passes a few).
  int through = 0;
  for (int i = 0; i < 1024; ++i) {
    lensim::camera::CameraSample cs;
    cs.film_raster = {8, 8};
    cs.lens = {(i % 32 + 0.5) / 32, (i / 32 + 0.5) / 32};
    const auto ray = cam->generateRay(cs);
    through += ray && ray->weight > 0;
  }
  EXPECT_GT(through, 10);
  // A focusdistance refocuses the decentred build with real rays instead.
  const auto refocused =
      camera("\"string tolerances\" \"job4.json\" \"integer asbuilt\" 1 \"float focusdistance\" 2");
  const auto* p2 = dynamic_cast<const lensim::camera::PlacedRealisticCamera*>(refocused.get());
  ASSERT_NE(p2, nullptr);
  EXPECT_GT(std::abs(p2->filmOffset_mm()), 0.5);
}

}  // namespace
