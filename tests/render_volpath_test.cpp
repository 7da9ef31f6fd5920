// The volpath integrator against closed forms: Beer-Lambert transmittance of a slab at each of a
// path's wavelengths (spectral sigma_a), white furnaces inside lossless and emitting media,
// single scattering from a thin layer, and path vs volpath within noise on a scene without
// media. Bounds come from the estimates' own standard errors.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string>

#include "direct_world_util.h"
#include "lensim/render/image_compare.h"
#include "lensim/render/integrators/volpath.h"
#include "lensim/render/lights/lights.h"
#include "lensim/render/materials/materials.h"
#include "lensim/render/media/media.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "render_test_util.h"
#include "test_paths.h"

using namespace lensim;
using lensim::io::Image;
using lensim::render::RenderOptions;
using lensim::testutil::buildText;
using lensim::testutil::RegionStats;
using lensim::testutil::regionStats;
using lensim::testutil::renderText;

namespace {

/// A scene built for calling the integrator directly.
struct Direct : testutil::DirectWorld {
  explicit Direct(const std::string& text) : DirectWorld(buildText(text, "volpath-test.pbrt")) {}
};

/// Transmittance along the ray (o, dir) at each wavelength of one set, estimated by volpath as
/// radiance over that of the emitter seen along (o_clear, dir). The hero-wavelength estimator is
/// unbiased for every wavelength once averaged over which wavelength is the hero, so the set is
/// traced with each of its members as hero.
struct Transmittance {
  double lambda[4], mean[4], sem[4];
};
Transmittance transmittance(const Direct& d, const Vec3& o, const Vec3& dir, const Vec3& o_clear) {
  const double u0 = 0.13;  // wavelengths 421.1, 538.6, 656.1, 773.6 nm
  const render::SampledWavelengths base = render::SampledWavelengths::sampleUniform(u0);
  constexpr int kPaths = 40000;
  sampling::IndependentSampler sampler(kPaths, 7);
  render::RayCounts counts;
  double sum[4] = {}, sum2[4] = {}, emitted[4] = {};
  for (int k = 0; k < 4; ++k) {
    const render::SampledWavelengths lambda =
        render::SampledWavelengths::sampleUniform(std::fmod(u0 + k / 4.0, 1.0));
    int slot[4] = {};
    for (int c = 0; c < 4; ++c)
      for (int j = 0; j < 4; ++j)
        if (std::abs(lambda.lambda(c) - base.lambda(j)) < 1e-6) slot[c] = j;
    sampler.startPixelSample({0, 0}, 0);
    render::SampledWavelengths l2 = lambda;
    const render::SampledSpectrum Le =
        render::volpathLi(d.sc, o_clear, dir, -1, l2, sampler, counts);
    for (int c = 0; c < 4; ++c) emitted[slot[c]] = Le[c];
    for (int i = 0; i < kPaths; ++i) {
      sampler.startPixelSample({k, 0}, i);
      render::SampledWavelengths l = lambda;
      const render::SampledSpectrum L = render::volpathLi(d.sc, o, dir, -1, l, sampler, counts);
      for (int c = 0; c < 4; ++c) sum[slot[c]] += L[c], sum2[slot[c]] += L[c] * L[c];
    }
  }
  Transmittance T;
  const double n = 4.0 * kPaths;
  for (int j = 0; j < 4; ++j) {
    EXPECT_GT(emitted[j], 0);
    T.lambda[j] = base.lambda(j);
    T.mean[j] = sum[j] / n / emitted[j];
    T.sem[j] =
        std::sqrt(std::max(0.0, sum2[j] / n - std::pow(sum[j] / n, 2)) / (n - 1)) / emitted[j];
  }
  return T;
}

}  // namespace

