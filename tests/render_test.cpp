// The renderer end to end on small scenes: furnace tests, analytic direct lighting, light pdfs,
// determinism across thread counts, crop windows, output files. Bounds are derived from the
// pixel noise of each render (standard error of a region mean), never bit-exact values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "lensim/render/film/film.h"
#include "lensim/render/lights/lights.h"
#include "lensim/render/materials/materials.h"
#include "lensim/render/renderer.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/sampling.h"
#include "render_test_util.h"

using lensim::io::Image;
using lensim::render::RenderOptions;
using lensim::testutil::RegionStats;
using lensim::testutil::regionStats;
using lensim::testutil::renderText;

namespace {

const char* kFurnaceHeader = R"(
LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 32 "integer yresolution" 32 "string filename" "furnace.exr"
Sampler "independent" "integer pixelsamples" 32
PixelFilter "box"
Integrator "path" "integer maxdepth" 64
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
)";

/// Renders a unit sphere with `material` in the furnace; returns the centre region's stats
/// (the sphere covers the central 12x12 pixels) per channel and the corner's.
struct Furnace {
  RegionStats centre[3], corner[3];
};
Furnace furnace(const std::string& material, int spp = 32) {
  RenderOptions o;
  o.spp = spp;
  const Image im =
      renderText(std::string(kFurnaceHeader) + material + "\nShape \"sphere\" \"float radius\" 1\n",
                 o)
          .image;
  Furnace f;
  for (int c = 0; c < 3; ++c) {
    f.centre[c] = regionStats(im, c, 10, 22, 10, 22);
    f.corner[c] = regionStats(im, c, 0, 4, 0, 4);
  }
  return f;
}

}  // namespace

TEST(Furnace, DiffuseSphereReadsItsAlbedo) {
  for (double a : {0.2, 0.5, 0.9}) {
    Furnace f = furnace("Material \"diffuse\" \"rgb reflectance\" [" + std::to_string(a) + " " +
                        std::to_string(a) + " " + std::to_string(a) + "]");
    for (int c = 0; c < 3; ++c) {
      std::printf("albedo %.1f channel %d: sphere %.4f +- %.4f, background %.4f +- %.4f\n", a, c,
                  f.centre[c].mean, f.centre[c].sem, f.corner[c].mean, f.corner[c].sem);
      // 5 standard errors, plus 0.5% for the RGB -> spectrum -> RGB round trip.
      EXPECT_NEAR(f.centre[c].mean, a, 5 * f.centre[c].sem + 0.005 * a);
      EXPECT_NEAR(f.corner[c].mean, 1.0, 5 * f.corner[c].sem + 0.005);
    }
  }
}

TEST(Furnace, MixChoosesBetweenItsMaterials) {
  // Half the points shade as albedo 0.2, half as 0.8: the sphere reads 0.2 + 0.3 = 0.5 for
  // amount 0.5 and 0.2 + 0.6 x 0.25 = 0.35 for amount 0.25.
  for (double amount : {0.5, 0.25}) {
    Furnace f = furnace(
        "MakeNamedMaterial \"dark\" \"string type\" \"diffuse\" \"rgb reflectance\" [.2 .2 .2]\n"
        "MakeNamedMaterial \"light\" \"string type\" \"diffuse\" \"rgb reflectance\" [.8 .8 .8]\n"
        "Material \"mix\" \"string materials\" [\"dark\" \"light\"] \"float amount\" " +
        std::to_string(amount));
    const double expect = 0.2 + 0.6 * amount;
    std::printf("mix amount %.2f: %.4f +- %.4f (expect %.3f)\n", amount, f.centre[1].mean,
                f.centre[1].sem, expect);
    EXPECT_NEAR(f.centre[1].mean, expect, 5 * f.centre[1].sem + 0.005);
  }
}

TEST(Furnace, LosslessMaterialsConserveEnergy) {
  // No absorption: a smooth glass sphere (refraction scales radiance by 1/eta^2 going in and
  // eta^2 coming out), a thin dielectric, a white diffuse transmitter.
  for (const char* m : {"Material \"dielectric\" \"float eta\" 1.5",
                        "Material \"thindielectric\" \"float eta\" 1.5",
                        "Material \"dielectric\" \"float eta\" 1.33 \"float roughness\" 0.0001",
                        "Material \"diffusetransmission\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"rgb transmittance\" [0.5 0.5 0.5]"}) {
    Furnace f = furnace(m);
    for (int c = 0; c < 3; ++c) {
      std::printf("%s channel %d: %.4f +- %.4f\n", m, c, f.centre[c].mean, f.centre[c].sem);
      EXPECT_NEAR(f.centre[c].mean, 1.0, 5 * f.centre[c].sem + 0.005) << m;
    }
  }
}

