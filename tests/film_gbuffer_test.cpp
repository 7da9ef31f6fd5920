// pbrt-v4's gbuffer film (issue 12): the auxiliary channels of the first visible surface, as
// pbrt-v4's GBufferFilm writes them (src/pbrt/film.cpp). Expected values are closed forms of the
// scene's geometry (a plane at a known depth and tilt seen by a perspective camera), the
// material's reflectance, and the sample-variance estimator computed here in two passes.
#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>

#include <fmt/format.h>

#include "lensim/io/image.h"
#include "lensim/render/film/film.h"
#include "lensim/render/film/gbuffer.h"
#include "render_test_util.h"
#include "test_paths.h"

namespace lensim {
namespace {

constexpr int kRes = 9;
constexpr double kFovDeg = 40;

/// A perspective camera at `eye` looking down +z (pbrt camera space = world axes there), a
/// diffuse plane through (0, 0, `z0`) with z = z0 + tilt x, lit head-on by a distant light.
std::string planeScene(double z0, double tilt, const std::string& film_extra = "",
                       double eye_z = 0) {
  const double zl = z0 - 10 * tilt, zr = z0 + 10 * tilt;
  return fmt::format(R"(
LookAt 0 0 {}  0 0 1  0 1 0
Camera "perspective" "float fov" {}
Film "gbuffer" "integer xresolution" {} "integer yresolution" {} "string filename" "g.exr" {}
PixelFilter "box"
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "distant" "rgb L" [1 1 1] "point3 from" [0 0 0] "point3 to" [0 0 1]
Material "diffuse" "rgb reflectance" [0.4 0.25 0.1]
Shape "trianglemesh" "point3 P" [-10 -10 {}  10 -10 {}  10 10 {}  -10 10 {}]
  "integer indices" [0 1 2 0 2 3]
)",
                     eye_z, kFovDeg, kRes, kRes, film_extra, zl, zr, zr, zl);
}

int channel(const io::Image& im, const std::string& name) {
  for (size_t c = 0; c < im.channels.size(); ++c)
    if (im.channels[c] == name) return int(c);
  ADD_FAILURE() << "no channel " << name;
  return 0;
}

double at(const io::Image& im, const std::string& name, int x, int y) {
  return im.at(x, y, channel(im, name));
}

// A fronto-parallel plane at depth 2: P.Z = 2 everywhere, P.X and P.Y the pixel centre's ray at
// that depth (x = 2 tan(fov/2) (2 (i + 1/2) / N - 1), y flipped as pbrt's raster), N = Ns = the
// plane's normal toward the camera (0, 0, -1), dzdx = dzdy = 0, albedo = the reflectance.
TEST(FilmGBuffer, PlaneAtKnownDepth) {
  const io::Image im = testutil::renderText(planeScene(2, 0)).image;
  ASSERT_EQ(int(im.channels.size()), 3 + 22);
  const double t = std::tan(kFovDeg / 2 * M_PI / 180);
  double worst_p = 0;
  for (int y = 0; y < kRes; ++y)
    for (int x = 0; x < kRes; ++x) {
      EXPECT_NEAR(at(im, "P.Z", x, y), 2.0, 1e-5);
      const double px = 2 * t * (2 * (x + 0.5) / kRes - 1),
                   py = -2 * t * (2 * (y + 0.5) / kRes - 1);
      // The box-filtered samples are uniform over the pixel: their mean position is the centre's
      // (linear on a plane at constant depth), up to the samples' scatter (16 per pixel).
      const double pixel = 4 * t / kRes;
      // (The mean of 16 uniform samples scatters by 0.29 / 4 = 0.07 pixel.)
      EXPECT_NEAR(at(im, "P.X", x, y), px, 0.35 * pixel) << x << " " << y;
      EXPECT_NEAR(at(im, "P.Y", x, y), py, 0.35 * pixel) << x << " " << y;
      worst_p = std::max({worst_p, std::abs(at(im, "P.X", x, y) - px) / pixel,
                          std::abs(at(im, "P.Y", x, y) - py) / pixel});
      EXPECT_NEAR(at(im, "N.X", x, y), 0, 1e-6);
      EXPECT_NEAR(at(im, "N.Y", x, y), 0, 1e-6);
      EXPECT_NEAR(at(im, "N.Z", x, y), -1, 1e-6);
      EXPECT_NEAR(at(im, "Ns.Z", x, y), -1, 1e-6);
      EXPECT_NEAR(at(im, "dzdx", x, y), 0, 1e-5);
      EXPECT_NEAR(at(im, "dzdy", x, y), 0, 1e-5);
      // Each sample's albedo is a 4-wavelength estimate: per pixel within its noise.
      EXPECT_NEAR(at(im, "Albedo.R", x, y), 0.4, 0.25 * 0.4);
      EXPECT_NEAR(at(im, "Albedo.G", x, y), 0.25, 0.25 * 0.25);
      EXPECT_NEAR(at(im, "Albedo.B", x, y), 0.1, 0.5 * 0.1);
      const double u = at(im, "u", x, y), v = at(im, "v", x, y);
      EXPECT_TRUE(u >= 0 && u <= 1 && v >= 0 && v <= 1) << u << " " << v;
      EXPECT_GE(at(im, "Variance.G", x, y), 0);
    }
  // Over the image (1296 samples) the albedo is the reflectance (an RGB albedo of the
  // colour space reproduces its RGB under the space's illuminant).
  const int ar = channel(im, "Albedo.R");
  const double mr = testutil::regionMean(im, ar, 0, kRes, 0, kRes),
               mg = testutil::regionMean(im, ar + 1, 0, kRes, 0, kRes),
               mb = testutil::regionMean(im, ar + 2, 0, kRes, 0, kRes);
  std::printf(
      "plane at depth 2: P.Z %.6f, mean albedo %.4f %.4f %.4f (0.4 0.25 0.1), worst "
      "|P.XY - pixel centre| %.3f pixel\n",
      at(im, "P.Z", 4, 4), mr, mg, mb, worst_p);
  EXPECT_NEAR(mr, 0.4, 0.015 * 0.4);
  EXPECT_NEAR(mg, 0.25, 0.015 * 0.25);
  EXPECT_NEAR(mb, 0.1, 0.05 * 0.1);
}

// A plane tilted in x, z = 2 + a x: along the ray of screen coordinate s (x = s z), the depth is
// z = 2 / (1 - a s). pbrt-v4's dzdx is the depth change to the ray differential, which it scales
// to max(1/8, 1/sqrt(spp)) = 1/4 pixel at 16 spp: z(s + ds / 4) - z(s) with ds = 2 tan(fov/2) / N,
// averaged over the pixel; dzdy = 0.
TEST(FilmGBuffer, TiltedPlaneDepthSlope) {
  const double a = 0.5;
  const io::Image im = testutil::renderText(planeScene(2, a)).image;
  const double t = std::tan(kFovDeg / 2 * M_PI / 180), ds = 2 * t / kRes;
  for (int x : {2, 4, 6}) {
    // Mean over the pixel of z and dz/ds (x only: neither depends on y).
    double z = 0, slope = 0;
    const int n = 1000;
    for (int k = 0; k < n; ++k) {
      const double s = t * (2 * (x + (k + 0.5) / n) / kRes - 1);
      z += 2 / (1 - a * s) / n;
      slope += (2 / (1 - a * (s + ds / 4)) - 2 / (1 - a * s)) / n;
    }
    const double want_dzdx = slope;
    const double got_z = at(im, "P.Z", x, 4), got = at(im, "dzdx", x, 4);
    std::printf("tilted plane, pixel %d: P.Z %.5f (%.5f), dzdx %.6f (%.6f), dzdy %.2g\n", x, got_z,
                z, got, want_dzdx, at(im, "dzdy", x, 4));
    EXPECT_NEAR(got_z, z, 0.01 * z);  // 16 samples' scatter over the pixel
    EXPECT_NEAR(got / want_dzdx, 1.0, 0.01);
    EXPECT_NEAR(at(im, "dzdy", x, 4), 0, 1e-5);
    // The normal of z - a x = 2, toward the camera: (a, 0, -1) / sqrt(1 + a^2).
    EXPECT_NEAR(at(im, "N.X", x, 4), a / std::sqrt(1 + a * a), 1e-5);
    EXPECT_NEAR(at(im, "N.Z", x, 4), -1 / std::sqrt(1 + a * a), 1e-5);
  }
}

// Through the realistic camera the visible surface is the first scene hit of the ray that leaves
// the lens: a fronto-parallel plane 3 m in front of the camera reads P.Z = 3 and N = (0, 0, -1)
// wherever the lens images it, and its albedo in the image centre (as pbrt-v4, the albedo is
// averaged over all the pixel's samples, so samples the lens blocks dilute it toward the corners).
TEST(FilmGBuffer, RealisticCameraSeesThePlaneBeyondTheLens) {
  const std::string text = fmt::format(R"(
LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "{}" "float aperturediameter" 5 "float focusdistance" 3
Film "gbuffer" "integer xresolution" 8 "integer yresolution" 8 "float diagonal" 35
  "string filename" "g.exr"
PixelFilter "box"
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "distant" "rgb L" [1 1 1] "point3 from" [0 0 0] "point3 to" [0 0 1]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-10 -10 3  10 -10 3  10 10 3  -10 10 3]
  "integer indices" [0 1 2 0 2 3]
)",
                                       lensim::test::lensPath("dgauss.50mm.dat"));
  const io::Image im = testutil::renderText(text).image;
  int covered = 0;
  double albedo = 0, centre = 0;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      if (at(im, "N.Z", x, y) == 0) continue;  // no ray left the lens here
      ++covered;
      EXPECT_NEAR(at(im, "P.Z", x, y), 3, 1e-5) << x << " " << y;
      EXPECT_NEAR(at(im, "N.Z", x, y), -1, 1e-6) << x << " " << y;
      albedo += at(im, "Albedo.G", x, y);
      if (x >= 3 && x <= 4 && y >= 3 && y <= 4) centre += at(im, "Albedo.G", x, y) / 4;
    }
  std::printf(
      "realistic camera: %d of 64 pixels see the plane, P.Z %.6f, albedo %.4f in the "
      "centre, %.4f over the image\n",
      covered, at(im, "P.Z", 4, 4), centre, albedo / std::max(covered, 1));
  EXPECT_GE(covered, 60);
  EXPECT_NEAR(centre, 0.5, 0.03);
  EXPECT_LE(albedo / covered, 0.5 + 0.01);
}

