// pbrt's procedural textures (render/textures/procedural.h) against closed forms and against values
// computed with an independent Python transcription of pbrt-v4's src/pbrt/util/noise.cpp and
// textures.cpp (InsidePolkaDot, FBm, Turbulence, WindyTexture) done for this test.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "lensim/render/textures/procedural.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/sampling.h"
#include "lensim/scene/description.h"
#include "render_test_util.h"
#include "stats.h"

namespace lensim::render {

using namespace lensim::sampling;
namespace {

TEST(Procedural, PerlinNoiseClosedFormsAndReferenceValues) {
  // Zero at every lattice point (all offsets vanish), also far from the origin and negative.
  for (int x : {0, 1, -3, 77})
    for (int y : {0, 5, -12})
      for (int z : {0, 2, -1}) EXPECT_EQ(perlinNoise(x, y, z), 0.0) << x << " " << y << " " << z;
  // At the cell centre every weight is 1/2: the mean of the 8 gradients' dot products (each
  // +-0.5 +- 0.5): -0.125 with pbrt's permutation.
  EXPECT_NEAR(perlinNoise(0.5, 0.5, 0.5), -0.125, 1e-15);
  EXPECT_NEAR(perlinNoise(1.25, -2.7, 3.1), 0.4992040755374998, 1e-12);
  EXPECT_NEAR(perlinNoise(10.3, 0.2, -5.75), 0.25646979213874943, 1e-12);
  EXPECT_NEAR(perlinNoise(-0.3, 7.9, 2.2), -0.15102912003563573, 1e-12);
  // Bounded, zero-mean and continuous.
  Rng rng(5, 1);
  test::RunningStats s;
  for (int i = 0; i < 20000; ++i) {
    const double x = rng.uniform() * 50, y = rng.uniform() * 50, z = rng.uniform() * 50;
    const double n = perlinNoise(x, y, z);
    ASSERT_LE(std::abs(n), 1.0);
    s.add(n);
    EXPECT_LT(std::abs(perlinNoise(x + 1e-6, y, z) - n), 1e-5);
  }
  EXPECT_NEAR(s.mean, 0, 5 * s.stderror() + 0.01);
}

TEST(Procedural, SumsOfOctaves) {
  const Vec3 p{1.25, -2.7, 3.1};
  EXPECT_NEAR(fbm(p, 0.5, 1), perlinNoise(1.25, -2.7, 3.1), 1e-15);
  EXPECT_NEAR(
      fbm(p, 0.5, 2),
      perlinNoise(1.25, -2.7, 3.1) + 0.5 * perlinNoise(1.99 * 1.25, 1.99 * -2.7, 1.99 * 3.1),
      1e-15);
  EXPECT_NEAR(fbm(p, 0.5, 8), 0.6586376364247302, 1e-12);
  EXPECT_NEAR(turbulence(p, 0.5, 8), 0.7291159109371244, 1e-12);
  EXPECT_NEAR(windy(p), 0.34165020611861624, 1e-12);
  EXPECT_EQ(turbulence(p, 0.5, 0), 0.2);  // only pbrt's partial-octave term
}

TEST(Procedural, PolkaDotsMatchReference) {
  // 144 points of a 12 x 12 grid (s = 0.37 i - 3.1, t = 0.41 j - 2.2), inside or not.
  const std::string expected =
      "11000001100010000000100000000000000011000000000000000000000000010000001100010000001100"
      "0000000000000000011010000000011010000000000000110100000011";
  int k = 0;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j, ++k)
      EXPECT_EQ(insidePolkaDot({i * 0.37 - 3.1, j * 0.41 - 2.2}), expected[size_t(k)] == '1')
          << i << " " << j;
  // The dots cover pi 0.35^2 of the cells that have one.
  Rng rng(2, 2);
  int inside = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) inside += insidePolkaDot({rng.uniform() * 200, rng.uniform() * 200});
  EXPECT_GT(double(inside) / n, 0.25 * kPi * 0.35 * 0.35);
  EXPECT_LT(double(inside) / n, 0.75 * kPi * 0.35 * 0.35);
}