TEST(Furnace, LossyMaterialsStayBelowOne) {
  // Single-scattering microfacet models (no multiple scattering between microfacets: at
  // alpha = 0.45 a white conductor keeps only ~74% at normal incidence) and the truncated layered
  // random walk lose energy; none may create it. Measured values are printed.
  for (const char* m : {"Material \"dielectric\" \"float eta\" 1.5 \"float roughness\" 0.3",
                        "Material \"coateddiffuse\" \"rgb reflectance\" [1 1 1]",
                        "Material \"conductor\" \"rgb reflectance\" [0.9 0.9 0.9] "
                        "\"float roughness\" 0.2",
                        "Material \"coatedconductor\" \"rgb reflectance\" [0.95 0.95 0.95] "
                        "\"float interface.roughness\" 0.05",
                        "Material \"matte\" \"color Kd\" [1 1 1] \"float sigma\" 20"}) {
    Furnace f = furnace(m);
    for (int c = 0; c < 3; ++c) {
      std::printf("%s channel %d: %.4f +- %.4f\n", m, c, f.centre[c].mean, f.centre[c].sem);
      EXPECT_LE(f.centre[c].mean, 1.0 + 5 * f.centre[c].sem + 0.005) << m;
      EXPECT_GE(f.centre[c].mean, 0.5) << m;
    }
  }
}

TEST(DirectLighting, DiffusePlaneUnderPointLightMatchesClosedForm) {
  // A point light of intensity I at height h above a diffuse plane of albedo a, seen straight
  // down by an orthographic camera: L(r) = a/pi * I h / (h^2 + r^2)^(3/2).
  const double I = 3, h = 1, a = 0.6;
  const std::string text = R"(
LookAt 0 5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-1 1 -1 1]
Film "rgb" "integer xresolution" 20 "integer yresolution" 20 "string filename" "p.exr"
Sampler "stratified" "integer xsamples" 8 "integer ysamples" 8
PixelFilter "box"
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "point" "rgb I" [3 3 3] "point3 from" [0 1 0]
Material "diffuse" "rgb reflectance" [0.6 0.6 0.6]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
  const Image im = renderText(text).image;
  double worst = 0;
  for (int y = 0; y < 20; y += 3)
    for (int x = 0; x < 20; x += 3) {
      // Pixel centre on the plane: screen [-1,1]^2 over 20 pixels; the box filter averages
      // over the pixel, so compare with the pixel-area average of the closed form.
      double expect = 0;
      const int k = 8;
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          const double sx = -1 + (x + (i + 0.5) / k) / 10, sy = 1 - (y + (j + 0.5) / k) / 10;
          const double r2 = sx * sx + sy * sy;
          expect += a / M_PI * I * h / std::pow(h * h + r2, 1.5) / (k * k);
        }
      const double got = im.at(x, y, 1);
      worst = std::max(worst, std::abs(got / expect - 1));
      EXPECT_NEAR(got, expect, 0.01 * expect) << x << "," << y;
    }
  std::printf("point light: worst relative error %.4f\n", worst);
}

TEST(DirectLighting, DiffusePlaneUnderSphereLightMatchesClosedForm) {
  // A sphere of radius R and radiance Le centred at height h above a diffuse plane: at the
  // point below it the irradiance is pi Le (R/h)^2, so L = a Le (R/h)^2.
  const double R = 0.25, h = 1, a = 0.5, Le = 4;
  const std::string text = R"(
LookAt 0 5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.05 0.05 -0.05 0.05]
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "s.exr"
Sampler "independent" "integer pixelsamples" 64
PixelFilter "box"
Integrator "path" "integer maxdepth" 1
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [4 4 4]
  Translate 0 1 0
  Shape "sphere" "float radius" 0.25
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
  // The camera looks down through the light: orthographic rays from above would hit the sphere,
  // so the camera sits below the sphere's bottom (y = 0.75) looking down.
  std::string t = text;
  t.replace(t.find("LookAt 0 5 0"), 12, "LookAt 0 0.7 0");
  const Image im = renderText(t).image;
  const RegionStats s = regionStats(im, 1, 0, 8, 0, 8);
  const double expect = a * Le * (R / h) * (R / h);
  std::printf("sphere light: %.5f +- %.5f, closed form %.5f\n", s.mean, s.sem, expect);
  // The 0.1 x 0.1 patch varies by < 0.5% from its centre value.
  EXPECT_NEAR(s.mean, expect, 5 * s.sem + 0.005 * expect);
}

TEST(Lights, PdfsIntegrateToOne) {
  // For each light, the solid-angle pdf of sampleLi seen from a point integrates to 1 over the
  // directions that reach the light: estimated by uniform sphere sampling of directions.
  const std::string text = R"(
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "x.exr"
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1]
  Translate 0 2 0
  Shape "sphere" "float radius" 0.5
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Translate 2 0 0
  Rotate 90 0 1 0
  Shape "disk" "float radius" 0.7
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Translate 0 -1.5 0
  Shape "cylinder" "float radius" 0.3 "float zmin" -0.5 "float zmax" 0.5
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "trianglemesh" "point3 P" [-1 -1 3  1 -1 3  0 1 2.5] "integer indices" [0 1 2]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Translate -2 0 0
  Rotate 90 0 1 0
  Shape "cone" "float radius" 0.5 "float height" 0.8 "float phimax" 300
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "bool twosided" true
  Shape "bilinearmesh" "point3 P" [-1 -1 -3  1 -1 -3  -1 1 -3  1 1 -3.5]
