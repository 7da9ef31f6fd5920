// pbrt-v4's film sensor parameters (issue 12): "sensor", "iso", the camera's shutter interval
// and "whitebalance", with the expected values derived from pbrt-v4's definitions
// (src/pbrt/film.cpp, PixelSensor::Create and PixelSensor's cie1931 constructor), not from
// lensim's output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "lensim/render/film/film.h"
#include "lensim/render/film/pixel_sensor.h"
#include "lensim/scene/sensor_settings.h"
#include "render_test_util.h"

namespace lensim {
namespace {

using render::Film;
using render::RGBColorSpace;
using render::SampledSpectrum;
using render::SampledWavelengths;

std::string sceneWithFilm(const std::string& film_extra, const std::string& camera_extra = "") {
  return R"(
LookAt 0 0.5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.01 0.01 -0.01 0.01] )" +
         camera_extra + R"(
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "s.exr" )" +
         film_extra + R"(
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "distant" "rgb L" [1 1 1] "point3 from" [0 1 0] "point3 to" [0 0 0]
Material "diffuse" "rgb reflectance" [1 1 1]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
}

Film filmOf(const std::string& film_extra, const std::string& camera_extra = "") {
  static scene::Scene s;  // Film keeps no reference to the scene
  s = testutil::buildText(sceneWithFilm(film_extra, camera_extra));
  EXPECT_FALSE(s.hasErrors()) << testutil::errorsOf(s);
  return Film(s, {0, 4, 0, 4});
}

std::string diagnosticsOf(const scene::Scene& s) {
  std::string out;
  for (const Diagnostic& d : s.diagnostics) out += d.str() + "\n";
  return out;
}