// A slab 1 m thick (z in [0.5, 1.5], bounded by interface quads) of a purely absorbing medium
// whose sigma_a varies with wavelength, in front of an emitter; a ray along +z. Transmittance at
// each wavelength is exp(-sigma_a(lambda) 1 m).
TEST(Volpath, BeerLambertSlabAtEachWavelength) {
  Direct d(R"(
Integrator "volpath" "integer maxdepth" 5
WorldBegin
MakeNamedMedium "ink" "string type" "homogeneous" "float scale" 1
  "spectrum sigma_a" [360 0.3 450 0.5 550 1.2 650 2.0 830 2.6] "rgb sigma_s" [0 0 0]
AttributeBegin
  MediumInterface "ink" ""
  Material "interface"
  # z = 0.5 facing -z and z = 1.5 facing +z: inside is the slab.
  Shape "trianglemesh" "point3 P" [-1 -1 0.5  -1 1 0.5  1 1 0.5  1 -1 0.5]
    "integer indices" [0 1 2 0 2 3]
  Shape "trianglemesh" "point3 P" [-1 -1 1.5  1 -1 1.5  1 1 1.5  -1 1 1.5]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1]
  Shape "trianglemesh" "point3 P" [-10 -10 2  -10 10 2  10 10 2  10 -10 2]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
)");
  auto sigma_a = [](double l) {  // the spectrum above, linear between its points
    const double x[] = {360, 450, 550, 650, 830}, y[] = {0.3, 0.5, 1.2, 2.0, 2.6};
    for (int i = 0; i < 4; ++i)
      if (l <= x[i + 1]) return y[i] + (y[i + 1] - y[i]) * (l - x[i]) / (x[i + 1] - x[i]);
    return y[4];
  };
  const Transmittance T = transmittance(d, {0, 0, 0}, {0, 0, 1}, {5, 0, 0});
  for (int j = 0; j < 4; ++j) {
    const double expected = std::exp(-sigma_a(T.lambda[j]));
    std::printf("%.1f nm: T %.5f +- %.5f, exp(-sigma_a d) %.5f\n", T.lambda[j], T.mean[j], T.sem[j],
                expected);
    EXPECT_NEAR(T.mean[j], expected, 4 * T.sem[j] + 1e-6) << "at " << T.lambda[j] << " nm";
    EXPECT_LT(T.sem[j], 0.02 * expected) << "at " << T.lambda[j] << " nm";
  }
  // Behind a dispersive lens or interface only the hero wavelength is carried: its estimate
  // alone must be unbiased (no averaging with the dropped wavelengths' pdfs).
  sampling::IndependentSampler sampler(20000, 11);
  render::RayCounts counts;
  for (int j = 0; j < 4; ++j) {
    render::SampledWavelengths lambda =
        render::SampledWavelengths::sampleUniform(std::fmod(0.13 + j / 4.0, 1.0));
    lambda.terminateSecondary();
    sampler.startPixelSample({9, 9}, 0);
    render::SampledWavelengths l2 = lambda;
    const double Le = render::volpathLi(d.sc, {5, 0, 0}, {0, 0, 1}, -1, l2, sampler, counts)[0];
    double sum = 0, sum2 = 0;
    for (int i = 0; i < 20000; ++i) {
      sampler.startPixelSample({j, 9}, i);
      render::SampledWavelengths l = lambda;
      const double v =
          render::volpathLi(d.sc, {0, 0, 0}, {0, 0, 1}, -1, l, sampler, counts)[0] / Le;
      sum += v, sum2 += v * v;
    }
    const double mean = sum / 20000, sem = std::sqrt((sum2 / 20000 - mean * mean) / 19999);
    const double expected = std::exp(-sigma_a(lambda.lambda(0)));
    EXPECT_NEAR(mean, expected, 4 * sem + 1e-6) << "hero only, " << lambda.lambda(0) << " nm";
  }
}

// A camera inside a sphere of a scattering medium, lit from all sides by a uniform infinite
// light of radiance 1 through the sphere's interface. Inside a lossless (albedo 1) medium the
// radiance is 1 everywhere, whatever the (chromatic) scattering coefficient and asymmetry; in a
// medium that absorbs and emits Le = 1 it is 1 too (emission sigma_a Le balances absorption).
TEST(Volpath, FurnaceInsideAlbedoOneAndEmittingMedia) {
  const std::string header = R"(
LookAt 0 0 0  0 0 1  0 1 0
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "f.exr"
Sampler "independent" "integer pixelsamples" 64
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 1000
)";
  const std::string world = R"(
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
AttributeBegin
  MediumInterface "m" ""
  Material "interface"
  Shape "sphere" "float radius" 2
