// pbrt-v4's gbuffer film (issue 12): the auxiliary channels of the first visible surface, as
// pbrt-v4's GBufferFilm writes them (src/pbrt/film.cpp). Expected values are closed forms of the
// scene's geometry (a plane at a known depth and tilt seen by a perspective camera), the
// material's reflectance, and the sample-variance estimator computed here in two passes; with
// bdpt and lighttracer, a moving camera (the shutter mean of the depth) and the variance of
// splatted estimates (the pixels' scatter). Film "savefp16" (half EXR) is tested here too.
#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli_run.h"
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
/// The 50 mm double Gauss focused at 3 m on a grey plane at z = 3, lit head-on.
std::string realisticPlaneScene() {
  return fmt::format(R"(
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
}

TEST(FilmGBuffer, RealisticCameraSeesThePlaneBeyondTheLens) {
  const io::Image im = testutil::renderText(realisticPlaneScene()).image;
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

namespace lensim {
namespace {

/// planeScene with another integrator.
std::string withIntegrator(std::string text, const std::string& integrator) {
  const std::string from = "Integrator \"path\"";
  text.replace(text.find(from), from.size(), "Integrator \"" + integrator + "\"");
  return text;
}

// bdpt and lighttracer fill the auxiliary channels too (pbrt-v4 leaves them 0 there: its
// BDPTIntegrator::Li ignores the VisibleSurface argument and LightPathIntegrator adds no camera
// samples). Their camera rays are sampled as path's, so every geometric channel and the albedo
// equal path's exactly; and they are the plane's closed form (P.Z = 2, N = Ns = (0, 0, -1)).
TEST(FilmGBuffer, BdptAndLightTracerFillTheAuxiliaryChannels) {
  const std::string text = planeScene(2, 0);
  const io::Image ip = testutil::renderText(text).image;
  const char* geometric[] = {"Albedo.R", "Albedo.G", "Albedo.B", "P.X", "P.Y", "P.Z",
                             "dzdx",     "dzdy",     "N.X",      "N.Y", "N.Z", "Ns.X",
                             "Ns.Y",     "Ns.Z",     "u",        "v"};
  for (const char* integrator : {"bdpt", "lighttracer"}) {
    const render::RenderResult r = testutil::renderText(withIntegrator(text, integrator));
    const io::Image& im = r.image;
    ASSERT_EQ(im.channels, ip.channels);
    int differing_rgb = 0, positive_variance = 0;
    for (int y = 0; y < kRes; ++y)
      for (int x = 0; x < kRes; ++x) {
        EXPECT_NEAR(at(im, "P.Z", x, y), 2.0, 1e-5) << integrator;
        EXPECT_NEAR(at(im, "N.Z", x, y), -1, 1e-6) << integrator;
        EXPECT_NEAR(at(im, "Ns.Z", x, y), -1, 1e-6) << integrator;
        for (const char* c : geometric)
          EXPECT_EQ(at(im, c, x, y), at(ip, c, x, y))
              << integrator << " " << c << " " << x << " " << y;
        differing_rgb += at(im, "G", x, y) != at(ip, "G", x, y);
        positive_variance += at(im, "Variance.G", x, y) > 0;
        // A pixel with a (splatted or sampled) value has a variance; one without has none
        // (the light tracer's 16 paths per pixel reach few of the 81 pixels of this view).
        EXPECT_EQ(at(im, "Variance.G", x, y) > 0, at(im, "G", x, y) > 0) << integrator;
      }
    std::printf(
        "%s: albedo.G %.4f (path %.4f), %d of %d pixels with another RGB than path's, "
        "%d with a positive variance\n",
        integrator, at(im, "Albedo.G", 4, 4), at(ip, "Albedo.G", 4, 4), differing_rgb, kRes * kRes,
        positive_variance);
    // The RGB is the integrator's own (not a fallback to path), with a variance.
    EXPECT_GT(differing_rgb, kRes * kRes / 2) << integrator;
    EXPECT_GT(positive_variance, 0) << integrator;
  }
}

// Through the realistic camera too, bdpt's and lighttracer's auxiliary channels are path's: the
// same camera rays (through the double Gauss) see the same plane at z = 3.
TEST(FilmGBuffer, BdptAndLightTracerThroughTheRealisticCamera) {
  const std::string text = realisticPlaneScene();
  const io::Image ip = testutil::renderText(text).image;
  for (const char* integrator : {"bdpt", "lighttracer"}) {
    const io::Image im = testutil::renderText(withIntegrator(text, integrator)).image;
    ASSERT_EQ(im.channels, ip.channels);
    int covered = 0;
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        for (const char* c : {"Albedo.G", "P.X", "P.Y", "P.Z", "N.Z", "Ns.Z", "u", "v"})
          EXPECT_EQ(at(im, c, x, y), at(ip, c, x, y))
              << integrator << " " << c << " " << x << " " << y;
        if (at(im, "N.Z", x, y) == 0) continue;
        ++covered;
        EXPECT_NEAR(at(im, "P.Z", x, y), 3, 1e-5) << integrator;
      }
    EXPECT_GE(covered, 60) << integrator;
  }
}

// The variance of a splatted estimate (lighttracer; bdpt adds its t = 1 splats to the variance
// of its camera samples): a Lambertian plane filling the view, lit head-on by a distant light,
// has the same expected radiance in every pixel, so the scatter of the pixel values over the
// image estimates the variance of one pixel's value, which the Variance channel over spp must
// match. With a box filter of radius 1/2 a splat lands on one pixel. The sensor is CIE 1931, so
// sensor G is Y = the luminance of the output linear sRGB.
TEST(FilmGBuffer, SplattedVarianceMatchesThePixelScatter) {
  constexpr int kN = 32, kSpp = 16;
  const double h = 0.55;  // the view at z = 2 is 2 tan(15 deg) = 0.536 wide each way
  for (const char* integrator : {"lighttracer", "bdpt"}) {
    const std::string text = fmt::format(R"(
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 30
Film "gbuffer" "integer xresolution" {} "integer yresolution" {} "string filename" "g.exr"
PixelFilter "box"
Sampler "independent" "integer pixelsamples" {}
Integrator "{}" "integer maxdepth" 1
WorldBegin
LightSource "distant" "rgb L" [1 1 1] "point3 from" [0 0 0] "point3 to" [0 0 1]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-{} -{} 2  {} -{} 2  {} {} 2  -{} {} 2]
  "integer indices" [0 1 2 0 2 3]
)",
                                         kN, kN, kSpp, integrator, h, h, h, h, h, h, h, h);
    const io::Image im = testutil::renderText(text).image;
    std::vector<double> lum;
    double variance = 0;
    for (int y = 0; y < kN; ++y)
      for (int x = 0; x < kN; ++x) {
        lum.push_back(0.2126729 * at(im, "R", x, y) + 0.7151522 * at(im, "G", x, y) +
                      0.0721750 * at(im, "B", x, y));
        variance += at(im, "Variance.G", x, y) / (kN * kN);
      }
    double mean = 0, scatter = 0;
    for (double v : lum) mean += v / double(lum.size());
    for (double v : lum) scatter += (v - mean) * (v - mean) / double(lum.size() - 1);
    const double predicted = variance / kSpp;
    std::printf("%s: mean Y %.5f, pixel scatter %.4g, Variance.G / spp %.4g (ratio %.3f)\n",
                integrator, mean, scatter, predicted, predicted / scatter);
    // 1024 pixels: the scatter's own relative error is about sqrt(2 / 1024) = 4.4 %.
    EXPECT_NEAR(predicted / scatter, 1.0, 0.15) << integrator;
    // And the image is right: albedo 0.5 under unit irradiance, radiance 0.5 / pi (the mean of
    // 1024 pixels scatters by 1%).
    EXPECT_NEAR(mean, 0.5 / M_PI, 0.05 * 0.5 / M_PI) << integrator;
  }
}

// A camera moving during the shutter: pbrt-v4's VisibleSurface takes the camera transform at
// the sample's time (CameraFromRender(si.time), src/pbrt/film.cpp). The camera moves from
// z = 0 to z = 1 over the shutter [0, 1] toward a plane at z = 5: a sample at time t sees the
// plane at camera-space depth 5 - t, so P.Z averaged over the image is the shutter mean 4.5
// (the start transform alone would give 5); in world coordinates P.Z is 5 at every time.
TEST(FilmGBuffer, MovingCameraDepthIsTheShutterMean) {
  const auto scene = [](const std::string& film_extra) {
    return fmt::format(R"(
TransformTimes 0 1
ActiveTransform StartTime
LookAt 0 0 0  0 0 1  0 1 0
ActiveTransform EndTime
LookAt 0 0 1  0 0 2  0 1 0
ActiveTransform All
Camera "perspective" "float fov" 40 "float shutteropen" 0 "float shutterclose" 1
Film "gbuffer" "integer xresolution" 9 "integer yresolution" 9 "string filename" "g.exr" {}
PixelFilter "box"
Sampler "independent" "integer pixelsamples" 64
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "distant" "rgb L" [1 1 1] "point3 from" [0 0 0] "point3 to" [0 0 1]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-10 -10 5  10 -10 5  10 10 5  -10 10 5]
  "integer indices" [0 1 2 0 2 3]
)",
                       film_extra);
  };
  const io::Image cam = testutil::renderText(scene("")).image;
  const io::Image world =
      testutil::renderText(scene("\"string coordinatesystem\" \"world\"")).image;
  double mean = 0, lo = 1e9, hi = -1e9;
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 9; ++x) {
      const double z = at(cam, "P.Z", x, y);
      mean += z / 81;
      lo = std::min(lo, z), hi = std::max(hi, z);
      EXPECT_NEAR(at(world, "P.Z", x, y), 5, 1e-5);
      EXPECT_NEAR(at(cam, "N.Z", x, y), -1, 1e-6);
      EXPECT_NEAR(at(cam, "dzdx", x, y), 0, 1e-5);
    }
  // 5184 uniform shutter times: the mean of 5 - t scatters by 0.289 / 72 = 0.004.
  std::printf(
      "moving camera: camera-space P.Z over the image %.4f (closed form 4.5), pixels "
      "%.3f to %.3f\n",
      mean, lo, hi);
  EXPECT_NEAR(mean, 4.5, 0.016);
  EXPECT_GT(lo, 4.0);
  EXPECT_LT(hi, 5.0);
}

