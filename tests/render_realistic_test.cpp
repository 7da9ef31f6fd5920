// The realistic camera in the renderer (issue 6): pbrt-v4's box-dgauss reference, the
// assignment's NTU reference renders through all four lenses, exposure and flat field, and
// repeated renders that must not hang.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "lensim/camera/realistic.h"
#include "lensim/io/image.h"
#include "lensim/optics/lens_system.h"
#include "lensim/render/autofocus_scene.h"
#include "lensim/render/image_compare.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "test_paths.h"

using namespace lensim;

namespace {

const std::string kShared = LENSIM_SHARED_DIR;

/// Block comparison (lensim/render/image_compare.h) of two renders (different seeds) against a
/// reference; the reference's noise from a low-sample sibling when there is one.
render::CompareResult compare(const io::Image& a, const io::Image& b, const io::Image& ref,
                              int spp_ours, int spp_ref, int block,
                              const io::Image* ref_low = nullptr, int spp_low = 0) {
  render::CompareOptions o;
  o.block = block;
  o.second = &b;
  o.spp = spp_ours;
  o.reference_spp = spp_ref;
  o.reference_low = ref_low;
  o.reference_low_spp = spp_low;
  const render::CompareResult r = render::compareImages(a, ref, o);
  if (getenv("LENSIM_TEST_VERBOSE")) std::printf("%s", render::formatCompare(r).c_str());
  return r;
}

bool present(const std::string& path) {
  return std::filesystem::exists(path);
}

}  // namespace

// pbrt-v4's own render of the box through the double Gauss (realistic camera, 1024 spp): absolute
// brightness and every 20x20 block within 5 standard errors plus 2%.
TEST(RealisticRender, BoxDgaussMatchesPbrtV4) {
  const std::string dir = kShared + "/scenes/pbrt-v4-refs/";
  if (!present(dir + "box-dgauss.pbrt") || !present(dir + "box-dgauss.exr"))
    GTEST_SKIP() << "shared scene or reference not present in " << dir;
  const scene::Scene s = scene::loadScene(dir + "box-dgauss.pbrt");
  const io::Image ref = io::readImage(dir + "box-dgauss.exr");
  render::RenderOptions o;
  // 32 spp: at 16 the dim block (8, 7) lies 3-5% under the reference with either sampler (its
  // mean rests on rare bright paths), and with the scene's zsobol the seed pair 1/2 puts it just
  // beyond 5 sigma + 2%; at 32 no block is (measured 2026-11-29).
  o.spp = 32;
  o.seed = 1;
  const render::RenderResult a = render::render(s, o);
  o.seed = 2;
  const io::Image b = render::render(s, o).image;
  const render::CompareResult m = compare(a.image, b, ref, 32, 1024, 20);
  std::printf(
      "box-dgauss vs pbrt-v4: mean ratio %.4f, mean |block diff| %.4f of the mean, %.0f%% of "
      "blocks beyond z %.2f, %.0f%% beyond 5 sigma + 2%%, no-ray samples %.2f%%\n",
      m.mean_ratio, m.mad_rel, 100 * m.zFailShare(), m.z_bound, 100 * m.outlierShare(),
      100.0 * a.stats.no_ray_samples / a.stats.camera_samples);
  EXPECT_NEAR(m.mean_ratio, 1.0, 0.02);
  EXPECT_EQ(m.outliers, 0);
  EXPECT_LE(static_cast<double>(a.stats.no_ray_samples) / a.stats.camera_samples, 0.05);
}

// The assignment's scenes through the four lenses against the NTU references (512 spp), with
// --pbrt-v2-quirks (the references carry two pbrt-v2 artefacts, see renderer.h; without them
// lensim is 1-4% brighter, most in the far floor and near vignetting edges). Metric: 10x10-pixel
// block means; the image-mean ratio, the mean absolute block difference relative to the image
// mean, the share of blocks beyond a Bonferroni bound for a 1% family-wise error (noise of
// lensim from two seeds, noise of the reference from its 32-spp sibling; differences under 0.1%
// of the image mean do not count), and the share beyond 5 sigma + 2%. Measured at 2 x 8 spp:
// ratios 1.001-1.002, mean |block diff| 0.8-1.1%, 0-2 of 900 blocks beyond the bound.
TEST(RealisticRender, AssignmentScenesAgreeWithTheirReferences) {
  const std::string dir = kShared + "/scenes/ntu-dis-2015-dof-dragons/";
  for (const char* lens : {"dgauss", "telephoto", "wide", "fisheye"}) {
    SCOPED_TRACE(lens);
    const std::string stem = dir + "dof-dragons." + lens;
    if (!present(stem + ".pbrt") || !present(stem + "_512ref.exr") || !present(stem + "_32ref.exr"))
      GTEST_SKIP() << "not present: " << stem << ".pbrt and its references";
    const scene::Scene s = scene::loadScene(stem + ".pbrt");
    const io::Image ref = io::readImage(stem + "_512ref.exr");
    const io::Image ref32 = io::readImage(stem + "_32ref.exr");
    render::RenderOptions o;
    o.spp = 8;
    o.seed = 1;
    o.pbrt_v2_quirks = true;
    const render::RenderResult ra = render::render(s, o);
    const io::Image& a = ra.image;
    // The pupil bounds waste at most 5% of the samples inside the image circle (the quirk's
    // dropped samples aside: counted without it).
    o.pbrt_v2_quirks = false;
    o.spp = 1;
    const render::RenderStats st = render::render(s, o).stats;
    const double waste = double(st.no_ray_samples - st.outside_samples) /
                         double(st.camera_samples - st.outside_samples);
    EXPECT_LE(waste, 0.05);
    o.spp = 8;
    o.pbrt_v2_quirks = true;
    o.seed = 2;
    const io::Image b = render::render(s, o).image;
    const render::CompareResult m = compare(a, b, ref, *o.spp, 512, 10, &ref32, 32);
    std::printf(
        "%-9s vs NTU reference: mean ratio %.4f, mean |block diff| %.4f of the mean, "
        "%.1f%% of %d blocks beyond z %.2f, %.1f%% beyond 5 sigma + 2%%; %.2f%% of the samples "
        "in the image circle without a ray\n",
        lens, m.mean_ratio, m.mad_rel, 100 * m.zFailShare(), m.blocks, m.z_bound,
        100 * m.outlierShare(), 100 * waste);
    EXPECT_NEAR(m.mean_ratio, 1.0, 0.01);
    EXPECT_LE(m.mad_rel, 0.015);
    EXPECT_LE(m.zFailShare(), 0.005);  // at most 4 of 900 blocks
    EXPECT_LE(m.outlierShare(), 0.005);
  }
}