AttributeEnd
)";
  const char* media[] = {
      // Lossless, chromatic sigma_s (optical radius 1 to 4), forward scattering.
      R"(MakeNamedMedium "m" "string type" "homogeneous" "rgb sigma_a" [0 0 0]
           "rgb sigma_s" [0.5 1 2] "float g" 0.6)",
      // Absorbing and emitting, backward scattering.
      R"(MakeNamedMedium "m" "string type" "homogeneous" "rgb sigma_a" [0.8 0.4 1.5]
           "rgb sigma_s" [0.3 0.6 0.2] "float g" -0.4 "rgb Le" [1 1 1])",
      // The same without emission: darker (so the medium, and the camera's, are in effect).
      R"(MakeNamedMedium "m" "string type" "homogeneous" "rgb sigma_a" [0.8 0.4 1.5]
           "rgb sigma_s" [0.3 0.6 0.2] "float g" -0.4)",
  };
  for (const char* m : media) {
    const bool dark = std::string(m).find("Le") == std::string::npos &&
                      std::string(m).find("[0 0 0]") == std::string::npos;
    SCOPED_TRACE(m);
    // The camera is inside the medium: the outside of the MediumInterface current at Camera.
    const std::string text =
        header + m + "\nMediumInterface \"\" \"m\"\nCamera \"perspective\" \"float fov\" 90\n" +
        world;
    const Image im = renderText(text).image;
    for (int c = 0; c < 3; ++c) {
      const RegionStats s = regionStats(im, c, 0, 16, 0, 16);
      std::printf("furnace channel %d: %.4f +- %.4f\n", c, s.mean, s.sem);
      if (dark)
        EXPECT_LT(s.mean, 0.8) << "channel " << c;
      else
        EXPECT_NEAR(s.mean, 1.0, 4 * s.sem + 0.005) << "channel " << c;
    }
  }
}

// Single scattering (maxdepth 1) from a slab z in [0, d] of an isotropic... Henyey-Greenstein
// medium lit by a distant light along -z with irradiance E, seen by an orthographic camera from
// above at angle theta to the normal. A point at distance s along the view ray inside the slab
// is reached by the light through depth s mu (mu = cos theta), so
//   L = sigma_s p(Theta) E int_0^{d/mu} exp(-sigma_t s (1 + mu)) ds
//     = sigma_s p(Theta) E (1 - exp(-sigma_t d (1 + mu) / mu)) / (sigma_t (1 + mu)),
// with Theta the angle between the light's and the scattered light's directions of travel.
TEST(Volpath, SingleScatteringFromAThinLayer) {
  const double theta = 40 * std::numbers::pi / 180, mu = std::cos(theta);
  const double sigma_a = 0.3, sigma_s = 0.9, thickness = 0.25, g = 0.3, E = 2.0;
  const double sigma_t = sigma_a + sigma_s;
  const double cos_Theta = -mu;  // light travels -z, scattered light (-sin, 0, cos)
  const double p =
      (1 - g * g) / (4 * std::numbers::pi * std::pow(1 + g * g - 2 * g * cos_Theta, 1.5));
  const double expected =
      sigma_s * p * E * (1 - std::exp(-sigma_t * thickness * (1 + mu) / mu)) / (sigma_t * (1 + mu));
  const double cx = 5 * std::sin(theta), cz = 5 * mu;
  const std::string text = fmt::format(R"(
LookAt {} 0 {}  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-0.5 0.5 -0.5 0.5]
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "s.exr"
Sampler "independent" "integer pixelsamples" 256
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 1
WorldBegin
LightSource "distant" "point3 from" [0 0 1] "point3 to" [0 0 0] "rgb L" [{} {} {}]
MakeNamedMedium "layer" "string type" "homogeneous" "rgb sigma_a" [{} {} {}]
  "rgb sigma_s" [{} {} {}] "float g" {}
AttributeBegin
  MediumInterface "layer" ""
  Material "interface"
  Shape "trianglemesh" "point3 P" [-50 -50 {}  50 -50 {}  50 50 {}  -50 50 {}]
    "integer indices" [0 1 2 0 2 3]
  Shape "trianglemesh" "point3 P" [-50 -50 0  -50 50 0  50 50 0  50 -50 0]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
)",
                                       cx, cz, E, E, E, sigma_a, sigma_a, sigma_a, sigma_s, sigma_s,
                                       sigma_s, g, thickness, thickness, thickness, thickness);
  const Image im = renderText(text).image;
  for (int c = 0; c < 3; ++c) {
    const RegionStats s = regionStats(im, c, 0, 16, 0, 16);
    std::printf("single scattering channel %d: %.5f +- %.5f, closed form %.5f\n", c, s.mean, s.sem,
                expected);
    EXPECT_NEAR(s.mean, expected, 4 * s.sem + 1e-3 * expected) << "channel " << c;
    EXPECT_LT(s.sem, 0.01 * expected);
  }
}

