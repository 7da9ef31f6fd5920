// The renderer as users run it: determinism across thread counts, crop windows and pixel bounds,
// the files `lensim render` writes, its errors, and every shared scene at low spp.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "cli_run.h"
#include "lensim/io/image.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "render_test_util.h"

using lensim::io::Image;
using lensim::render::RenderOptions;

namespace {

using Result = lensim::test::CliResult;

Result run(const std::string& args) {
  return lensim::test::runLensim(args);
}

const std::string kShared = LENSIM_SHARED_DIR;

/// A small scene with every kind of light and several materials and shapes.
const char* kScene = R"(
LookAt 0 1.5 -4  0 0.5 0  0 1 0
Camera "perspective" "float fov" 45
Film "rgb" "integer xresolution" 48 "integer yresolution" 36 "string filename" "scene.exr"
Sampler "zsobol" "integer pixelsamples" 8
Integrator "path" "integer maxdepth" 6
WorldBegin
LightSource "infinite" "rgb L" [0.1 0.12 0.15]
LightSource "spot" "rgb I" [4 4 4] "point3 from" [2 3 -2] "point3 to" [0 0 0]
LightSource "distant" "blackbody L" 5500 "point3 from" [-1 2 -1] "point3 to" [0 0 0] "float scale" 0.5
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [3 3 3]
  Translate 0 3 0
  Shape "disk" "float radius" 0.5
AttributeEnd
Texture "checks" "spectrum" "checkerboard" "float uscale" 4 "float vscale" 4
  "rgb tex1" [0.8 0.8 0.8] "rgb tex2" [0.1 0.1 0.1]
Material "diffuse" "texture reflectance" "checks"
Shape "bilinearmesh" "point3 P" [-3 0 -3  3 0 -3  -3 0 3  3 0 3]
Material "coateddiffuse" "rgb reflectance" [0.6 0.2 0.1] "float roughness" 0.05
Shape "sphere" "float radius" 0.5
AttributeBegin
  Translate 1.2 0 0
  Rotate -90 1 0 0
  Material "conductor" "spectrum eta" "metal-Cu-eta" "spectrum k" "metal-Cu-k" "float roughness" 0.2
  Shape "cylinder" "float radius" 0.3 "float zmin" 0 "float zmax" 1 "float phimax" 270
AttributeEnd
ObjectBegin "cone"
  Material "dielectric" "float eta" 1.5
  Rotate -90 1 0 0
  Shape "cone" "float radius" 0.3 "float height" 0.8
ObjectEnd
AttributeBegin
  Translate -1.2 0 0
  ObjectInstance "cone"
AttributeEnd
AttributeBegin
  Translate -1.2 0 1.2
  ObjectInstance "cone"
AttributeEnd
)";

}  // namespace

TEST(Render, IdenticalWhateverTheThreadCount) {
  RenderOptions o;
  o.threads = 1;
  const Image a = lensim::testutil::renderText(kScene, o).image;
  o.threads = 2;
  const Image b = lensim::testutil::renderText(kScene, o).image;
  o.threads = 5;
  const Image c = lensim::testutil::renderText(kScene, o).image;
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  EXPECT_TRUE(a.pixels == b.pixels);
  EXPECT_TRUE(a.pixels == c.pixels);
  double sum = 0;
  for (float v : a.pixels) sum += v;
  EXPECT_GT(sum, 0);
}

TEST(Render, CropWindowEqualsTheSamePixelsOfTheFullRender) {
  const Image full = lensim::testutil::renderText(kScene).image;
  RenderOptions o;
  o.crop = std::array<double, 4>{0.25, 0.6, 0.3, 0.9};
  const auto crop = lensim::testutil::renderText(kScene, o);
  // pbrt's rounding: ceil(48 * 0.25) = 12 .. ceil(48 * 0.6) = 29; ceil(36 * 0.3) = 11 .. 33.
  EXPECT_EQ(crop.bounds, (lensim::render::PixelBounds{12, 29, 11, 33}));
  ASSERT_EQ(crop.image.width, 17);
  ASSERT_EQ(crop.image.height, 22);
  for (int y = 0; y < crop.image.height; ++y)
    for (int x = 0; x < crop.image.width; ++x)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(crop.image.at(x, y, c), full.at(x + 12, y + 11, c)) << x << "," << y;
  o.crop.reset();
  o.pixelbounds = std::array<int, 4>{40, 48, 0, 5};
  const auto pb = lensim::testutil::renderText(kScene, o);
  ASSERT_EQ(pb.image.width, 8);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 8; ++x) ASSERT_EQ(pb.image.at(x, y, 1), full.at(x + 40, y, 1));
}

