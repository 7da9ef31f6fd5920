// pbrt-v3's directlighting integrator (render/integrators/directlighting.h): on a diffuse scene it
// is path tracing with maxdepth 1 (z-tests on the difference of two renders), and it follows
// specular reflection and transmission up to its maxdepth (closed forms: a mirror of reflectance
// R shows R times the radiance of the lit plane it reflects; a glass slab at normal incidence
// shows the floor behind it times T^2 (1 + R^2), the two paths through the slab that maxdepth 5
// allows).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "render_test_util.h"

using lensim::io::Image;
using lensim::render::RenderOptions;
using lensim::testutil::renderText;

namespace {

// A diffuse room corner: floor, back wall, a diffuse sphere, a spherical area light, a point
// light and a dim environment (every light kind directlighting samples: area, delta, infinite);
// the area light takes 4 samples per hit in strategy "all" (pbrt-v3 "nsamples").
std::string diffuseScene(const std::string& integrator) {
  return R"(
LookAt 0 1.5 -4  0 0.6 0  0 1 0
Camera "perspective" "float fov" 45
Film "rgb" "integer xresolution" 32 "integer yresolution" 32 "string filename" "d.exr"
Sampler "independent" "integer pixelsamples" 16
PixelFilter "box"
)" + integrator +
         R"(
WorldBegin
LightSource "point" "rgb I" [1 1 1] "point3 from" [-1 2 -1]
LightSource "infinite" "rgb L" [0.1 0.1 0.1]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [4 4 4] "integer nsamples" 4
  Translate 1 2.2 0
  Shape "sphere" "float radius" 0.3
AttributeEnd
Material "diffuse" "rgb reflectance" [0.7 0.5 0.3]
Shape "trianglemesh" "point3 P" [-4 0 -4  4 0 -4  4 0 4  -4 0 4] "integer indices" [0 1 2 0 2 3]
Shape "trianglemesh" "point3 P" [-4 0 2  4 0 2  4 4 2  -4 4 2] "integer indices" [0 1 2 0 2 3]
AttributeBegin
  Translate 0 0.5 0
  Material "diffuse" "rgb reflectance" [0.3 0.6 0.8]
  Shape "sphere" "float radius" 0.5
AttributeEnd
)";
}

/// The largest |z| over 4x4 blocks of 8x8 pixels of the per-pixel difference a - b (each channel):
/// the block mean of the difference over its standard error from the differences' own spread.
/// Geometry cancels in the difference, so only the noise of the two renders is left.
double worstBlockZ(const Image& a, const Image& b) {
  double worst = 0;
  for (int by = 0; by < 4; ++by)
    for (int bx = 0; bx < 4; ++bx)
      for (int c = 0; c < 3; ++c) {
        double s = 0, s2 = 0;
        int n = 0;
        for (int y = by * 8; y < by * 8 + 8; ++y)
          for (int x = bx * 8; x < bx * 8 + 8; ++x) {
            const double d = double(a.at(x, y, c)) - double(b.at(x, y, c));
            s += d, s2 += d * d, ++n;
          }
        const double mean = s / n;
        const double sem = std::sqrt(std::max(1e-30, (s2 / n - mean * mean) / (n - 1)));
        worst = std::max(worst, std::abs(mean) / sem);
      }
  return worst;
}

RenderOptions seeded(int seed, int spp = 16) {
  RenderOptions o;
  o.seed = seed;
  o.spp = spp;
  return o;
}

}  // namespace

TEST(DirectLightingIntegrator, DiffuseSceneEqualsPathWithMaxDepthOne) {
  const Image path =
      renderText(diffuseScene("Integrator \"path\" \"integer maxdepth\" 1"), seeded(1)).image;
  for (const char* strategy : {"all", "one"}) {
    const Image direct = renderText(diffuseScene(std::string("Integrator \"directlighting\" "
                                                             "\"string strategy\" \"") +
                                                 strategy + "\""),
                                    seeded(2))
                             .image;
    const double z = worstBlockZ(direct, path);
    std::printf("strategy %s: worst block |z| %.2f over 48 block-channels\n", strategy, z);
    EXPECT_LT(z, 4.5) << strategy;
  }
  // The test can fail: path with one more bounce (indirect light) is told apart.
  const Image path2 =
      renderText(diffuseScene("Integrator \"path\" \"integer maxdepth\" 2"), seeded(3)).image;
  const Image direct = renderText(diffuseScene("Integrator \"directlighting\""), seeded(4)).image;
  const double z2 = worstBlockZ(direct, path2);
  std::printf("against path maxdepth 2: worst block |z| %.2f\n", z2);
  EXPECT_GT(z2, 6);
}

namespace {

/// Mean over the pixel of a w x w image (orthographic screen [-1,1]^2, pixel centres at
/// x = -1 + (i + 0.5) 2/w) of f(x, z) on a horizontal plane seen straight down or up.
template <class F>
double pixelAverage(int px, int py, int w, F f) {
  const int k = 8;
  double s = 0;
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      const double sx = -1 + (px + (i + 0.5) / k) * 2 / w, sy = 1 - (py + (j + 0.5) / k) * 2 / w;
      s += f(sx, sy);
    }
  return s / (k * k);
}

}  // namespace