// A diffuse box with an area light and no media: volpath and path render the same image
// within noise (per-block z-test of lensim compare).
TEST(Volpath, AgreesWithPathWithoutMedia) {
  auto scene = [](const char* integrator) {
    return fmt::format(R"(
LookAt 0 1 -3.2  0 1 0  0 1 0
Camera "perspective" "float fov" 45
Film "rgb" "integer xresolution" 40 "integer yresolution" 40 "string filename" "b.exr"
Sampler "independent" "integer pixelsamples" 16
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
Material "diffuse" "rgb reflectance" [0.7 0.1 0.1]
Shape "trianglemesh" "point3 P" [-1 0 -1  -1 0 1  -1 2 1  -1 2 -1] "integer indices" [0 2 1 0 3 2]
Material "diffuse" "rgb reflectance" [0.1 0.7 0.1]
Shape "trianglemesh" "point3 P" [1 0 -1  1 0 1  1 2 1  1 2 -1] "integer indices" [0 1 2 0 2 3]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.8]
AttributeBegin
  Translate 0.3 0.35 0.2
  Shape "sphere" "float radius" 0.35
AttributeEnd
)",
                       integrator);
  };
  RenderOptions o;
  o.spp = 32;
  o.seed = 1;
  const Image a = renderText(scene("volpath"), o).image;
  o.seed = 2;
  const Image b = renderText(scene("volpath"), o).image;
  o.seed = 3;
  o.spp = 128;
  const Image ref = renderText(scene("path"), o).image;
  // The reference's noise from its own renderer (path's variance per sample need not be
  // volpath's).
  o.seed = 4;
  o.spp = 32;
  const Image ref_low = renderText(scene("path"), o).image;
  render::CompareOptions co;
  co.second = &b;
  co.spp = 32;
  co.reference_spp = 128;
  co.reference_low = &ref_low;
  co.reference_low_spp = 32;
  const render::CompareResult r = render::compareImages(a, ref, co);
  std::printf("%s", render::formatCompare(r).c_str());
  EXPECT_EQ(r.z_failures, 0) << render::formatCompare(r);
  EXPECT_NEAR(r.mean_ratio, 1.0, 0.02) << render::formatCompare(r);
  // The test can fail: a red wall made white is found.
  const std::string wrong = [&] {
    std::string s = scene("volpath");
    s.replace(s.find("0.7 0.1 0.1"), 11, "0.7 0.7 0.7");
    return s;
  }();
  o.seed = 1;
  o.spp = 32;
  const Image w = renderText(wrong, o).image;
  EXPECT_GT(render::compareImages(w, ref, co).z_failures, 0);
}

