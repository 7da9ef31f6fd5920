// Textured subsurface coefficients (pbrt-v4's SubsurfaceMaterial with a `texture reflectance`,
// `mfp`, `sigma_a` or `sigma_s`): the walk that enters at a point runs with the coefficients
// evaluated there. Checked against closed forms (the index-matched slab's albedo from
// Chandrasekhar's H function per texture region, energy conservation at albedo 1) and against
// untextured renders of the same constants (per-region and per-block z-tests).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/image_compare.h"
#include "render_test_util.h"

using namespace lensim;
using lensim::io::Image;
using lensim::render::RenderOptions;
using lensim::testutil::RegionStats;
using lensim::testutil::regionStats;
using lensim::testutil::renderText;
using lensim::testutil::TempDir;

namespace {

/// z statistic of the difference of two independent estimates.
double zOf(const RegionStats& a, const RegionStats& b) {
  return (a.mean - b.mean) / std::sqrt(a.sem * a.sem + b.sem * b.sem);
}

/// Chandrasekhar's H function for isotropic scattering of albedo a at mu = 1, from
/// H(mu) = 1 + (a/2) mu H(mu) int_0^1 H(mu') / (mu + mu') dmu' on a midpoint rule of 400 nodes.
double chandrasekharH1(double a) {
  constexpr int n = 400;
  std::vector<double> x(n), H(n, 1.0);
  for (int i = 0; i < n; ++i) x[size_t(i)] = (i + 0.5) / n;
  auto eval = [&](double mu) {
    double s = 0;
    for (int j = 0; j < n; ++j) s += H[size_t(j)] / (mu + x[size_t(j)]);
    return 1 / (1 - 0.5 * a * mu * s / n);
  };
  for (int it = 0; it < 5000; ++it) {
    std::vector<double> next(n);
    double change = 0;
    for (int i = 0; i < n; ++i) {
      next[size_t(i)] = eval(x[size_t(i)]);
      change = std::max(change, std::abs(next[size_t(i)] - H[size_t(i)]));
    }
    H = next;
    if (change < 1e-11) break;
  }
  return eval(1);
}

/// A uniform-colour linear float image (EXR) of w x h pixels.
std::string writeConstantImage(const TempDir& dir, const std::string& name, Vec3 rgb) {
  Image im(4, 4, {"R", "G", "B"});
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = float(c == 0 ? rgb.x : c == 1 ? rgb.y : rgb.z);
  const std::string path = dir.file(name);
  io::writeImage(path, im);
  return path;
}

// The slab of Subsurface.ThickSlabMatchesChandrasekharsAlbedo (100 x 100 x 30 mean free paths,
// index-matched, isotropic, under a uniform sky of radiance 1, seen along its normal by an
// orthographic camera), its top face's u running along world x, and `material` on it.
std::string slabScene(const std::string& textures, const std::string& material, int spp,
                      int seed = 0) {
  return fmt::format(R"(
LookAt 0 0 5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-0.5 0.5 -0.5 0.5]
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "s.exr"
Sampler "independent" "integer pixelsamples" {} "integer seed" {}
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 10
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
{}
{}
Shape "trianglemesh" "point3 P" [-50 -50 0  50 -50 0  50 50 0  -50 50 0
                                 -50 -50 -30  50 -50 -30  50 50 -30  -50 50 -30]
  "point2 uv" [0 0  1 0  1 1  0 1  0 0  1 0  1 1  0 1]
  "integer indices" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  1 5 6 1 6 2  2 6 7 2 7 3
                     3 7 4 3 4 0]
)",
                     spp, seed, textures, material);
}

// Which image columns see u < 0.5 (world x < 0) of the slab: LookAt down -z with +y up puts
// world -x on the camera's +x, which raster x follows, so the right half. Columns 7 and 8
// (the split and its neighbour) are left out.
constexpr int kLowU0 = 9, kLowU1 = 16, kHighU0 = 0, kHighU1 = 7;

}  // namespace

// sigma_a and sigma_s as checkerboard textures: the slab's u < 0.5 half has isotropic albedo
// 0.5, the other 0.9 (sigma_t 1 on both). Each half reads its own closed form
// 1 - H(1) sqrt(1 - a) (Chandrasekhar 1950, sec. 45): camera paths enter where they are seen
// and, the slab being convex, never re-enter, so each half is the untextured slab of its own
// coefficients.
TEST(SubsurfaceTexture, CheckerboardSigmaMatchesChandrasekharPerHalf) {
  const std::string text = slabScene(R"(
Texture "sa" "spectrum" "checkerboard" "float uscale" 2 "float vscale" 1
  "rgb tex1" [0.5 0.5 0.5] "rgb tex2" [0.1 0.1 0.1]
Texture "ss" "spectrum" "checkerboard" "float uscale" 2 "float vscale" 1
  "rgb tex1" [0.5 0.5 0.5] "rgb tex2" [0.9 0.9 0.9]
)",
                                     R"(Material "subsurface" "texture sigma_a" "sa"
  "texture sigma_s" "ss" "float eta" 1)",
                                     64);
  const Image im = renderText(text).image;
  const std::tuple<double, int, int> halves[] = {{0.5, kLowU0, kLowU1}, {0.9, kHighU0, kHighU1}};
  for (const auto& [a, x0, x1] : halves) {
    const double expected = 1 - chandrasekharH1(a) * std::sqrt(1 - a);
    const RegionStats s = regionStats(im, 1, x0, x1, 0, 16);
    std::printf("checkerboard sigma, half of albedo %.1f: L %.4f +- %.4f, closed form %.4f\n", a,
                s.mean, s.sem, expected);
    EXPECT_NEAR(s.mean, expected, 4 * s.sem + 0.003) << "albedo " << a;
  }
}