AttributeEnd
LightSource "infinite" "rgb L" [1 1 1]
)";
  lensim::scene::Scene s = lensim::testutil::buildText(text);
  lensim::render::Accel accel(s);
  lensim::render::Textures tex(s);
  lensim::render::LightSet lights(s, accel, tex);
  ASSERT_EQ(lights.size(), 7u);
  const lensim::Vec3 p{0.1, 0.05, -0.1};
  lensim::sampling::Rng rng(7, 11);
  const int n = 400000;
  for (size_t li = 0; li < lights.size(); ++li) {
    const lensim::render::Light& light = lights.light(li);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
      const lensim::Vec3 w = lensim::sampling::sampleUniformSphere({rng.uniform(), rng.uniform()});
      double pdf = 0;
      if (light.isInfinite()) {
        pdf = light.pdfLi(p, w, nullptr);
      } else {
        // Area sampling covers every point of the light, also those behind its own front
        // (the cylinder's far side): sum over all crossings of the light along w.
        lensim::Vec3 o = p;
        for (int k = 0; k < 8; ++k) {
          auto hit = accel.intersect({o, w, INFINITY});
          if (!hit) break;
          if (lights.areaLight(hit->shape, hit->prim) == &light) {
            pdf += light.pdfLi(p, w, &*hit);
            // A sphere seen from outside is sampled within its cone of directions: one
            // density per direction.
            if (s.shapes[size_t(hit->shape)].type == lensim::scene::ShapeType::Sphere) break;
          }
          o = hit->p + w * 1e-6;
        }
      }
      const double v = pdf / lensim::sampling::uniformSpherePdf();
      sum += v, sum2 += v * v;
    }
    const double mean = sum / n, sem = std::sqrt((sum2 / n - mean * mean) / n);
    std::printf("light %zu: integral of pdf %.4f +- %.4f\n", li, mean, sem);
    EXPECT_NEAR(mean, 1.0, 5 * sem + 0.002) << "light " << li;
  }
}

TEST(NormalMap, TiltsTheShadingNormal) {
  // A plane lit by a point light straight above the viewed spot. A flat normal map (RGB 0.5 0.5 1
  // read linearly) changes nothing; one tilted by 60 degrees halves the diffuse reflection.
  lensim::testutil::TempDir dir("lensim-normalmap");
  auto mapFile = [&](const std::string& name, lensim::Vec3 n) {
    lensim::io::Image im(4, 4, {"R", "G", "B"});
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x)
        for (int c = 0; c < 3; ++c)
          im.at(x, y, c) = float((n[c] + 1) / 2);  // linear values, stored as EXR
    const std::string path = dir.file(name);
    lensim::io::writeImage(path, im);
    return path;
  };
  const double t = 60 * M_PI / 180;
  const std::string flat = mapFile("flat.exr", {0, 0, 1});
  const std::string tilted = mapFile("tilted.exr", {std::sin(t), 0, std::cos(t)});
  auto scene = [&](const std::string& map) {
    return std::string(R"(
LookAt 0 0.5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.01 0.01 -0.01 0.01]
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "n.exr"
Sampler "independent" "integer pixelsamples" 4
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "point" "rgb I" [1 1 1] "point3 from" [0 1 0]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5])") +
           (map.empty() ? "" : " \"string normalmap\" \"" + map + "\"") + R"(
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
  };
  const double plain = regionStats(renderText(scene("")).image, 1, 0, 4, 0, 4).mean;
  const double with_flat = regionStats(renderText(scene(flat)).image, 1, 0, 4, 0, 4).mean;
  const double with_tilt = regionStats(renderText(scene(tilted)).image, 1, 0, 4, 0, 4).mean;
  std::printf("normal map: plain %.5f flat %.5f tilted %.5f (ratio %.4f, expect 0.5)\n", plain,
              with_flat, with_tilt, with_tilt / plain);
  EXPECT_NEAR(plain, 0.5 / M_PI, 0.002);
  EXPECT_NEAR(with_flat / plain, 1.0, 0.002);
  EXPECT_NEAR(with_tilt / plain, 0.5, 0.01);
}

namespace {

/// Luminance of the centre of a tiny patch of a diffuse plane (albedo 0.5) seen from above,
/// lit by `light` (pbrt-v4 syntax), direct lighting only.
double planeLuminance(const std::string& light) {
  const std::string text = R"(
LookAt 0 0.5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.01 0.01 -0.01 0.01]
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "l.exr"
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
)" + light + R"(
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
  const Image im = renderText(text).image;
  double y = 0;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) y += lensim::testutil::luminanceAt(im, i, j) / 16;
  return y;
}

}  // namespace