// A uniformgrid of 2 x 1 x 1 voxels (densities a, b) mapped by the CTM at MakeNamedMedium onto
// x in [-1, 1], |y|, |z| <= 0.5, inside an interface sphere, absorbing with a spectral sigma_a,
// in front of an emitter. Along the x axis pbrt-v4's lookup (trilinear between voxel centres,
// zero beyond) gives a density whose integral over the grid's unit x is 0.4375 (a + b), so the
// optical depth is sigma_a(lambda) * 2 m * 0.4375 (a + b). Delta tracking meets null collisions
// here (the majorant is the largest density of each cell).
TEST(Volpath, BeerLambertThroughAUniformGrid) {
  const double a = 0.6, b = 1.4;
  Direct d(fmt::format(R"(
Integrator "volpath" "integer maxdepth" 5
WorldBegin
AttributeBegin
  Translate -1 -0.5 -0.5
  Scale 2 1 1
  MakeNamedMedium "grid" "string type" "uniformgrid" "integer nx" 2 "float density" [{} {}]
    "spectrum sigma_a" [360 0.3 830 1.3] "rgb sigma_s" [0 0 0]
AttributeEnd
AttributeBegin
  MediumInterface "grid" ""
  Material "interface"
  Shape "sphere" "float radius" 3
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1]
  Shape "trianglemesh" "point3 P" [4 -10 -10  4 -10 10  4 10 10  4 10 -10]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
)",
                       a, b));
  const Transmittance T = transmittance(d, {-3.5, 0, 0}, {1, 0, 0}, {-3.5, 5, 0});
  for (int j = 0; j < 4; ++j) {
    const double sigma = 0.3 + (T.lambda[j] - 360) / 470;
    const double expected = std::exp(-sigma * 2 * 0.4375 * (a + b));
    std::printf("uniformgrid %.1f nm: T %.5f +- %.5f, closed form %.5f\n", T.lambda[j], T.mean[j],
                T.sem[j], expected);
    EXPECT_NEAR(T.mean[j], expected, 4 * T.sem[j] + 1e-6) << "at " << T.lambda[j] << " nm";
  }
}

// A camera inside an rgbgrid of 2 x 2 x 2 voxels of different chromatic scattering and no
// absorption, lit by a uniform sky through an interface sphere: a lossless medium, so the
// radiance is 1 everywhere (null collisions against cell majorants, spectral MIS).
// The furnace enclosed in a uniform area emitter instead of a sky: a black sphere emitting L = 1
// inward (ReverseOrientation: its normal, hence its outside medium, faces the centre) around a
// camera in a lossless chromatic medium. The radiance is 1 everywhere; this exercises the MIS
// of area-light hits found by phase sampling against light sampling from medium points.
TEST(Volpath, FurnaceInsideAUniformAreaEmitter) {
  const char* media[] = {
      R"(MakeNamedMedium "m" "string type" "homogeneous" "rgb sigma_a" [0 0 0]
  "rgb sigma_s" [0.3 0.6 1.2] "float g" 0.3)",
      R"(MakeNamedMedium "m" "string type" "homogeneous" "rgb sigma_a" [0.5 0.2 0.9]
  "rgb sigma_s" [0.3 0.6 1.2] "float g" 0.3 "rgb Le" [1 1 1])",
      // Without its emission the absorbing medium darkens the view: the medium is in effect.
      R"(MakeNamedMedium "m" "string type" "homogeneous" "rgb sigma_a" [0.5 0.2 0.9]
  "rgb sigma_s" [0.3 0.6 1.2] "float g" 0.3)",
  };
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(media[k]);
    const std::string text = std::string(R"(
LookAt 0 0 0  0 0 1  0 1 0
)") + media[k] + R"(
MediumInterface "" "m"
Camera "perspective" "float fov" 90
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "a.exr"
Sampler "independent" "integer pixelsamples" 64
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 1000
WorldBegin
AttributeBegin
  ReverseOrientation
  MediumInterface "" "m"
  AreaLightSource "diffuse" "rgb L" [1 1 1]
  Material "diffuse" "rgb reflectance" [0 0 0]
  Shape "sphere" "float radius" 2
AttributeEnd
)";
    const Image im = renderText(text).image;
    for (int c = 0; c < 3; ++c) {
      const RegionStats s = regionStats(im, c, 0, 16, 0, 16);
      std::printf("area-emitter furnace %d channel %d: %.4f +- %.4f\n", k, c, s.mean, s.sem);
      if (k == 2)
        EXPECT_LT(s.mean, 0.8) << "channel " << c;
      else
        EXPECT_NEAR(s.mean, 1.0, 4 * s.sem + 0.005) << "channel " << c;
    }
  }
}