TEST(RenderCommand, WritesExrPngAndTiffThatReadBack) {
  lensim::testutil::TempDir dir("lensim-render-cli");
  const std::string scene = dir.write("scene.pbrt", kScene);
  for (const char* ext : {"exr", "png", "tif"}) {
    const std::string out = dir.file(std::string("out.") + ext);
    Result r = run("render " + scene + " --spp 4 --outfile " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("rays/s"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("NaN/inf samples"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("samples without ray  0"), std::string::npos) << r.out;
    const Image im = lensim::io::readImage(out);
    EXPECT_EQ(im.width, 48);
    EXPECT_EQ(im.height, 36);
    if (std::string(ext) == "exr") {
      EXPECT_EQ(im.metadata.count("lensim:partial"), 0u);
      EXPECT_EQ(im.metadata.at("lensim:spp"), "4");
    }
  }
  // The EXR holds the same values as the in-process render of the same settings.
  RenderOptions o;
  o.spp = 4;
  const Image mem = lensim::render::render(lensim::scene::loadScene(scene), o).image;
  const Image exr = lensim::io::readImage(dir.file("out.exr"));
  EXPECT_TRUE(mem.pixels == exr.pixels);
  // The film's filename is used without --outfile (relative to the working directory).
  Result r = run("render " + scene + " --spp 1 --quiet --cropwindow 0 0.5 0 0.5");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(std::filesystem::exists("scene.exr"));
  EXPECT_EQ(lensim::io::readImage("scene.exr").width, 24);
  std::filesystem::remove("scene.exr");
}

TEST(RenderCommand, ErrorsExitWithStatusOne) {
  lensim::testutil::TempDir dir("lensim-render-err");
  Result missing = run("render " + dir.file("none.pbrt") + " --quiet");
  EXPECT_EQ(missing.status, 1);
  Result ext = run("render " + dir.write("s.pbrt", kScene) + " --outfile " + dir.file("x.bmp"));
  EXPECT_EQ(ext.status, 1) << ext.out;
  const std::string fov = dir.write("fov.pbrt",
                                    "Camera \"perspective\" \"float fov\" 190\n"
                                    "WorldBegin\nShape \"sphere\"\n");
  Result bad = run("render " + fov + " --quiet");
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.out.find("fov.pbrt:1:1: error: perspective camera: fov 190"), std::string::npos)
      << bad.out;
}

TEST(RenderCommand, BadCropWindowSaysWhichValueAndWhatIsExpected) {
  lensim::testutil::TempDir dir("lensim-render-crop");
  const std::string scene = dir.write("s.pbrt", kScene);
  Result r =
      run("render " + scene + " --quiet -o " + dir.file("o.exr") + " --cropwindow 0 1 nan 1");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("error: --cropwindow: y0 is nan; expected a finite fraction of the image, "
                       "in [0, 1] (--cropwindow x0 x1 y0 y1)"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("s.pbrt"), std::string::npos) << r.out;  // not the scene's fault
  r = run("render " + scene + " --quiet -o " + dir.file("o.exr") + " --cropwindow 0.2 0.2 0 1");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("error: --cropwindow gives empty pixel bounds"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.exr")));
}

TEST(RenderCommand, ErrorsAboutReferencedFilesSayErrorOnce) {
  // An unreadable image behind a texture, a light or a normal map: the scene line that names it
  // and the image's own message, with "error:" once (it was printed twice).
  lensim::testutil::TempDir dir("lensim-render-nested");
  dir.write("bad.png", "not an image\n");
  dir.write("bad.exr", "not an image\n");
  const char* const cases[] = {
      "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"bad.png\"\n"
      "Material \"diffuse\" \"texture reflectance\" \"t\"\n",
      "LightSource \"infinite\" \"string filename\" \"bad.exr\"\n",
      "LightSource \"projection\" \"string filename\" \"bad.exr\"\n",
      "LightSource \"goniometric\" \"string filename\" \"bad.exr\"\n",
      "AreaLightSource \"diffuse\" \"string filename\" \"bad.exr\"\n",
      "Material \"diffuse\" \"string normalmap\" \"bad.png\"\n",
  };
  for (const char* body : cases) {
    SCOPED_TRACE(body);
    const std::string scene =
        dir.write("s.pbrt", std::string("WorldBegin\n") + body + "Shape \"sphere\"\n");
    Result r = run("render " + scene + " --quiet -o " + dir.file("o.exr"));
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_NE(r.out.find("s.pbrt:2:1: error: "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("bad."), std::string::npos) << r.out;
    size_t count = 0;
    for (size_t at = r.out.find("error:"); at != std::string::npos;
         at = r.out.find("error:", at + 1))
      ++count;
    EXPECT_EQ(count, 1u) << r.out;
  }
}

TEST(RenderCommand, RealisticCameraErrorIsReportedCleanly) {
  // A focus distance the lens cannot reach: a located error at the Camera directive naming the
  // closest possible distance, exit status 1, and no image.
  lensim::testutil::TempDir dir("lensim-render-real");
  const std::string scene = dir.file("close.pbrt");
  {
    std::ofstream f(scene);
    f << "Camera \"realistic\" \"string lensfile\" \"" << LENSIM_SOURCE_DIR
      << "/lenses/dgauss.50mm.dat\" \"float focusdistance\" 0.05\n"
      << "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
      << "WorldBegin\nLightSource \"infinite\"\n";
  }
  Result r = run("render " + scene + " --spp 1 --quiet --outfile " + dir.file("x.exr"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find(scene + ":1:1: error: realistic camera: focus distance 0.05 m is closer"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("the closest is 0.1960 m"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.exr")));
}

TEST(SharedScenes, EveryPresentSceneRendersAtLowSpp) {
  // Each shared scene renders at 1 spp on a small crop, realistic cameras included.
  const std::filesystem::path root = kShared + "/scenes";
  if (!std::filesystem::exists(root)) GTEST_SKIP() << root << " is not present";
  int rendered = 0, missing = 0;
  // Files that others Include are parts of scenes, not scenes.
  std::set<std::filesystem::path> included;
  for (const auto& e : std::filesystem::recursive_directory_iterator(root)) {
    if (e.path().extension() != ".pbrt") continue;
    std::ifstream in(e.path());
    std::string line;
    while (std::getline(in, line)) {
      const size_t i = line.find("Include \"");
      if (i == std::string::npos || line.find('#') < i) continue;
      const size_t a = i + 9, b = line.find('"', a);
      included.insert(
          std::filesystem::weakly_canonical(e.path().parent_path() / line.substr(a, b - a)));
    }
  }
  for (const auto& e : std::filesystem::recursive_directory_iterator(root)) {
    if (e.path().extension() != ".pbrt") continue;
    const std::string path = e.path().string();
    if (included.count(std::filesystem::weakly_canonical(e.path()))) continue;
    lensim::scene::Scene s;
    try {
      s = lensim::scene::loadScene(path);
    } catch (const lensim::Error& err) {
      // Scenes whose geometry is not shipped (San Miguel) are not "present".
      if (std::string(err.what()).find("not found") == std::string::npos) throw;
      std::printf("skipped %s: its files are not all present (%s)\n", path.c_str(), err.what());
      ++missing;
      continue;
    }
    RenderOptions o;
    o.spp = 1;
    o.crop = std::array<double, 4>{0.4, 0.5, 0.4, 0.5};
    try {
      auto r = lensim::render::render(s, o);
      EXPECT_GT(r.image.width, 0) << path;
      EXPECT_EQ(r.stats.nonfinite_samples, 0u) << path;
      ++rendered;
    } catch (const lensim::Error& err) {
      ADD_FAILURE() << path << ": " << err.what();
    }
  }
  std::printf("shared scenes: %d rendered, %d with missing files\n", rendered, missing);
  EXPECT_GE(rendered, 8);  // hw3 x2, dof-dragons x4, box x2
}

TEST(RenderCommand, InterruptWritesThePartialImageAndFails) {
  lensim::testutil::TempDir dir("lensim-render-int");
  const std::string scene = dir.write("scene.pbrt", kScene);
  const std::string out = dir.file("partial.exr");
  // Enough samples to run for many seconds; SIGINT after 1.5 s (well after start-up).
  const std::string cmd = "sh -c '" + std::string(LENSIM_BINARY) + " render " + scene +
                          " --spp 100000 --quiet --outfile " + out +
                          " & p=$!; sleep 1.5; kill -INT $p; wait $p; echo rc=$?'";
  Result r = run("--version >/dev/null; " + cmd);
  EXPECT_NE(r.out.find("rc=130"), std::string::npos) << r.out;
  ASSERT_TRUE(std::filesystem::exists(out)) << r.out;
  const Image im = lensim::io::readImage(out);
  EXPECT_EQ(im.metadata.at("lensim:partial"), "true");
}