TEST(LightUnits, ScaleAndPowerFollowPbrtV4) {
  const double a_pi = 0.5 / M_PI;  // diffuse BRDF of the plane
  struct Case {
    std::string light;
    double expect;  // luminance of the plane under the light (height 1 where it applies)
  };
  const double cs = std::cos(25 * M_PI / 180), ce = std::cos(30 * M_PI / 180);
  const std::vector<Case> cases = {
      {R"(LightSource "point" "rgb I" [2 2 2] "point3 from" [0 1 0])", a_pi * 2},
      {R"(LightSource "point" "rgb I" [1 1 1] "float scale" 3 "point3 from" [0 2 0])",
       a_pi * 3 / 4},
      // power: I = P / 4 pi (after normalising the spectrum to unit luminance).
      {R"(LightSource "point" "blackbody I" 3000 "float power" 100 "point3 from" [0 1 0])",
       a_pi * 100 / (4 * M_PI)},
      {R"(LightSource "spot" "rgb I" [2 2 2] "point3 from" [0 1 0] "point3 to" [0 0 0])", a_pi * 2},
      {R"(LightSource "spot" "rgb I" [1 1 1] "float power" 10 "point3 from" [0 1 0]
         "point3 to" [0 0 0] "float coneangle" 30 "float conedeltaangle" 5)",
       a_pi * 10 / (2 * M_PI * ((1 - cs) + (cs - ce) / 2))},
      {R"(LightSource "distant" "rgb L" [2 2 2] "point3 from" [0 1 0] "point3 to" [0 0 0])",
       a_pi * 2},
      // A blackbody spectrum is normalised to unit luminance, then scaled.
      {R"(LightSource "distant" "blackbody L" 5500 "float scale" 1.5 "point3 from" [0 1 0]
         "point3 to" [0 0 0])",
       a_pi * 1.5},
      // Tilted: irradiance times cos 60 degrees.
      {R"(LightSource "distant" "rgb L" [1 1 1] "point3 from" [0 1 1.7320508] "point3 to" [0 0 0])",
       a_pi * 0.5},
  };
  for (const Case& c : cases) {
    const double got = planeLuminance(c.light);
    std::printf("%-60.60s %.5f (expect %.5f)\n", c.light.c_str(), got, c.expect);
    // Delta lights: no noise; 1% for the RGB/spectrum round trip of the film.
    EXPECT_NEAR(got, c.expect, 0.01 * c.expect) << c.light;
  }
}

TEST(ImageTexture, ReadsSrgbPngTopRowAtVOne) {
  // A 2x2 PNG (top row red, bottom row blue) on a unit quad with uv (0,0) at the bottom-left:
  // pbrt puts the image's top row at v = 1. The 8-bit values are sRGB-decoded.
  lensim::testutil::TempDir dir("lensim-imagetex");
  lensim::io::Image im(2, 2, {"R", "G", "B"});
  for (int x = 0; x < 2; ++x) {
    im.at(x, 0, 0) = 0.5f;  // top: red 0.5 (linear), stored as sRGB 188
    im.at(x, 1, 2) = 0.5f;  // bottom: blue
  }
  lensim::io::writeImage(dir.file("rb.png"), im);
  const std::string text = R"(
LookAt 0 0 -1  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [-0.5 0.5 -0.5 0.5]
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "t.exr"
Sampler "independent" "integer pixelsamples" 4
PixelFilter "box"
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Texture "img" "spectrum" "imagemap" "string filename" ")" +
                           dir.file("rb.png") + R"(" "string filter" "point"
Material "diffusetransmission" "texture reflectance" "img" "rgb transmittance" [0 0 0]
Shape "bilinearmesh" "point3 P" [0.5 -0.5 0  -0.5 -0.5 0  0.5 0.5 0  -0.5 0.5 0]
  "point2 uv" [0 0 1 0 0 1 1 1]
)";
  const Image out = renderText(text).image;
  // Rows 0-1 (top of the picture) are red, rows 6-7 blue: a diffuse transmitter under a
  // uniform sky reflects its reflectance (half of the hemisphere is the sky behind the quad:
  // it transmits nothing, so the reading is the reflectance exactly).
  const RegionStats top_r = regionStats(out, 0, 0, 8, 0, 2),
                    top_b = regionStats(out, 2, 0, 8, 0, 2);
  const RegionStats bot_r = regionStats(out, 0, 0, 8, 6, 8),
                    bot_b = regionStats(out, 2, 0, 8, 6, 8);
  std::printf("image texture: top R %.4f B %.4f, bottom R %.4f B %.4f\n", top_r.mean, top_b.mean,
              bot_r.mean, bot_b.mean);
  EXPECT_NEAR(top_r.mean, 0.5, 5 * top_r.sem + 0.02);
  EXPECT_NEAR(bot_b.mean, 0.5, 5 * bot_b.sem + 0.02);
  EXPECT_LT(top_b.mean, 0.05);
  EXPECT_LT(bot_r.mean, 0.05);
}