// Film "bool savefp16": lensim writes 32-bit float EXR by default (pbrt-v4 defaults to half);
// an explicit true writes HALF channels, which hold the values to half precision (11
// significant bits), and values beyond half's range are written as +-65504 with a warning that
// counts them (never as infinities).
TEST(FilmSaveFp16, HalfChannelsWhenAskedClampedToTheHalfRange) {
  EXPECT_FALSE(testutil::buildText(planeScene(2, 0)).film.save_fp16);
  EXPECT_TRUE(testutil::buildText(planeScene(2, 0, "\"bool savefp16\" true")).film.save_fp16);
  EXPECT_FALSE(testutil::buildText(planeScene(2, 0, "\"bool savefp16\" false")).film.save_fp16);

  io::Image im(3, 2, {"R", "G", "B"});
  const float values[18] = {0.1f, 1.0f, 3.14159f, 1e6f,  -1e6f, 65504.0f, -2.5f, 1e-3f,   12345.6f,
                            0.0f, 7e4f, 0.333f,   1e-5f, 42.0f, 0.5f,     100.f, 60000.f, 2.0f};
  for (int i = 0; i < 18; ++i) im.pixels[size_t(i)] = values[i];
  im.metadata["lensim:spp"] = "4";
  const auto dir = std::filesystem::temp_directory_path();
  const std::string half_path = (dir / "lensim_fp16_test.exr").string(),
                    float_path = (dir / "lensim_fp32_test.exr").string();
  io::ImageWriteOptions wo;
  wo.exr_half = true;
  testing::internal::CaptureStderr();
  io::writeImage(half_path, im, wo);
  const std::string warning = testing::internal::GetCapturedStderr();
  io::writeImage(float_path, im);
  const auto type = [](const std::string& path) {
    Imf::InputFile f(path.c_str());
    std::set<int> types;
    for (auto it = f.header().channels().begin(); it != f.header().channels().end(); ++it)
      types.insert(int(it.channel().type));
    return types;
  };
  EXPECT_EQ(type(half_path), std::set<int>{int(Imf::HALF)});
  EXPECT_EQ(type(float_path), std::set<int>{int(Imf::FLOAT)});
  // 1e6, -1e6 (one pixel) and 7e4 (another): 2 pixels, 3 values.
  EXPECT_NE(warning.find("2 pixels (3 values)"), std::string::npos) << warning;
  const io::Image back = io::readImage(half_path);
  EXPECT_EQ(back.metadata.at("lensim:spp"), "4");
  for (int i = 0; i < 18; ++i) {
    const double want = std::clamp(double(values[i]), -65504.0, 65504.0);
    // Half: 10 stored mantissa bits (relative rounding error <= 2^-11) above 2^-14, absolute
    // steps of 2^-24 below.
    EXPECT_NEAR(back.pixels[size_t(i)], want, std::abs(want) * 0x1p-11 + 0x1p-25) << i;
  }
  EXPECT_EQ(back.pixels[3], 65504.0f);
  EXPECT_EQ(back.pixels[4], -65504.0f);
  std::filesystem::remove(half_path);
  std::filesystem::remove(float_path);
}