TEST(Volpath, FurnaceInsideAnRgbGrid) {
  const std::string text = R"(
LookAt 0 0 0  0 0 1  0 1 0
MakeNamedMedium "g" "string type" "rgbgrid" "integer nx" 2 "integer ny" 2 "integer nz" 2
  "point3 p0" [-2 -2 -2] "point3 p1" [2 2 2] "float g" 0.5
  "rgb sigma_a" [0 0 0  0 0 0  0 0 0  0 0 0  0 0 0  0 0 0  0 0 0  0 0 0]
  "rgb sigma_s" [0.5 1 2  2 1 0.5  1 1 1  3 0.2 0.2  0.1 0.1 0.1  0.2 3 0.2  1 2 3  0 0 0]
MediumInterface "" "g"
Camera "perspective" "float fov" 90
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "f.exr"
Sampler "independent" "integer pixelsamples" 64
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 1000
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
AttributeBegin
  MediumInterface "g" ""
  Material "interface"
  Shape "sphere" "float radius" 1.9
AttributeEnd
)";
  const Image im = renderText(text).image;
  for (int c = 0; c < 3; ++c) {
    const RegionStats s = regionStats(im, c, 0, 16, 0, 16);
    std::printf("rgbgrid furnace channel %d: %.4f +- %.4f\n", c, s.mean, s.sem);
    EXPECT_NEAR(s.mean, 1.0, 4 * s.sem + 0.005) << "channel " << c;
  }
}