TEST(Procedural, MarbleStaysOnItsColourSpline) {
  Rng rng(3, 3);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 c =
        marbleRgb({rng.uniform() * 10, rng.uniform() * 10, rng.uniform() * 10}, 8, 0.5, 0.2);
    // Convex combinations of the control points, times 1.5.
    for (double v : {c.x, c.y, c.z}) {
      EXPECT_GE(v, 1.5 * 0.2 - 1e-12);
      EXPECT_LE(v, 1.5 * 0.6 + 1e-12);
    }
  }
  // sin(marble) = -1 -> t = 0: the first control point, 1.5 (.58, .58, .6).
  const Vec3 c = marbleRgb({0, -kPi / 2, 0}, 0, 0.5, 0.0);
  EXPECT_NEAR(c.x, 0.87, 1e-12);
  EXPECT_NEAR(c.z, 0.9, 1e-12);
}

TEST(Procedural, TexturesFromSceneFiles) {
  scene::Scene s = testutil::buildText(R"(WorldBegin
Texture "f" "float" "fbm" "integer octaves" 2 "float roughness" 0.25
Texture "w" "float" "wrinkled"
Texture "wi" "float" "windy"
Translate 1 0 0
Texture "m" "spectrum" "marble" "float scale" 2 "float variation" 0.5
Texture "d" "float" "dots" "float inside" 0.9 "float outside" 0.1
Texture "b" "float" "bilerp" "float v00" 1 "float v01" 2 "float v10" 3 "float v11" 4
Texture "bad" "float" "marble"
)");
  ASSERT_EQ(s.textures.size(), 6u) << testutil::errorsOf(s);
  EXPECT_NE(testutil::errorsOf(s).find("\"marble\" is a spectrum texture"), std::string::npos);
  for (const Diagnostic& d : s.diagnostics)
    EXPECT_EQ(d.message.find("not rendered"), std::string::npos) << d.message;
  Textures tx(s);
  auto input = [](int i) {
    scene::Input in;
    in.texture = i;
    return in;
  };
  TextureEvalContext ctx;
  ctx.p = {1.25, -2.7, 3.1};
  ctx.uv = {0.25, 0.75};
  EXPECT_NEAR(
      tx.evalFloat(input(0), ctx),
      perlinNoise(1.25, -2.7, 3.1) + 0.25 * perlinNoise(1.99 * 1.25, 1.99 * -2.7, 1.99 * 3.1),
      1e-12);
  EXPECT_NEAR(tx.evalFloat(input(1), ctx), 0.7291159109371244, 1e-12);
  EXPECT_NEAR(tx.evalFloat(input(2), ctx), 0.34165020611861624, 1e-12);
  // Bilerp at (s, t) = (0.25, 0.75): 0.1875 v00 + 0.5625 v01 + 0.0625 v10 + 0.1875 v11.
  EXPECT_NEAR(tx.evalFloat(input(5), ctx), 0.1875 + 0.5625 * 2 + 0.0625 * 3 + 0.1875 * 4, 1e-12);
  EXPECT_NEAR(tx.evalFloat(input(4), ctx), insidePolkaDot({0.25, 0.75}) ? 0.9 : 0.1, 1e-12);
  // The marble is declared after Translate 1 0 0: its texture space is shifted.
  const SampledWavelengths lambda = SampledWavelengths::sampleUniform(0.3);
  const SampledSpectrum m = tx.evalSpectrum(input(3), ctx, lambda, SpectrumType::Albedo);
  scene::SpectrumValue expected;
  expected.rgb = marbleRgb(Vec3{0.25, -2.7, 3.1} * 2, 8, 0.5, 0.5);
  const SampledSpectrum e = tx.constant(expected, SpectrumType::Albedo)->sample(lambda);
  for (int i = 0; i < kSpectrumSamples; ++i) EXPECT_NEAR(m[i], e[i], 0.01);
}

}  // namespace
}  // namespace lensim::render