// pbrt-v4 errors on a sensor name it has no curves for ("unknown sensor type"): so does lensim,
// at the parameter, naming the sensors it knows.
TEST(FilmSensor, UnknownSensorIsALocatedError) {
  const scene::Scene s =
      testutil::buildText(sceneWithFilm("\"string sensor\" \"kodak_brownie\""), "sensor.pbrt");
  ASSERT_TRUE(s.hasErrors());
  const std::string e = testutil::errorsOf(s);
  EXPECT_NE(e.find("sensor.pbrt:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("kodak_brownie"), std::string::npos) << e;
  EXPECT_NE(e.find("cie1931"), std::string::npos) << e;
  EXPECT_NE(e.find("nikon_d810"), std::string::npos) << e;
}

// Every camera pbrt-v4 names is applied: no diagnostic, and the builder's list is the data
// file's.
TEST(FilmSensor, PbrtCameraSensorsAreApplied) {
  EXPECT_EQ(scene::pbrtCameraSensorNames().size(), 17u);
  EXPECT_EQ(scene::pbrtCameraSensorNames(), render::cameraSensorNames());
  for (const std::string& name : scene::pbrtCameraSensorNames()) {
    const scene::Scene s =
        testutil::buildText(sceneWithFilm("\"string sensor\" \"" + name + "\""), "sensor.pbrt");
    EXPECT_FALSE(s.hasErrors()) << testutil::errorsOf(s);
    EXPECT_TRUE(s.diagnostics.empty()) << diagnosticsOf(s);
    EXPECT_EQ(Film(s, {0, 4, 0, 4}).sensor().name(), name);
  }
  const scene::Scene s = testutil::buildText(sceneWithFilm("\"string sensor\" \"cie1931\""));
  EXPECT_TRUE(s.diagnostics.empty()) << diagnosticsOf(s);
}

// The cie1931 sensor records XYZ (the CIE 1931 matching functions over the sampled wavelengths,
// divided by the Y integral) times the imaging ratio, converted to the output space (sRGB):
// named explicitly it is exactly the default.
TEST(FilmSensor, Cie1931IsTheXyzPipeline) {
  const Film by_default = filmOf(""), named = filmOf("\"string sensor\" \"cie1931\"");
  for (int k = 0; k < 50; ++k) {
    const SampledWavelengths lambda = SampledWavelengths::sampleUniform((k + 0.5) / 50);
    SampledSpectrum L(0.0);
    for (int i = 0; i < render::kSpectrumSamples; ++i) L[i] = 0.2 + 0.1 * ((k + i) % 7);
    const Vec3 want = RGBColorSpace::sRGB().toRgb(render::sampledToXyz(L, lambda));
    const Vec3 a = by_default.toRgb(L, lambda), b = named.toRgb(L, lambda);
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
    EXPECT_EQ(a.z, b.z);
    EXPECT_NEAR(a.x, want.x, 1e-12 + 1e-12 * std::abs(want.x));
    EXPECT_NEAR(a.y, want.y, 1e-12 + 1e-12 * std::abs(want.y));
    EXPECT_NEAR(a.z, want.z, 1e-12 + 1e-12 * std::abs(want.z));
  }
}

// pbrt-v4: imaging ratio = exposure time x ISO / 100, with exposure time = shutterclose -
// shutteropen of the camera (defaults 0 and 1: ratio 1).
TEST(FilmSensor, IsoAndExposureScaleAsPbrtV4) {
  EXPECT_DOUBLE_EQ(scene::sensorImagingRatio(1, 100), 1.0);
  EXPECT_DOUBLE_EQ(scene::sensorImagingRatio(0.5, 400), 2.0);
  EXPECT_DOUBLE_EQ(scene::sensorImagingRatio(1.0 / 60, 1600), 16.0 / 60);
  const Film base = filmOf("");
  const Film scaled =
      filmOf("\"float iso\" 400", "\"float shutteropen\" 0.25 \"float shutterclose\" 0.75");
  const Film dim = filmOf("\"float iso\" 50", "\"float shutteropen\" 0 \"float shutterclose\" 0.5");
  const SampledWavelengths lambda = SampledWavelengths::sampleUniform(0.3);
  const SampledSpectrum L(1.0);
  const Vec3 a = base.toRgb(L, lambda), b = scaled.toRgb(L, lambda), c = dim.toRgb(L, lambda);
  EXPECT_NEAR(b.y / a.y, 2.0, 1e-12);
  EXPECT_NEAR(b.x / a.x, 2.0, 1e-12);
  EXPECT_NEAR(c.y / a.y, 0.25, 1e-12);

  // And in a render: a Lambertian plane of albedo 0.5 under a distant light of unit irradiance
  // facing it has luminance 0.5/pi; ISO 400 with a 0.5 s shutter doubles it.
  std::string text =
      sceneWithFilm("\"float iso\" 400", "\"float shutteropen\" 0 \"float shutterclose\" 0.5");
  text.replace(text.find("reflectance\" [1 1 1]"), 21, "reflectance\" [0.5 0.5 0.5]");
  const io::Image im = testutil::renderText(text).image;
  double y = 0;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) y += testutil::luminanceAt(im, i, j) / 16;
  std::printf("plane luminance %.5f, expected %.5f\n", y, 2 * 0.5 / M_PI);
  EXPECT_NEAR(y, 2 * 0.5 / M_PI, 0.01 * 2 * 0.5 / M_PI);
}

// pbrt-v4's white balance (cie1931 sensor with "whitebalance" T): von Kries adaptation in the
// Bradford LMS space from the white of CIE illuminant D at T x 1.4388 / 1.4380 (a blackbody
// below 4000 K) to the output space's white (D65 for sRGB). Then the illuminant's own white records
// as equal RGB, and "whitebalance" 6500 (= D65) changes nothing.
TEST(FilmSensor, WhiteBalanceMapsTheIlluminantWhiteToEqualRgb) {
  EXPECT_NEAR(scene::whiteBalanceCct(6500), 6503.6, 0.1);
  // A blackbody at the temperature pbrt-v4's Spectra::D uses for "whitebalance" 3000 (below
  // 4000 K, D is a blackbody of T x 1.4388 / 1.4380).
  const render::BlackbodySpectrum white(scene::whiteBalanceCct(3000));
  const Film balanced = filmOf("\"float whitebalance\" 3000"), raw = filmOf("");
  const Film d65 = filmOf("\"float whitebalance\" 6500");
  Vec3 sb{0, 0, 0}, sr{0, 0, 0};
  const int n = 2000;
  for (int k = 0; k < n; ++k) {
    const SampledWavelengths lambda = SampledWavelengths::sampleUniform((k + 0.5) / n);
    const SampledSpectrum L = white.sample(lambda);
    sb = sb + balanced.toRgb(L, lambda);
    sr = sr + raw.toRgb(L, lambda);
    const Vec3 a = raw.toRgb(L, lambda), b = d65.toRgb(L, lambda);
    const double m = std::max({std::abs(a.x), std::abs(a.y), std::abs(a.z)});
    EXPECT_NEAR(b.x, a.x, 2e-3 * m);
    EXPECT_NEAR(b.y, a.y, 2e-3 * m);
    EXPECT_NEAR(b.z, a.z, 2e-3 * m);
  }
  std::printf("3000 K white: raw rgb %.4f %.4f %.4f, balanced %.4f %.4f %.4f\n", sr.x / sr.y, 1.0,
              sr.z / sr.y, sb.x / sb.y, 1.0, sb.z / sb.y);
  EXPECT_GT(sr.x / sr.z, 1.5);  // 3000 K is warm in sRGB
  EXPECT_NEAR(sb.x / sb.y, 1.0, 2e-3);
  EXPECT_NEAR(sb.z / sb.y, 1.0, 2e-3);
}

// pbrt-v4's spectral film (src/pbrt/film.h, SpectralFilm): R, G, B as the rgb film, then one
// channel of radiance per wavelength bucket, "S0.<centre>nm" with a decimal comma. A white
// Lambertian plane (reflectance 1) facing a distant blackbody light of unit luminance has radiance
// B(lambda) / (pi Y_B), Y_B = integral(B ybar) / integral(ybar): each bucket must hold the mean of
// that over its wavelengths (computed here by quadrature of Planck's law).
TEST(FilmSpectral, BucketsFollowTheLightsSpectrum) {
  const double T = 3500;
  const std::string text = R"(
LookAt 0 0.5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.01 0.01 -0.01 0.01]
Film "spectral" "integer xresolution" 4 "integer yresolution" 4 "string filename" "s.exr"
  "integer nbuckets" 8 "float lambdamin" 400 "float lambdamax" 720
Sampler "sobol" "integer pixelsamples" 256
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "distant" "blackbody L" 3500 "point3 from" [0 1 0] "point3 to" [0 0 0]
Material "diffuse" "rgb reflectance" [1 1 1]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
  const io::Image im = testutil::renderText(text).image;
  ASSERT_EQ(im.channelCount(), 3 + 8);
  EXPECT_EQ(im.channels[0], "R");
  EXPECT_EQ(im.channels[3], "S0.420,000nm");
  EXPECT_EQ(im.channels[10], "S0.700,000nm");
  // The spectral layout's header attributes, as pbrt-v4 writes them.
  EXPECT_EQ(im.metadata.at("spectralLayoutVersion"), "1.0");
  EXPECT_EQ(im.metadata.at("emissiveUnits"), "W.m^-2.sr^-1");
  // Luminance of the (unnormalised) Planck spectrum, 1 nm steps over 360-830 nm.
  double yb = 0, ybar = 0;
  for (double l = 360; l <= 830; l += 1) {
    yb += render::BlackbodySpectrum::planck(l, T) * render::cieXyzBar(l).y;
    ybar += render::cieXyzBar(l).y;
  }
  const double norm = ybar / yb;  // B * norm has unit luminance
  double worst = 0;
  for (int b = 0; b < 8; ++b) {
    double mean = 0;
    const int steps = 400;
    for (int k = 0; k < steps; ++k)
      mean += render::BlackbodySpectrum::planck(400 + 40 * b + 40 * (k + 0.5) / steps, T);
    const double want = mean / steps * norm / M_PI;
    const double got = testutil::regionMean(im, 3 + b, 0, 4, 0, 4);
    std::printf("bucket %d (%s): %.5f, expected %.5f (ratio %.4f)\n", b,
                im.channels[size_t(3 + b)].c_str(), got, want, got / want);
    worst = std::max(worst, std::abs(got / want - 1));
    EXPECT_NEAR(got / want, 1.0, 0.03) << b;
  }
  std::printf("worst bucket deviation %.2f%%\n", 100 * worst);
}

TEST(FilmSpectral, ParametersAsPbrtV4) {
  const std::string head = R"(
Film "spectral" )";
  const std::string tail = R"(
WorldBegin
)";
  scene::Scene s = testutil::buildText(head + tail);
  EXPECT_FALSE(s.hasErrors()) << testutil::errorsOf(s);
  EXPECT_EQ(s.film.type, "spectral");
  EXPECT_EQ(s.film.spectral_buckets, 16);
  EXPECT_EQ(s.film.lambda_min_nm, 360);
  EXPECT_EQ(s.film.lambda_max_nm, 830);
  EXPECT_TRUE(s.diagnostics.empty());
  s = testutil::buildText(head + "\"float lambdamin\" 300" + tail, "l.pbrt");
  EXPECT_NE(testutil::errorsOf(s).find("l.pbrt:2:"), std::string::npos) << testutil::errorsOf(s);
  s = testutil::buildText(head + "\"integer nbuckets\" 0" + tail, "l.pbrt");
  EXPECT_NE(testutil::errorsOf(s).find("nbuckets"), std::string::npos) << testutil::errorsOf(s);
}

}  // namespace
}  // namespace lensim
