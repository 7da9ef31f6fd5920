// Dispersion in renders (issue 10): lateral colour of an off-axis light through a dispersive lens
// against the workbench's chief rays, none through the same lens without dispersion; the hero
// wavelength scheme stays unbiased; a prism's deviation against Snell's law.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "lensim/optics/chromatic.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/glass.h"
#include "lensim/render/materials/bsdf.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/render/textures/textures.h"
#include "lensim/scene/description.h"
#include "render_test_util.h"
#include "test_paths.h"

using namespace lensim;

namespace {

constexpr double kPi = std::numbers::pi;

// The test lens: a landscape lens (stop in front of an N-SF66 meniscus), and the same rows with
// a constant index (no glass column).
std::string writeLens(bool dispersive) {
  const std::string path =
      std::string(::testing::TempDir()) + (dispersive ? "disp.dat" : "plain.dat");
  std::FILE* f = std::fopen(path.c_str(), "w");
  std::fprintf(f, "0 12 0 5\n-40 5 1.92286 22%s\n-18 0 0 26\n",
               dispersive ? " - schott:N-SF66" : "");
  std::fclose(f);
  return path;
}

constexpr int kRes = 1400;                                // film pixels across
constexpr double kDiagonal = 35;                          // mm
constexpr double kFieldDeg = 15;                          // the light's field angle
constexpr double kDistance = 100;                         // m
const double kPitch = kDiagonal / std::sqrt(2.0) / kRes;  // mm per pixel

// A small sphere light (3 mrad) at 15 degrees off axis, emitting a narrow band around
// `centre_nm`, through the lens; returns the x centroid of its image (film mm from the centre,
// along the raster x axis) from the luminance of a window around it.
double imageCentroid_mm(const std::string& lens, double centre_nm, int spp) {
  const double th = kFieldDeg * kPi / 180;
  const std::string scene = fmt::format(
      R"(LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "{}" "float aperturediameter" 5 "float focusdistance" 1000
Film "rgb" "integer xresolution" {} "integer yresolution" {} "float diagonal" {}
Sampler "independent" "integer pixelsamples" {}
Integrator "path" "integer maxdepth" 1
WorldBegin
AttributeBegin
  Translate {} 0 {}
  AreaLightSource "diffuse" "spectrum L" [{} 0 {} 1 {} 1 {} 0]
  Shape "sphere" "float radius" 0.3
AttributeEnd
)",
      lens, kRes, kRes, kDiagonal, spp, kDistance * std::sin(th), kDistance * std::cos(th),
      centre_nm - 6, centre_nm - 3, centre_nm + 3, centre_nm + 6);
  render::RenderOptions o;
  o.seed = 7;
  // The image lies near raster x = 700 + 489 (8.65 mm right of the centre: a light on the
  // camera's right appears on the image's right): a window of 120 x 60 pixels around it holds
  // the blur of every band.
  o.pixelbounds = std::array<int, 4>{1129, 1249, 670, 730};
  const render::RenderResult r = testutil::renderText(scene, o);
  double sw = 0, sx = 0;
  for (int y = 0; y < r.image.height; ++y)
    for (int x = 0; x < r.image.width; ++x) {
      const double w = testutil::luminanceAt(r.image, x, y);
      sw += w;
      sx += w * (r.bounds.x0 + x + 0.5);
    }
  EXPECT_GT(sw, 0) << "no light in the window";
  // Image height: distance from the film centre.
  return (sx / sw - kRes / 2.0) * kPitch;
}

}  // namespace