TEST(Alpha, CutOutSurfacesAreInvisibleToCameraAndShadowRays) {
  // A plane with alpha 0 between the camera, a point light and a lit plane: the image is the
  // same as without it (same samples; only float rounding of the hit points differs).
  const std::string base = R"(
LookAt 0 0.5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.01 0.01 -0.01 0.01]
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "a.exr"
Sampler "independent" "integer pixelsamples" 4
Integrator "path" "integer maxdepth" 2
WorldBegin
LightSource "point" "rgb I" [2 2 2] "point3 from" [0 1 0]
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
  const std::string cut =
      base + R"(Shape "trianglemesh" "point3 P" [-5 0.3 -5  5 0.3 -5  5 0.3 5  -5 0.3 5]
  "integer indices" [0 1 2 0 2 3] "float alpha" 0
)";
  const std::string opaque =
      base + R"(Shape "trianglemesh" "point3 P" [-5 0.3 -5  5 0.3 -5  5 0.3 5  -5 0.3 5]
  "integer indices" [0 1 2 0 2 3] "float alpha" 1
)";
  const Image a = renderText(base).image, b = renderText(cut).image, c = renderText(opaque).image;
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  double diff_cut = 0, diff_opaque = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    diff_cut = std::max(diff_cut, double(std::abs(a.pixels[i] - b.pixels[i])));
    diff_opaque = std::max(diff_opaque, double(std::abs(a.pixels[i] - c.pixels[i])));
  }
  EXPECT_LT(diff_cut, 1e-4);
  EXPECT_GT(diff_opaque, 0.05);  // the opaque plane (lit, nearer the light) is what one sees
}

TEST(Lights, EnvironmentMapSamplingMatchesItsRadiance) {
  // For equal-area (square) and latitude-longitude environment maps: the pdf of sampleLi
  // integrates to 1 over the sphere, and the importance-sampled estimate of the integral of Le
  // (E[Le / pdf]) equals the uniform-sampling estimate.
  lensim::testutil::TempDir dir("lensim-envmap");
  for (auto [w, h] : {std::pair{16, 16}, std::pair{32, 16}}) {
    lensim::io::Image im(w, h, {"R", "G", "B"});
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float v =
            0.05f + float((x * 7 + y * 3) % 11) / 5.0f + (x == 3 && y == 4 ? 20.f : 0.f);
        im.at(x, y, 0) = v;
        im.at(x, y, 1) = 0.5f * v;
        im.at(x, y, 2) = 0.25f * v + 0.1f;
      }
    const std::string file = dir.file("env" + std::to_string(w) + ".exr");
    lensim::io::writeImage(file, im);
    const std::string text = R"(
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "x.exr"
WorldBegin
AttributeBegin
  Rotate 30 1 0 0
  LightSource "infinite" "string filename" ")" +
                             file + R"("
AttributeEnd
)";
    lensim::scene::Scene s = lensim::testutil::buildText(text);
    lensim::render::Accel accel(s);
    lensim::render::Textures tex(s);
    lensim::render::LightSet lights(s, accel, tex);
    ASSERT_EQ(lights.size(), 1u);
    const lensim::render::Light& light = lights.light(0);
    const auto lambda = lensim::render::SampledWavelengths::sampleUniform(0.3);
    lensim::sampling::Rng rng(3, 5);
    const int n = 200000;
    double pdf_sum = 0, pdf_sum2 = 0, uni = 0, uni2 = 0, imp = 0, imp2 = 0;
    for (int i = 0; i < n; ++i) {
      const lensim::Vec2 u{rng.uniform(), rng.uniform()};
      const lensim::Vec3 wdir = lensim::sampling::sampleUniformSphere(u);
      const double p = light.pdfLi({0, 0, 0}, wdir, nullptr) * 4 * M_PI;
      pdf_sum += p, pdf_sum2 += p * p;
      const double lu = light.Le(wdir, lambda)[0] * 4 * M_PI;
      uni += lu, uni2 += lu * lu;
      auto ls = light.sampleLi({0, 0, 0}, {rng.uniform(), rng.uniform()}, lambda);
      ASSERT_TRUE(ls);
      const double li = ls->L[0] / ls->pdf;
      imp += li, imp2 += li * li;
      // The sample's pdf is the pdf of its direction.
      ASSERT_NEAR(ls->pdf, light.pdfLi({0, 0, 0}, ls->wi, nullptr), 1e-6 * ls->pdf + 1e-9);
    }
    auto sem = [&](double s, double s2) { return std::sqrt((s2 / n - (s / n) * (s / n)) / n); };
    std::printf(
        "env %dx%d: pdf integral %.4f +- %.4f; integral of Le: uniform %.4f +- %.4f, "
        "importance %.4f +- %.4f\n",
        w, h, pdf_sum / n, sem(pdf_sum, pdf_sum2), uni / n, sem(uni, uni2), imp / n,
        sem(imp, imp2));
    EXPECT_NEAR(pdf_sum / n, 1.0, 5 * sem(pdf_sum, pdf_sum2));
    const double tol = 5 * std::hypot(sem(uni, uni2), sem(imp, imp2));
    EXPECT_NEAR(imp / n, uni / n, tol);
    // Importance sampling must help: its error is smaller.
    EXPECT_LT(sem(imp, imp2), sem(uni, uni2));
  }
}