// reflectance as a checkerboard texture (0.3 on u < 0.5, 0.8 elsewhere; mfp a texture-free
// constant): each half matches an untextured render of its reflectance within noise, and the
// halves differ (the test can fail).
TEST(SubsurfaceTexture, CheckerboardReflectanceMatchesUntexturedHalves) {
  const Image textured = renderText(slabScene(R"(
Texture "r" "spectrum" "checkerboard" "float uscale" 2 "float vscale" 1
  "rgb tex1" [0.3 0.3 0.3] "rgb tex2" [0.8 0.8 0.8]
)",
                                              R"(Material "subsurface" "texture reflectance" "r"
  "rgb mfp" [1 1 1] "float eta" 1)",
                                              64, 1))
                             .image;
  const std::tuple<double, int, int> halves[] = {{0.3, kLowU0, kLowU1}, {0.8, kHighU0, kHighU1}};
  for (const auto& [r, x0, x1] : halves) {
    const Image plain = renderText(slabScene("",
                                             fmt::format(R"(Material "subsurface"
  "rgb reflectance" [{0} {0} {0}] "rgb mfp" [1 1 1] "float eta" 1)",
                                                         r),
                                             64, 2))
                            .image;
    const RegionStats t = regionStats(textured, 1, x0, x1, 0, 16);
    const RegionStats u = regionStats(plain, 1, 0, 16, 0, 16);
    const double z = zOf(t, u);
    std::printf(
        "checkerboard reflectance %.1f: textured %.4f +- %.4f, untextured %.4f +- %.4f, "
        "z %.2f\n",
        r, t.mean, t.sem, u.mean, u.sem, z);
    EXPECT_LT(std::abs(z), 4) << "reflectance " << r;
  }
  const RegionStats lo = regionStats(textured, 1, kLowU0, kLowU1, 0, 16);
  const RegionStats hi = regionStats(textured, 1, kHighU0, kHighU1, 0, 16);
  EXPECT_GT(hi.mean - lo.mean, 10 * std::hypot(lo.sem, hi.sem));
}

// A constant image texture for reflectance gives the untextured image within noise (per-block
// z-test, as `lensim compare`): a sphere of eta 1.33 with a rough boundary and chromatic mfp
// under a sky and a point light. (path renders subsurface scenes with volpath's code: one
// integrator suffices.) The test can fail: an image of reflectance 0.6 instead of 0.7 in red is
// found.
TEST(SubsurfaceTexture, ConstantImageTextureMatchesUntextured) {
  TempDir dir("lensim-sss-texture");
  const std::string image = writeConstantImage(dir, "refl.exr", {0.7, 0.5, 0.3});
  const std::string darker = writeConstantImage(dir, "darker.exr", {0.6, 0.5, 0.3});
  auto scene = [&](const std::string& material, int spp, int seed) {
    return fmt::format(R"(
LookAt 0 0 -4  0 0 0  0 1 0
Camera "perspective" "float fov" 32
Film "rgb" "integer xresolution" 24 "integer yresolution" 24 "string filename" "c.exr"
Sampler "independent" "integer pixelsamples" {} "integer seed" {}
Integrator "volpath" "integer maxdepth" 8
WorldBegin
LightSource "infinite" "rgb L" [0.4 0.4 0.4]
LightSource "point" "point3 from" [-3 3 -3] "rgb I" [20 20 20]
{} "rgb mfp" [0.05 0.1 0.2] "float roughness" 0.2 "float eta" 1.33
Shape "sphere" "float radius" 1
)",
                       spp, seed, material);
  };
  auto textured = [](const std::string& file) {
    return fmt::format(R"(Texture "refl" "spectrum" "imagemap" "string filename" "{}"
Material "subsurface" "texture reflectance" "refl")",
                       file);
  };
  const std::string plain = R"(Material "subsurface" "rgb reflectance" [0.7 0.5 0.3])";
  const Image a = renderText(scene(textured(image), 32, 1)).image;
  const Image b = renderText(scene(textured(image), 32, 2)).image;
  const Image ref = renderText(scene(plain, 128, 3)).image;
  const Image ref_low = renderText(scene(plain, 32, 4)).image;
  render::CompareOptions co;
  co.block = 4;
  co.second = &b;
  co.spp = 32;
  co.reference_spp = 128;
  co.reference_low = &ref_low;
  co.reference_low_spp = 32;
  render::CompareOptions whole = co;
  whole.block = 24;  // the image's mean as one block
  const render::CompareResult r = render::compareImages(a, ref, co);
  const render::CompareResult rw = render::compareImages(a, ref, whole);
  std::printf("%s", render::formatCompare(r).c_str());
  EXPECT_EQ(r.z_failures, 0) << render::formatCompare(r);
  EXPECT_EQ(rw.z_failures, 0) << render::formatCompare(rw);
  EXPECT_NEAR(r.mean_ratio, 1.0, 0.02) << render::formatCompare(r);
  const Image wa = renderText(scene(textured(darker), 32, 5)).image;
  const Image wb = renderText(scene(textured(darker), 32, 6)).image;
  whole.second = &wb;
  const render::CompareResult w = render::compareImages(wa, ref, whole);
  std::printf("reflectance 0.6 in red against 0.7: %s", render::formatCompare(w).c_str());
  EXPECT_GT(w.z_failures, 0) << render::formatCompare(w);
}