namespace {

/// A path in this test's temporary directory (created).
std::string testFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_render_realistic_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// A scene file under the test's temporary directory: the camera inside a uniform environment
// (radiance 1 everywhere), the realistic camera looking at it through the double Gauss.
std::string writeFlatField(const std::string& name, double aperture_mm) {
  const std::string path = testFile(name);
  std::ofstream f(path);
  f << "Camera \"realistic\" \"string lensfile\" \"" << lensim::test::lensPath("dgauss.50mm.dat")
    << "\" \"float aperturediameter\" " << aperture_mm << " \"float focusdistance\" 3\n"
    << "Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24 \"float diagonal\" 35\n"
    << "Sampler \"independent\" \"integer pixelsamples\" 64\n"
    << "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
    << "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n";
  return path;
}

double centreMean(const io::Image& im) {
  double sum = 0;
  int n = 0;
  for (int y = 10; y < 14; ++y)
    for (int x = 10; x < 14; ++x, ++n)
      for (int c = 0; c < 3; ++c) sum += im.at(x, y, c) / 3;
  return sum / n;
}

}  // namespace

// Through the whole renderer: the flat field's centre reads pi L sin^2(theta) (theta the real
// marginal-ray angle at the film) within 2%, and half the stop diameter passes a quarter of it.
TEST(RealisticRender, FlatFieldAndExposure) {
  render::RenderOptions o;
  o.seed = 3;
  const scene::Scene full = scene::loadScene(writeFlatField("full.pbrt", 12));
  const scene::Scene half = scene::loadScene(writeFlatField("half.pbrt", 6));
  const double e_full = centreMean(render::render(full, o).image);
  const double e_half = centreMean(render::render(half, o).image);
  camera::RealisticSettings s;
  s.lens_path = lensim::test::lensPath("dgauss.50mm.dat");
  s.setup.aperture_diameter_mm = 12;
  s.setup.focus_distance_m = 3;
  camera::RealisticCamera cam(s);
  const optics::LensSystem& ls = *cam.lens().lens;
  const double sin_theta = lensim::test::realMarginalSin(ls);
  const double expected = std::numbers::pi * sin_theta * sin_theta;
  std::printf("flat field centre %.5f, pi sin^2 %.5f; full/half stop %.3f\n", e_full, expected,
              e_full / e_half);
  EXPECT_NEAR(e_full, expected, 0.02 * expected);
  EXPECT_NEAR(e_full / e_half, 4.0, 0.15);
}