TEST(DispersionRender, LateralColourMatchesTheWorkbench) {
  const std::string disp = writeLens(true), plain = writeLens(false);
  // The workbench: the real chief ray's image height at F and C on the film focused at d.
  optics::LensSetup setup;
  setup.aperture_diameter_mm = 5;
  setup.focus_distance_m = 1000;
  const optics::FocusedLens fl = optics::focusLens(optics::readLensFile(disp), setup);
  const double hF = optics::chiefRayHeightAt(fl, kFieldDeg, 486),
               hC = optics::chiefRayHeightAt(fl, kFieldDeg, 656);
  const double predicted = hF - hC;  // about -0.22 mm: 12 pixels
  ASSERT_LT(predicted, -10 * kPitch);

  const double rF = imageCentroid_mm(disp, 486, 48), rC = imageCentroid_mm(disp, 656, 48);
  const double rendered = rF - rC;
  std::printf(
      "lateral colour F-C at %.0f deg: rendered %.4f mm, chief rays %.4f mm, pitch %.4f mm\n",
      kFieldDeg, rendered, predicted, kPitch);
  EXPECT_NEAR(rendered, predicted, kPitch);
  // And where: the image height itself agrees with the chief ray to a few pixels (the blur of a
  // defocused band is not exactly centred on its chief ray).
  EXPECT_NEAR(rF, hF, 3 * kPitch);

  // The same lens without dispersion: no lateral colour.
  const double pF = imageCentroid_mm(plain, 486, 192), pC = imageCentroid_mm(plain, 656, 192);
  std::printf("non-dispersive lens: F-C %.4f mm\n", pF - pC);
  EXPECT_NEAR(pF - pC, 0, 0.5 * kPitch);
}

// Neither the spectral MIS of the dispersive camera nor terminating the secondary wavelengths may
// bias the image. A uniform wall of narrow-band
// light (around 450 nm, then 620 nm) through the dispersive lens and through the same lens
// without dispersion: at the film centre the irradiance is pi L sin^2(theta'), theta' the real
// marginal ray's angle at that wavelength, so the ratio of the two renders must be the ratio of
// sin^2(theta') at the band and at the d line (the dispersive lens is faster in the blue: its
// focal length is shorter there, by 4% at 450 nm). The glass's absorption is off here
// (glass_transmittance_test checks it).
TEST(DispersionRender, HeroWavelengthTerminationIsUnbiased) {
  auto render = [](const std::string& lens, double centre_nm, bool hero_only = false) {
    const std::string scene = fmt::format(
        R"(LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "{}" "float aperturediameter" 5 "float focusdistance" 1000
  "bool glassabsorption" false
Film "rgb" "integer xresolution" 32 "integer yresolution" 32 "float diagonal" 0.5
Sampler "independent" "integer pixelsamples" 512
Integrator "path" "integer maxdepth" 1
WorldBegin
AttributeBegin
  ReverseOrientation
  AreaLightSource "diffuse" "spectrum L" [{} 0 {} 1 {} 1 {} 0]
  Translate 0 0 50
  Shape "bilinearmesh" "point3 P" [-100 -100 0  100 -100 0  -100 100 0  100 100 0]
AttributeEnd
)",
        lens, centre_nm - 12, centre_nm - 10, centre_nm + 10, centre_nm + 12);
    render::RenderOptions o;
    o.seed = std::getenv("LENSIM_SEED") ? std::atoi(std::getenv("LENSIM_SEED")) : 3;
    o.dispersion_hero_only = hero_only;
    const render::RenderResult r = testutil::renderText(scene, o);
    double y = 0;
    for (int j = 0; j < r.image.height; ++j)
      for (int i = 0; i < r.image.width; ++i) y += testutil::luminanceAt(r.image, i, j);
    return y;
  };
  const std::string disp = writeLens(true), plain = writeLens(false);
  optics::LensSetup setup;
  setup.aperture_diameter_mm = 5;
  setup.focus_distance_m = 1000;
  const optics::FocusedLens fl = optics::focusLens(optics::readLensFile(disp), setup);
  const double s_d = test::realMarginalSin(*fl.lens);
  for (double band : {450.0, 620.0}) {
    SCOPED_TRACE(band);
    // Averaged over the band as the film sees it: the band's trapezoid times CIE y-bar.
    double num = 0, den = 0;
    for (double l = band - 12; l <= band + 12; l += 0.5) {
      const double w = std::clamp((12 - std::abs(l - band)) / 2, 0.0, 1.0) * render::cieXyzBar(l).y;
      const double s = test::realMarginalSin(fl.lens->atWavelength(l));
      num += w * s * s;
      den += w;
    }
    const double expected = num / den / (s_d * s_d);
    const double y_plain = render(plain, band);
    const double ratio = render(disp, band) / y_plain;
    std::printf("%.0f nm: dispersive / non-dispersive %.4f, expected %.4f\n", band, ratio,
                expected);
    EXPECT_NEAR(ratio, expected, 0.02);  // the noise: 0.004 (standard deviation over seeds)
    if (band == 450.0) {
      // The hero-wavelength-only scheme (pbrt-v4's), noisier: the same expectation.
      const double hero = render(disp, band, true) / y_plain;
      std::printf("%.0f nm, hero wavelength only: %.4f\n", band, hero);
      EXPECT_NEAR(hero, expected, 0.03);
    }
  }
}