// Through the CLI: "savefp16" true in the scene gives a half EXR, the default a float one; the
// two renders (deterministic) agree within half precision.
TEST(FilmSaveFp16, RenderWritesHalfOnlyWhenTheSceneAsks) {
  const auto dir = std::filesystem::temp_directory_path();
  std::vector<io::Image> images;
  for (const bool fp16 : {true, false}) {
    const std::string scene_path = (dir / "lensim_fp16_scene.pbrt").string();
    const std::string out = (dir / "lensim_fp16_out.exr").string();
    {
      std::ofstream f(scene_path);
      f << fmt::format(R"(
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 {}
Sampler "independent" "integer pixelsamples" 1
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
)",
                       fp16 ? "\"bool savefp16\" true" : "");
    }
    const test::CliResult r =
        test::runLensim(fmt::format("render {} --quiet --outfile {}", scene_path, out));
    ASSERT_EQ(r.status, 0) << r.out;
    Imf::InputFile f(out.c_str());
    EXPECT_EQ(f.header().channels().findChannel("G")->type, fp16 ? Imf::HALF : Imf::FLOAT);
    images.push_back(io::readImage(out));
    std::filesystem::remove(out);
    std::filesystem::remove(scene_path);
  }
  ASSERT_EQ(images[0].pixels.size(), images[1].pixels.size());
  for (size_t i = 0; i < images[0].pixels.size(); ++i) {
    const float full = images[1].pixels[i];
    EXPECT_GT(full, 0.0f);
    EXPECT_NEAR(images[0].pixels[i], full, full * 0x1p-11) << i;
  }
}

}  // namespace
}  // namespace lensim