// "coordinatesystem": "camera" (default) gives camera-space positions, "world" world ones; any
// other value is an error at the parameter, as in pbrt-v4.
TEST(FilmGBuffer, CoordinateSystem) {
  const io::Image cam = testutil::renderText(planeScene(2, 0, "", -1)).image;
  const io::Image world =
      testutil::renderText(planeScene(2, 0, "\"string coordinatesystem\" \"world\"", -1)).image;
  EXPECT_NEAR(at(cam, "P.Z", 4, 4), 3, 1e-5);
  EXPECT_NEAR(at(world, "P.Z", 4, 4), 2, 1e-5);
  EXPECT_NEAR(at(world, "N.Z", 4, 4), -1, 1e-6);
  const scene::Scene s =
      testutil::buildText(planeScene(2, 0, "\"string coordinatesystem\" \"screen\""), "g.pbrt");
  const std::string e = testutil::errorsOf(s);
  EXPECT_NE(e.find("g.pbrt:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("screen"), std::string::npos) << e;
  const scene::Scene ok = testutil::buildText(planeScene(2, 0));
  EXPECT_TRUE(ok.diagnostics.empty());
}

// pbrt-v4's variance channels: the sample variance (n - 1 denominator) of the unweighted sensor
// RGB of the samples that saw a surface, and that variance over the mean. Checked against the
// two-pass estimator over the same samples; a constant sample gives 0; samples without a visible
// surface do not count.
TEST(FilmGBuffer, VarianceIsTheSampleVariance) {
  static scene::Scene s;
  s = testutil::buildText(planeScene(2, 0));
  ASSERT_FALSE(s.hasErrors());
  render::Film noisy(s, {0, 1, 0, 1}), constant(s, {0, 1, 0, 1});
  ASSERT_TRUE(noisy.gbuffer());
  render::VisibleSurface vs;
  vs.n = vs.ns = {0, 0, -1};
  const int n = 300;
  std::vector<Vec3> values;
  uint64_t state = 12345;
  const auto next = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(state >> 11) * 0x1.0p-53;
  };
  const render::SampledWavelengths fixed = render::SampledWavelengths::sampleUniform(0.37);
  for (int k = 0; k < n; ++k) {
    const render::SampledWavelengths lambda = render::SampledWavelengths::sampleUniform(next());
    render::SampledSpectrum L(0.0);
    for (int i = 0; i < render::kSpectrumSamples; ++i) L[i] = 2 * next();
    const double w = 0.5 + next();
    noisy.addSample(0, 0, L, lambda, w, &vs);
    values.push_back(noisy.toSensorRgb(L, lambda));
    noisy.addSample(0, 0, L * 7.0, lambda, w, nullptr);  // no surface: not in the variance
    constant.addSample(0, 0, render::SampledSpectrum(0.8), fixed, w, &vs);
  }
  Vec3 mean;
  for (const Vec3& v : values) mean += v / n;
  Vec3 var;
  for (const Vec3& v : values) {
    const Vec3 d = v - mean;
    var += Vec3{d.x * d.x, d.y * d.y, d.z * d.z} / (n - 1);
  }
  const io::Image im = noisy.image(), ic = constant.image();
  std::printf("variance R G B %.6g %.6g %.6g (two-pass %.6g %.6g %.6g)\n",
              at(im, "Variance.R", 0, 0), at(im, "Variance.G", 0, 0), at(im, "Variance.B", 0, 0),
              var.x, var.y, var.z);
  EXPECT_NEAR(at(im, "Variance.R", 0, 0), var.x, 1e-5 * var.x);
  EXPECT_NEAR(at(im, "Variance.G", 0, 0), var.y, 1e-5 * var.y);
  EXPECT_NEAR(at(im, "Variance.B", 0, 0), var.z, 1e-5 * var.z);
  EXPECT_NEAR(at(im, "RelativeVariance.G", 0, 0), var.y / mean.y, 1e-5 * var.y / mean.y);
  for (const char* c : {"Variance.R", "Variance.G", "Variance.B"})
    EXPECT_NEAR(at(ic, c, 0, 0), 0, 1e-12) << c;
}

// The EXR written for a gbuffer film has pbrt-v4's channels, read back with OpenEXR.
TEST(FilmGBuffer, ExrChannelsAsPbrtV4) {
  const io::Image im = testutil::renderText(planeScene(2, 0)).image;
  const std::string path =
      (std::filesystem::temp_directory_path() / "lensim_gbuffer_test.exr").string();
  io::writeImage(path, im);
  Imf::InputFile file(path.c_str());
  std::set<std::string> got;
  for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it)
    got.insert(it.name());
  const std::set<std::string> want = {"R",
                                      "G",
                                      "B",
                                      "Albedo.R",
                                      "Albedo.G",
                                      "Albedo.B",
                                      "P.X",
                                      "P.Y",
                                      "P.Z",
                                      "dzdx",
                                      "dzdy",
                                      "N.X",
                                      "N.Y",
                                      "N.Z",
                                      "Ns.X",
                                      "Ns.Y",
                                      "Ns.Z",
                                      "u",
                                      "v",
                                      "Variance.R",
                                      "Variance.G",
                                      "Variance.B",
                                      "RelativeVariance.R",
                                      "RelativeVariance.G",
                                      "RelativeVariance.B"};
  EXPECT_EQ(got, want);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace lensim