// pbrt-v3's "simpleweighting" (the default in v3 files): pixel values on a pinhole's scale. The
// same flat field written in v3 syntax reads about L = 1 at the centre (0.94: the mean cos^4 of
// the rays and the 2% of samples the lens blocks), exactly the irradiance render's value times
// z^2 / A0 (film distance, sampled area at the centre), and falls off toward the corner as the
// irradiance render does.
TEST(RealisticRender, SimpleWeightingOfPbrtV3ReadsRadianceAtTheCentre) {
  const std::string path = testFile("v3.pbrt");
  {
    std::ofstream f(path);
    f << "Camera \"realistic\" \"string lensfile\" \"" << lensim::test::lensPath("dgauss.50mm.dat")
      << "\" \"float aperturediameter\" 12 \"float focusdistance\" 3\n"
      << "Film \"image\" \"integer xresolution\" 24 \"integer yresolution\" 24 "
         "\"float diagonal\" 35\n"
      << "Sampler \"random\" \"integer pixelsamples\" 64\n"
      << "PixelFilter \"box\" \"float xwidth\" 0.5 \"float ywidth\" 0.5\n"
      << "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\nWorldEnd\n";
  }
  render::RenderOptions o;
  o.seed = 4;
  const scene::Scene v3 = scene::loadScene(path);
  ASSERT_TRUE(v3.camera.realistic && v3.camera.realistic->simple_weighting);
  const io::Image simple = render::render(v3, o).image;
  const io::Image irradiance =
      render::render(scene::loadScene(writeFlatField("v4.pbrt", 12)), o).image;
  auto corner = [](const io::Image& im) {
    double sum = 0;
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x)
        for (int c = 0; c < 3; ++c) sum += im.at(x, y, c) / 27;
    return sum;
  };
  const double centre = centreMean(simple);
  camera::RealisticSettings s;
  s.lens_path = lensim::test::lensPath("dgauss.50mm.dat");
  s.setup.aperture_diameter_mm = 12;
  s.setup.focus_distance_m = 3;
  s.film_diagonal_mm = 35;
  s.x_resolution = s.y_resolution = 24;
  const camera::RealisticCamera cam(s);
  const double z = cam.lens().lens->filmDistance_mm();
  const double expected = centreMean(irradiance) * z * z / cam.centreAreaMm2();
  std::printf(
      "simple weighting: centre %.4f (irradiance x z^2/A0: %.4f), corner/centre %.4f "
      "(irradiance %.4f)\n",
      centre, expected, corner(simple) / centre, corner(irradiance) / centreMean(irradiance));
  EXPECT_NEAR(centre, expected, 0.01 * expected);
  EXPECT_NEAR(centre, 0.95, 0.04);
  EXPECT_NEAR(corner(simple) / centre, corner(irradiance) / centreMean(irradiance), 0.03);
}

// Camera construction happens before the render's parallel work: rendering a small
// realistic-camera scene many times in a row with 2 threads never hangs (ctest's timeout
// catches a hang; pbrt-v4 hangs in about one start in three on this machine kind).
TEST(RealisticRender, ManyRendersInARowDoNotHang) {
  const scene::Scene s = scene::loadScene(writeFlatField("repeat.pbrt", 8));
  render::RenderOptions o;
  o.threads = 2;
  o.spp = 1;
  for (int k = 0; k < 50; ++k) {
    o.seed = k;
    const render::RenderResult r = render::render(s, o);
    ASSERT_EQ(r.image.width, 24);
  }
}

// Autofocus through the renderer: a checkerboard plane facing the camera at a known distance;
// the film distance found lies within the depth of focus of the optics core's exact film
// distance for that distance.
TEST(RealisticRender, AutofocusFindsAPlaneThroughTheRenderer) {
  const std::string path = testFile("plane.pbrt"), zones = testFile("zones.txt");
  {
    std::ofstream f(path);
    f << "Camera \"realistic\" \"string lensfile\" \"" << lensim::test::lensPath("dgauss.50mm.dat")
      << "\" \"float aperturediameter\" 17.1 \"float focusdistance\" 10\n"
      << "Film \"rgb\" \"integer xresolution\" 200 \"integer yresolution\" 150 \"float diagonal\" "
         "35\n"
      << "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n"
      << "Texture \"checks\" \"spectrum\" \"checkerboard\" \"float uscale\" 100 \"float vscale\" "
         "100\n"
      << "  \"rgb tex1\" [0.9 0.9 0.9] \"rgb tex2\" [0.1 0.1 0.1]\n"
      << "Material \"diffuse\" \"texture reflectance\" \"checks\"\n"
      << "Shape \"bilinearmesh\" \"point3 P\" [-1 -1 1.5  1 -1 1.5  -1 1 1.5  1 1 1.5]\n"
      << "  \"point2 uv\" [0 0 1 0 0 1 1 1]\n";
    std::ofstream z(zones);
    z << "# centre\n0.45 0.55 0.43 0.57\n";
  }
  const scene::Scene s = scene::loadScene(path);
  render::SceneAutofocusOptions o;
  o.zones_file = zones;
  o.spp = 4;
  const render::SceneAutofocusResult r = render::autofocusScene(s, o);
  const optics::FocusedLens fl =
      optics::focusLens(optics::readLensFile(lensim::test::lensPath("dgauss.50mm.dat")),
                        {.aperture_diameter_mm = 17.1,
                         .focus_distance_m = 1.5,
                         .focus_method = optics::FocusMethod::Exact});
  const double n_w = optics::workingFNumber(*fl.lens, fl.paraxial, fl.lens->filmZ_mm() - 1500);
  const double pitch = 35 / std::sqrt(1 + 0.75 * 0.75) / 200;
  const double tolerance = n_w * 2 * pitch;
  std::printf("autofocus: %.4f mm (%d renders, %.1f s); optics core %.4f mm +- %.3f\n",
              r.film_distance_mm, r.renders, r.seconds, fl.lens->filmDistance_mm(), tolerance);
  EXPECT_NEAR(r.film_distance_mm, fl.lens->filmDistance_mm(), tolerance);
  EXPECT_NEAR(r.focus_distance_m, 1.5, 0.15);
}