TEST(DirectionMix, BlendsByTheNormalsAlignment) {
  // A sphere under a uniform sky: where the normal is along "dir" it shows tex1 (white), where it
  // is perpendicular tex2 (black). Seen along dir, the sphere's centre is near 1, its rim near 0.
  Furnace f = furnace(R"(Texture "dm" "spectrum" "directionmix" "rgb tex1" [0.8 0.8 0.8]
  "rgb tex2" [0 0 0] "vector3 dir" [0 0 1]
Material "diffuse" "texture reflectance" "dm")");
  std::printf("directionmix: centre %.4f\n", f.centre[1].mean);
  // The central 12x12 pixels see normals within ~40 degrees of dir: |cos| > 0.75.
  EXPECT_GT(f.centre[1].mean, 0.6);
  EXPECT_LT(f.centre[1].mean, 0.8 + 5 * f.centre[1].sem);
}

TEST(LightUnits, GoniometricLightScalesByItsImage) {
  // A latitude-longitude image (8x4): rows near the light's +y pole 2, rows near -y 0.5. The
  // plane below the light is seen along -y: it gets I x 0.5. Without an image it is a point
  // light; with "power" P the intensity is P / (4 pi x the image's mean over the sphere).
  lensim::testutil::TempDir dir("lensim-gonio");
  lensim::io::Image im(8, 4, {"R", "G", "B"});
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = y < 2 ? 2.0f : 0.5f;
  const std::string file = dir.file("gonio.exr");
  lensim::io::writeImage(file, im);
  const double a_pi = 0.5 / M_PI;
  const double plain = planeLuminance(
      R"(AttributeBegin
  Translate 0 1 0
  LightSource "goniometric" "rgb I" [2 2 2]
AttributeEnd)");
  EXPECT_NEAR(plain, a_pi * 2, 0.01 * a_pi * 2);
  const double imaged = planeLuminance(R"(AttributeBegin
  Translate 0 1 0
  LightSource "goniometric" "rgb I" [2 2 2] "string filename" ")" +
                                       file + R"("
AttributeEnd)");
  EXPECT_NEAR(imaged, a_pi * 2 * 0.5, 0.01 * a_pi);
  // The image's mean over the sphere is 1.25 (half the solid angle each).
  const double powered = planeLuminance(R"(AttributeBegin
  Translate 0 1 0
  LightSource "goniometric" "rgb I" [1 1 1] "float power" 50 "string filename" ")" +
                                        file + R"("
AttributeEnd)");
  EXPECT_NEAR(powered, a_pi * 50 / (4 * M_PI * 1.25) * 0.5, 0.01 * a_pi);
  std::printf("goniometric: plain %.4f imaged %.4f powered %.4f\n", plain, imaged, powered);
}

TEST(NamedSpectra, UntabulatedPbrtNamesStillRender) {
  // BK7 from Schott's Sellmeier formula: n_d = 1.5168 at 587.56 nm, n_F = 1.5224 at 486.13 nm.
  auto bk7 = lensim::render::makeSpectrum(lensim::scene::SpectrumValue::named("glass-BK7"),
                                          lensim::render::SpectrumType::Unbounded);
  EXPECT_NEAR(bk7->eval(587.56), 1.5168, 1e-4);
  EXPECT_NEAR(bk7->eval(486.13), 1.5224, 1e-4);
  // A dispersive glass sphere is still lossless in the furnace (only the hero wavelength
  // survives refraction, so it is noisier).
  Furnace f = furnace(R"(Material "dielectric" "spectrum eta" "glass-BK7")", 64);
  for (int c = 0; c < 3; ++c) {
    std::printf("BK7 sphere channel %d: %.4f +- %.4f\n", c, f.centre[c].mean, f.centre[c].sem);
    EXPECT_NEAR(f.centre[c].mean, 1.0, 5 * f.centre[c].sem + 0.01);
  }
}