TEST(DirectLightingIntegrator, MirrorShowsRTimesTheLitCeiling) {
  // The orthographic camera at y = 1 looks down at a mirror (y = 0, Kr = R) that reflects a
  // diffuse ceiling (y = 2, albedo a) lit by a point light of intensity I at (0, 1, 0): the
  // ceiling's radiance at horizontal distance r from the light's foot is a/pi I h/(h^2+r^2)^1.5
  // with h = 1, and the mirror shows R times it. The light reflected by the mirror onto the
  // ceiling (a caustic) is no direct lighting and is not counted, by pbrt-v3 either.
  const double R = 0.7, a = 0.6, I = 3, h = 1;
  auto scene = [](const std::string& integrator) {
    return R"(
LookAt 0 1 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-1 1 -1 1]
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "m.exr"
Sampler "stratified" "integer xsamples" 8 "integer ysamples" 8
PixelFilter "box"
)" + integrator +
           R"(
WorldBegin
LightSource "point" "rgb I" [3 3 3] "point3 from" [0 1 0]
AttributeBegin
  Material "mirror" "rgb Kr" [0.7 0.7 0.7]
  Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.6 0.6 0.6]
Shape "trianglemesh" "point3 P" [-5 2 -5  5 2 -5  5 2 5  -5 2 5] "integer indices" [0 1 2 0 2 3]
)";
  };
  const Image im = renderText(scene("Integrator \"directlighting\"")).image;
  double worst = 0;
  for (int y = 0; y < 16; y += 3)
    for (int x = 0; x < 16; x += 3) {
      const double expect = pixelAverage(x, y, 16, [&](double sx, double sz) {
        return R * a / M_PI * I * h / std::pow(h * h + sx * sx + sz * sz, 1.5);
      });
      const double got = im.at(x, y, 1);
      worst = std::max(worst, std::abs(got / expect - 1));
      EXPECT_NEAR(got, expect, 0.01 * expect) << x << "," << y;
    }
  std::printf("mirror: worst relative error %.4f\n", worst);
  // maxdepth 1 follows no specular bounce (pbrt-v3: depth + 1 < maxdepth), nor does path with
  // maxdepth 1: the mirror is black.
  for (const char* it : {"Integrator \"directlighting\" \"integer maxdepth\" 1",
                         "Integrator \"path\" \"integer maxdepth\" 1"}) {
    const Image black = renderText(scene(it)).image;
    EXPECT_EQ(lensim::testutil::regionMean(black, 1, 0, 16, 0, 16), 0.0) << it;
  }
}

TEST(DirectLightingIntegrator, GlassSlabTransmitsTheLitFloor) {
  // A slab of index 1.5 (y from 2 to 2.1) between the camera above and a diffuse floor (y = 0)
  // lit by a point light under the slab. At normal incidence each face transmits T = 1 - R,
  // R = ((n-1)/(n+1))^2 = 0.04; the radiance scalings 1/n^2 in and n^2 out cancel. Within
  // maxdepth 5 the floor is reached straight through (depth 2) and after one reflection inside
  // the slab off each face (depth 4): T^2 (1 + R^2) times the floor's radiance.
  const double n = 1.5, a = 0.5, I = 2, h = 1;
  const double R = std::pow((n - 1) / (n + 1), 2), T = 1 - R;
  const std::string text = R"(
LookAt 0 5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-1 1 -1 1]
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "g.exr"
Sampler "stratified" "integer xsamples" 8 "integer ysamples" 8
PixelFilter "box"
Integrator "directlighting"
WorldBegin
LightSource "point" "rgb I" [2 2 2] "point3 from" [0 1 0]
AttributeBegin
  Material "dielectric" "float eta" 1.5
  Translate 0 2.05 0
  Shape "trianglemesh" "point3 P" [-5 0.05 -5  5 0.05 -5  5 0.05 5  -5 0.05 5
                                   -5 -0.05 -5  5 -0.05 -5  5 -0.05 5  -5 -0.05 5]
        "integer indices" [0 2 1 0 3 2  4 5 6 4 6 7]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
  const Image im = renderText(text).image;
  double worst = 0;
  for (int y = 1; y < 16; y += 3)
    for (int x = 1; x < 16; x += 3) {
      const double expect = pixelAverage(x, y, 16, [&](double sx, double sz) {
        return T * T * (1 + R * R) * a / M_PI * I * h / std::pow(h * h + sx * sx + sz * sz, 1.5);
      });
      const double got = im.at(x, y, 1);
      worst = std::max(worst, std::abs(got / expect - 1));
      EXPECT_NEAR(got, expect, 0.005 * expect) << x << "," << y;
    }
  std::printf("glass slab: worst relative error %.4f\n", worst);
}