// Through each of the four classic lenses: a camera standing in a lossless chromatic fog inside
// a uniform sky sees what it sees in vacuum (the flat field with the lens's vignetting), and on
// a diffuse scene without media volpath agrees with path (per-block z-tests).
TEST(Volpath, ThroughEachClassicLens) {
  for (const char* lens : lensim::test::kClassicLenses) {
    SCOPED_TRACE(lens);
    const std::string camera =
        fmt::format(R"(Camera "realistic" "string lensfile" "{}" "float aperturediameter" 5
  "float focusdistance" 3
Film "rgb" "integer xresolution" 24 "integer yresolution" 24 "float diagonal" 35
  "string filename" "l.exr"
Sampler "independent" "integer pixelsamples" 16
PixelFilter "box" "float xradius" 0.5 "float yradius" 0.5
)",
                    lensim::test::lensPath(lens));
    auto fog = [&](bool medium) {
      return std::string(medium ? R"(MakeNamedMedium "fog" "string type" "homogeneous"
  "rgb sigma_a" [0 0 0] "rgb sigma_s" [0.4 0.8 1.6] "float g" 0.5
MediumInterface "" "fog"
)"
                                : "") +
             camera + R"(Integrator "volpath" "integer maxdepth" 500
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
)" +
             (medium ? R"(AttributeBegin
  MediumInterface "fog" ""
  Material "interface"
  Shape "sphere" "float radius" 2
AttributeEnd
)"
                     : "");
    };
    RenderOptions o;
    o.spp = 32;
    o.seed = 1;
    const Image a = renderText(fog(true), o).image;
    o.seed = 2;
    const Image b = renderText(fog(true), o).image;
    o.seed = 3;
    o.spp = 128;
    const Image ref = renderText(fog(false), o).image;
    render::CompareOptions co;
    co.block = 6;
    co.second = &b;
    co.spp = 32;
    co.reference_spp = 128;
    const render::CompareResult r = render::compareImages(a, ref, co);
    // Vignetted corners are nearly black and their two-render variance estimates unreliable:
    // at most one block beyond the Bonferroni bound, none beyond 5 sigma + 2% (as the reference
    // tests). Means converge: at 8x the samples every ratio here is within 0.5% of 1.
    EXPECT_LE(r.z_failures, 1) << "fog\n" << render::formatCompare(r);
    EXPECT_EQ(r.outliers, 0) << "fog\n" << render::formatCompare(r);
    EXPECT_NEAR(r.mean_ratio, 1.0, 0.03) << "fog\n" << render::formatCompare(r);

    auto box = [&](const char* integrator) {
      return "LookAt 0 1 -3.2  0 1 0  0 1 0\n" + camera +
             fmt::format(R"(Integrator "{}" "integer maxdepth" 5
WorldBegin
LightSource "infinite" "rgb L" [0.3 0.3 0.3]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [6 6 6]
  Shape "trianglemesh" "point3 P" [-0.3 1.99 -0.3  0.3 1.99 -0.3  0.3 1.99 0.3  -0.3 1.99 0.3]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.7 0.7 0.7]
Shape "trianglemesh" "point3 P" [-1 0 -1  1 0 -1  1 0 1  -1 0 1  -1 2 -1  1 2 -1  1 2 1  -1 2 1]
  "integer indices" [0 2 1 0 3 2  4 5 6 4 6 7  3 7 6 3 6 2]
Material "diffuse" "rgb reflectance" [0.7 0.1 0.1]
Shape "trianglemesh" "point3 P" [-1 0 -1  -1 0 1  -1 2 1  -1 2 -1] "integer indices" [0 2 1 0 3 2]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.8]
Shape "sphere" "float radius" 0.35
)",
                         integrator);
    };
    o.spp = 32;
    o.seed = 4;
    const Image c = renderText(box("volpath"), o).image;
    o.seed = 5;
    const Image e = renderText(box("volpath"), o).image;
    o.seed = 6;
    o.spp = 128;
    const Image ref2 = renderText(box("path"), o).image;
    // The reference's noise from a second path render at 32 spp: path's variance per sample is
    // not volpath's in every block (taking it as equal, 3 of 48 comparisons over 12 sets of seeds
    // had 2 blocks beyond the bound; with this 1 of 48, and at 4x the samples none).
    o.seed = 7;
    o.spp = 32;
    const Image ref2_low = renderText(box("path"), o).image;
    co.second = &e;
    co.reference_low = &ref2_low;
    co.reference_low_spp = 32;
    const render::CompareResult r2 = render::compareImages(c, ref2, co);
    EXPECT_LE(r2.z_failures, 1) << "box\n" << render::formatCompare(r2);
    EXPECT_EQ(r2.outliers, 0) << "box\n" << render::formatCompare(r2);
    EXPECT_NEAR(r2.mean_ratio, 1.0, 0.03) << "box\n" << render::formatCompare(r2);
    std::printf("%s: fog/vacuum mean ratio %.4f, %d z failures; volpath/path %.4f, %d z failures\n",
                lens, r.mean_ratio, r.z_failures, r2.mean_ratio, r2.z_failures);
  }
}

// Shadow rays of volpath pass through "interface" surfaces (medium boundaries without a
// surface), as pbrt-v4's volpath does, also in a scene without media: a diffuse plane under a
// point light reads the same with an interface quad between them as without it.
TEST(Volpath, ShadowRaysPassInterfaceSurfaces) {
  auto scene = [](bool interface) {
    return std::string(R"(
LookAt 0 3 0  0 0 0  0 0 1
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "i.exr"
Sampler "independent" "integer pixelsamples" 16
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 1
WorldBegin
LightSource "point" "point3 from" [0.5 2 0] "rgb I" [4 4 4]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)") + (interface ? R"(Material "interface"
Shape "trianglemesh" "point3 P" [-5 1 -5  5 1 -5  5 1 5  -5 1 5] "integer indices" [0 1 2 0 2 3]
)"
                 : "");
  };
  const Image a = renderText(scene(false)).image;
  const Image b = renderText(scene(true)).image;
  for (int c = 0; c < 3; ++c) {
    const RegionStats sa = regionStats(a, c, 0, 16, 0, 16), sb = regionStats(b, c, 0, 16, 0, 16);
    ASSERT_GT(sa.mean, 0.01);
    EXPECT_NEAR(sb.mean, sa.mean, 4 * std::hypot(sa.sem, sb.sem) + 1e-4) << "channel " << c;
  }
}