TEST(LightUnits, ProjectionLightProjectsItsImage) {
  // A 2x1 image (left white, right black) projected straight down from (0, 1, 0) with a 90
  // degree field of view: the light's +x is the world's +x, so the floor at x < 0 is lit with
  // intensity 1 (RGB white is unit-luminance D65), the floor at x > 0 is dark, and points
  // outside the frustum get nothing.
  lensim::testutil::TempDir dir("lensim-projection");
  lensim::io::Image im(2, 1, {"R", "G", "B"});
  for (int c = 0; c < 3; ++c) im.at(0, 0, c) = 1;
  const std::string file = dir.file("proj.exr");
  lensim::io::writeImage(file, im);
  const std::string text = R"(
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "x.exr"
WorldBegin
AttributeBegin
  Translate 0 1 0
  Rotate 90 1 0 0
  LightSource "projection" "float fov" 90 "string filename" ")" +
                           file + R"("
AttributeEnd
Shape "sphere" "float radius" 0.01
)";
  lensim::scene::Scene s = lensim::testutil::buildText(text);
  ASSERT_EQ(lensim::testutil::errorsOf(s), "");
  lensim::render::Accel accel(s);
  lensim::render::Textures tex(s);
  lensim::render::LightSet lights(s, accel, tex);
  ASSERT_EQ(lights.size(), 1u);
  const auto& light = lights.light(0);
  double y_left = 0, y_right = 0;
  int left_hits = 0;
  for (int i = 0; i < 64; ++i) {
    const auto lambda = lensim::render::SampledWavelengths::sampleVisible((i + 0.5) / 64);
    if (auto ls = light.sampleLi({-0.5, 0, 0.3}, {0.5, 0.5}, lambda)) {
      y_left += lensim::render::sampledToXyz(ls->L, lambda).y / 64;
      ++left_hits;
    }
    if (auto ls = light.sampleLi({0.5, 0, 0.3}, {0.5, 0.5}, lambda))
      y_right += lensim::render::sampledToXyz(ls->L, lambda).y / 64;
    EXPECT_FALSE(light.sampleLi({3, 0, 0}, {0.5, 0.5}, lambda).has_value());
  }
  EXPECT_EQ(left_hits, 64);
  const double r2 = 0.25 + 1 + 0.09;
  std::printf("projection: left %.4f (expect %.4f), right %.4f\n", y_left, 1 / r2, y_right);
  EXPECT_NEAR(y_left, 1 / r2, 0.03 / r2);  // spectral noise of 64 wavelength sets
  EXPECT_EQ(y_right, 0);
}

TEST(Materials, RegularizeRoughensSpecularLobes) {
  lensim::scene::Scene s = lensim::testutil::buildText(R"(
Integrator "path" "bool regularize" true
WorldBegin
Material "conductor" "spectrum eta" "metal-Au-eta" "spectrum k" "metal-Au-k"
Shape "sphere"
Material "dielectric" "float roughness" 0.5
Shape "sphere"
)");
  EXPECT_TRUE(s.integrator.regularize);
  lensim::render::Textures tex(s);
  lensim::render::Materials mats(s, tex);
  auto lambda = lensim::render::SampledWavelengths::sampleUniform(0.5);
  const lensim::render::TextureEvalContext ctx{};
  using lensim::render::BxDFFlags;
  const int smooth = s.shapes[0].material, rough = s.shapes[1].material;
  EXPECT_TRUE(any(mats.bxdf(smooth, ctx, lambda, false)->flags(), BxDFFlags::Specular));
  EXPECT_TRUE(any(mats.bxdf(smooth, ctx, lambda, true)->flags(), BxDFFlags::Glossy));
  // Already rough (alpha = sqrt(0.5) > 0.3): unchanged.
  EXPECT_TRUE(any(mats.bxdf(rough, ctx, lambda, true)->flags(), BxDFFlags::Glossy));
}

TEST(Film, WhiteBalanceNeutralisesItsIlluminant) {
  // A white plane under a 3000 K blackbody: without white balance it is orange; with
  // "whitebalance" 3000 it is neutral (lensim's white for a temperature is the CIE daylight
  // locus from 4000 K, where pbrt-v4 uses its D illuminant, and the blackbody below, where the
  // locus is not defined).
  auto render = [&](const std::string& film_extra) {
    const std::string text = R"(
LookAt 0 0.5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.01 0.01 -0.01 0.01]
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "w.exr" )" +
                             film_extra + R"(
Sampler "independent" "integer pixelsamples" 64
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "distant" "blackbody L" 3000 "point3 from" [0 1 0] "point3 to" [0 0 0]
Material "diffuse" "rgb reflectance" [1 1 1]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
    const Image im = renderText(text).image;
    lensim::Vec3 m{0, 0, 0};
    for (int c = 0; c < 3; ++c)
      (c == 0 ? m.x : c == 1 ? m.y : m.z) = regionStats(im, c, 0, 4, 0, 4).mean;
    return m;
  };
  const lensim::Vec3 raw = render(""), balanced = render("\"float whitebalance\" 3000");
  std::printf("white balance: raw %.3f %.3f %.3f, balanced %.3f %.3f %.3f\n", raw.x, raw.y, raw.z,
              balanced.x, balanced.y, balanced.z);
  EXPECT_GT(raw.x / raw.z, 1.2);
  // 64 wavelength sets per pixel: ~1% spectral noise.
  EXPECT_NEAR(balanced.x / balanced.y, 1.0, 0.03);
  EXPECT_NEAR(balanced.z / balanced.y, 1.0, 0.03);
  // D65 balance leaves the image as it is.
  const lensim::Vec2 d65 = lensim::render::daylightChromaticity(6504);
  EXPECT_NEAR(d65.x, 0.3127, 5e-4);
  EXPECT_NEAR(d65.y, 0.3291, 5e-4);
}