// A 60-degree prism of SF11 (pbrt-v4's "glass-F11"): the minimum deviation found by tracing rays
// through both faces with the renderer's refraction, against D = 2 asin(n sin(A/2)) - A, at the
// F, d and C lines; and the index against Schott's SF11 data sheet.
TEST(DispersionRender, PrismMinimumDeviationAtThreeWavelengths) {
  const render::SpectrumPtr eta = render::fallbackNamedSpectrum("glass-F11");
  EXPECT_NEAR(eta->eval(optics::kLineF_nm), 1.80645, 2e-5);
  EXPECT_NEAR(eta->eval(optics::kLineD_nm), 1.78472, 2e-5);
  EXPECT_NEAR(eta->eval(optics::kLineC_nm), 1.77599, 2e-5);
  const double A = 60 * kPi / 180;
  // Faces: normals (outward) at -A/2 and +A/2 from the -x/+x directions in the x-y plane.
  const Vec3 n1{-std::cos(A / 2), std::sin(A / 2), 0}, n2{std::cos(A / 2), std::sin(A / 2), 0};
  std::vector<double> deviations;
  for (double l : {optics::kLineF_nm, optics::kLineD_nm, optics::kLineC_nm}) {
    const double n = eta->eval(l);
    auto deviation = [&](double incidence) -> double {
      // Incoming direction making `incidence` with -n1.
      const double a = std::atan2(-n1.y, -n1.x) + incidence;
      const Vec3 d{std::cos(a), std::sin(a), 0};
      // render::refract takes wi pointing away from the surface, n on the side of wi.
      const auto in = render::refract(-d, n1, n);
      if (!in) return std::nan("");
      const Vec3 d2 = in->wt;
      const auto out = render::refract(-d2, n2, n);  // -d2 lies inside: refract flips to 1/n
      if (!out) return std::nan("");
      const Vec3 d3 = out->wt;
      return std::acos(std::clamp(dot(d, d3), -1.0, 1.0));
    };
    double best = 1e9;
    for (double i = 20; i < 89; i += 0.001) {
      const double D = deviation(i * kPi / 180);
      if (std::isfinite(D)) best = std::min(best, D);
    }
    const double closed = 2 * std::asin(n * std::sin(A / 2)) - A;
    EXPECT_NEAR(best, closed, 1e-6) << l;
    deviations.push_back(best);
  }
  // Blue deviates most.
  EXPECT_GT(deviations[0], deviations[1]);
  EXPECT_GT(deviations[1], deviations[2]);
}

// The prism scene of the README (scenes/chromatic/prism.pbrt): a white slit seen through a
// glass-F11 prism spreads into a spectrum, blue deviated most (to the left in the image), red
// least; the band's width against the prism's dispersion between 450 and 650 nm.
TEST(DispersionRender, PrismSceneShowsASpectrum) {
  const std::string path = std::string(LENSIM_SOURCE_DIR) + "/scenes/chromatic/prism.pbrt";
  scene::Scene s = scene::loadScene(path);
  render::RenderOptions o;
  o.spp = 8;
  o.seed = 1;
  const render::RenderResult r = render::render(s, o);
  const io::Image& im = r.image;
  // Centroids of red and blue over the left 80% (the slit itself shows, white, at the right).
  double sr = 0, xr = 0, sb = 0, xb = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width * 8 / 10; ++x) {
      const double R = std::max(0.0f, im.at(x, y, 0)), B = std::max(0.0f, im.at(x, y, 2));
      sr += R, xr += R * x, sb += B, xb += B * x;
    }
  ASSERT_GT(sr, 0);
  ASSERT_GT(sb, 0);
  const double red_x = xr / sr, blue_x = xb / sb;
  std::printf("prism: red centroid x %.1f, blue %.1f (pixels)\n", red_x, blue_x);
  EXPECT_GT(red_x, blue_x + 3);  // a spectrum, red to the right of blue
}