// Energy conservation at albedo 1 with textured coefficients: a sphere whose sigma_s is a
// checkerboard (2 and 8 per unit, sigma_a 0) and one whose reflectance is an image of 1, behind
// a smooth eta 1.33 boundary under a uniform sky of radiance 1, read 1 everywhere.
TEST(SubsurfaceTexture, WhiteFurnaceWithTexturedCoefficients) {
  TempDir dir("lensim-sss-furnace");
  const std::string white = writeConstantImage(dir, "white.exr", {1, 1, 1});
  const std::string materials[] = {
      R"(Texture "ss" "spectrum" "checkerboard" "float uscale" 4 "float vscale" 4
  "rgb tex1" [2 2 2] "rgb tex2" [8 8 8]
Material "subsurface" "rgb sigma_a" [0 0 0] "texture sigma_s" "ss" "float g" 0.5)",
      fmt::format(R"(Texture "r" "spectrum" "imagemap" "string filename" "{}"
Material "subsurface" "texture reflectance" "r" "rgb mfp" [0.2 0.3 0.5])",
                  white)};
  for (const std::string& material : materials) {
    const Image im = renderText(fmt::format(R"(
LookAt 0 0 -4  0 0 0  0 1 0
Camera "perspective" "float fov" 20
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "f.exr"
Sampler "independent" "integer pixelsamples" 64
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 20
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
{} "float eta" 1.33
Shape "sphere" "float radius" 1
)",
                                            material))
                         .image;
    for (int c = 0; c < 3; ++c) {
      const RegionStats s = regionStats(im, c, 0, 16, 0, 16);
      std::printf("textured furnace channel %d: %.4f +- %.4f\n", c, s.mean, s.sem);
      EXPECT_NEAR(s.mean, 1.0, 4 * s.sem + 0.003) << material << "\nchannel " << c;
    }
  }
}

// The builder keeps the textures (spectrum textures, as pbrt-v4's GetSpectrumTextureOrNull) and
// refuses a float texture for a spectrum coefficient, naming it.
TEST(SubsurfaceTexture, BuilderReadsSpectrumTextures) {
  const scene::Scene s = testutil::buildText(R"(WorldBegin
Texture "c" "spectrum" "checkerboard" "rgb tex1" [0.2 0.2 0.2] "rgb tex2" [0.7 0.7 0.7]
Material "subsurface" "texture reflectance" "c" "texture mfp" "c"
Material "subsurface" "texture sigma_a" "c" "rgb sigma_s" [1 2 3]
Shape "sphere"
)");
  ASSERT_EQ(testutil::errorsOf(s), "");
  ASSERT_EQ(s.materials.size(), 2u);
  EXPECT_TRUE(s.materials[0].as<scene::SubsurfaceParams>().from_reflectance);
  EXPECT_GE(s.materials[0].as<scene::SubsurfaceParams>().reflectance.texture, 0);
  EXPECT_GE(s.materials[0].as<scene::SubsurfaceParams>().mfp.texture, 0);
  EXPECT_GE(s.materials[1].as<scene::SubsurfaceParams>().sigma_a.texture, 0);
  EXPECT_EQ(s.materials[1].as<scene::SubsurfaceParams>().sigma_s.texture, -1);
  EXPECT_EQ(s.materials[1].as<scene::SubsurfaceParams>().sigma_s.spectrum.rgb.z, 3);
  EXPECT_EQ(testutil::errorsOf(testutil::buildText(R"(WorldBegin
Texture "f" "float" "checkerboard"
Material "subsurface" "texture reflectance" "f"
)")),
            "test.pbrt:3:23: error: unknown spectrum texture \"f\" (\"f\" is a float texture)\n");
}