TEST(LightUnits, ImageAreaLightEmitsItsTexels) {
  // A one-sided 1x1 quad light facing down at height 1 over a diffuse plane. With a uniform white
  // image it equals "rgb L" [1 1 1]; with the image's right half black it equals a quad of the
  // left half alone (u runs along +x, the image's left column is u < 0.5).
  lensim::testutil::TempDir dir("lensim-imagelight");
  auto image = [&](const std::string& name, float right) {
    lensim::io::Image im(2, 1, {"R", "G", "B"});
    for (int c = 0; c < 3; ++c) im.at(0, 0, c) = 1, im.at(1, 0, c) = right;
    lensim::io::writeImage(dir.file(name), im);
    return dir.file(name);
  };
  auto lum = [&](const std::string& light, const std::string& quad) {
    const std::string text = R"(
LookAt 0 0.5 0  0 0 0  0 0 1
Camera "orthographic" "float screenwindow" [-0.01 0.01 -0.01 0.01]
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "l.exr"
Sampler "independent" "integer pixelsamples" 256
PixelFilter "box"
Integrator "path" "integer maxdepth" 1
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" )" +
                             light + R"(
  Shape "bilinearmesh" "point3 P" [)" +
                             quad + R"(]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
    const Image im = renderText(text).image;
    return regionStats(im, 1, 0, 4, 0, 4);
  };
  const std::string full = "-0.5 1 -0.5  0.5 1 -0.5  -0.5 1 0.5  0.5 1 0.5";
  const std::string left = "-0.5 1 -0.5  0 1 -0.5  -0.5 1 0.5  0 1 0.5";
  const RegionStats a = lum("\"rgb L\" [1 1 1]", full);
  const RegionStats b = lum("\"string filename\" \"" + image("white.exr", 1) + "\"", full);
  const RegionStats c = lum("\"rgb L\" [1 1 1]", left);
  const RegionStats d = lum("\"string filename\" \"" + image("half.exr", 0) + "\"", full);
  std::printf(
      "image area light: L %.4f +- %.4f, white image %.4f +- %.4f; half quad %.4f +- "
      "%.4f, half image %.4f +- %.4f\n",
      a.mean, a.sem, b.mean, b.sem, c.mean, c.sem, d.mean, d.sem);
  EXPECT_NEAR(a.mean, b.mean, 5 * std::hypot(a.sem, b.sem) + 0.005 * a.mean);
  EXPECT_NEAR(c.mean, d.mean, 5 * std::hypot(c.sem, d.sem) + 0.005 * c.mean);
  EXPECT_GT(c.mean, 0.3 * a.mean);
}

// --pbrt-v2-quirks, the ray epsilon: pbrt-v2 gives a hit at camera-ray parameter t (counted in
// camera-space units) the epsilon 1e-3 t, and its shadow and BSDF rays skip everything nearer.
// A camera between a floor and a large opaque roof, looking down at the floor 0.3 away, under a
// disc light 4 above: physically the floor is black. With a camera transform scaled by 5000
// (epsilon 1.5) pbrt-v2 skips the roof, and the floor reads as if there were no roof; scaled by
// 20000 (epsilon 6) it also loses the light hits of BSDF sampling, so it is darker than that but
// not black; unscaled (epsilon 3e-4) the roof still shadows.
TEST(PbrtV2Quirks, RayEpsilonGrowsWithTheCameraRayParameter) {
  auto sceneText = [](double scale, bool roof) {
    std::string s = "Scale " + std::to_string(scale) + " " + std::to_string(scale) + " " +
                    std::to_string(scale) + R"(
LookAt 0 0.3 0  0 0 0  0 0 1
Camera "perspective" "float fov" 10
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "a.exr"
Sampler "independent" "integer pixelsamples" 64
Integrator "path" "integer maxdepth" 1
WorldBegin
AttributeBegin
AreaLightSource "diffuse" "rgb L" [4 4 4]
Translate 0 4 0
Rotate 90 1 0 0
Shape "disk" "float radius" 8
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5] "integer indices" [0 1 2 0 2 3]
)";
    if (roof)
      s += R"(Shape "trianglemesh" "point3 P" [-3 0.5 -3  3 0.5 -3  3 0.5 3  -3 0.5 3]
  "integer indices" [0 1 2 0 2 3]
)";
    return s;
  };
  auto mean = [](const Image& im) { return regionStats(im, 1, 0, im.width, 0, im.height).mean; };
  RenderOptions physical, quirks;
  quirks.pbrt_v2_quirks = true;
  const double open = mean(renderText(sceneText(1, false), physical).image);
  const double roofed = mean(renderText(sceneText(5000, true), physical).image);
  const double q1 = mean(renderText(sceneText(1, true), quirks).image);
  const double q5000 = mean(renderText(sceneText(5000, true), quirks).image);
  const double q20000 = mean(renderText(sceneText(20000, true), quirks).image);
  std::printf("floor: open %.4f, roofed %.4f; quirks: unscaled %.4f, x5000 %.4f, x20000 %.4f\n",
              open, roofed, q1, q5000, q20000);
  ASSERT_GT(open, 0.01);
  EXPECT_LT(roofed, 1e-6);
  EXPECT_LT(q1, 1e-6);
  EXPECT_NEAR(q5000, open, 0.03 * open);
  EXPECT_GT(q20000, 0.1 * open);
  EXPECT_LT(q20000, 0.9 * open);
}
