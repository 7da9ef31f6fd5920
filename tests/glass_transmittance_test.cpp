// Internal transmittance of the glasses in use (issue 28, docs/glass.md): the lens's axial
// transmittance and a traced path's against the catalogue's IT rows read and interpolated here,
// independently of lensim's AGF reader; the realistic camera's per-wavelength weights; `lens info`.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/camera/realistic.h"
#include "lensim/optics/absorption.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/sampling/filter.h"
#include "render_test_util.h"
#include "test_paths.h"

using namespace lensim;
using camera::CameraSample;
using camera::kCameraWavelengths;

namespace {

// The IT rows (lambda um, tau, thickness mm) of one glass of a Zemax AGF file, read line by line.
struct Row {
  double lambda_um, tau, thickness_mm;
};
std::vector<Row> itRows(const std::string& agf, const std::string& glass) {
  std::ifstream in(agf);
  std::string line;
  std::vector<Row> rows;
  bool inside = false;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "NM") {
      std::string name;
      s >> name;
      inside = name == glass;
    } else if (inside && tag == "IT") {
      Row r{};
      if (s >> r.lambda_um >> r.tau >> r.thickness_mm && r.tau > 0 && r.tau <= 1 &&
          r.thickness_mm > 0)
        rows.push_back(r);
    }
  }
  return rows;
}

// The absorption coefficient (1/mm) at lambda: -ln(tau)/d of the rows, linear in lambda between
// rows and held beyond the end rows (the convention docs/glass.md states).
double alpha(const std::vector<Row>& rows, double lambda_nm) {
  const double l = lambda_nm / 1000;
  auto a = [](const Row& r) { return -std::log(r.tau) / r.thickness_mm; };
  if (l <= rows.front().lambda_um) return a(rows.front());
  if (l >= rows.back().lambda_um) return a(rows.back());
  for (size_t i = 1; i < rows.size(); ++i)
    if (rows[i].lambda_um >= l) {
      const double t = (l - rows[i - 1].lambda_um) / (rows[i].lambda_um - rows[i - 1].lambda_um);
      return (1 - t) * a(rows[i - 1]) + t * a(rows[i]);
    }
  return a(rows.back());
}

const std::string kSchott = std::string(LENSIM_SOURCE_DIR) + "/data/glass/agf/schott.agf";

// Stop, a singlet of constant index (no transmittance data), then a 10 mm N-SF66 plate cemented
// to a 2 mm N-BK7 plate (radii 1e6 mm: flat to 5e-5 mm over the beam) in front of the film.
constexpr double kSf66_mm = 10, kBk7_mm = 2;
std::string writeLens() {
  const std::string path = std::string(::testing::TempDir()) + "absorbing.dat";
  std::ofstream(path) << "0 5 0 4\n"
                         "30 4 1.5 20\n"
                         "-30 2 0 20\n"
                         "1e6 10 1.92286 20 - schott:N-SF66\n"
                         "-1e6 2 1.5168 20 - schott:N-BK7\n"
                         "-1e6 0 0 20\n";
  return path;
}

optics::FocusedLens focused() {
  optics::LensSetup setup;
  setup.aperture_diameter_mm = 4;
  setup.focus_distance_m = 10;
  return optics::focusLens(optics::readLensFile(writeLens()), setup);
}

double expectedAxial(double lambda_nm) {
  static const std::vector<Row> sf66 = itRows(kSchott, "N-SF66"), bk7 = itRows(kSchott, "N-BK7");
  return std::exp(-alpha(sf66, lambda_nm) * kSf66_mm - alpha(bk7, lambda_nm) * kBk7_mm);
}

}  // namespace

TEST(GlassTransmittance, AxialAgainstTheCataloguesRows) {
  ASSERT_GT(itRows(kSchott, "N-SF66").size(), 10u);
  const optics::FocusedLens fl = focused();
  const optics::LensAbsorption a(*fl.lens);
  ASSERT_TRUE(a.any());
  ASSERT_EQ(a.mediaWithoutData(), std::vector<int>{1});  // the constant-index singlet
  for (double l : {400.0, 436.0, 450.0, 550.0, 700.0, 1200.0}) {
    SCOPED_TRACE(l);
    EXPECT_NEAR(a.axial(l), expectedAxial(l), 1e-12);
  }
  // The flint absorbs the blue: about 0.50 at 400 nm, 0.99 at 700 nm for these 10 + 2 mm.
  EXPECT_LT(a.axial(400), 0.6);
  EXPECT_GT(a.axial(700), 0.98);
  EXPECT_LT(a.axial(400), a.axial(550));
  EXPECT_LT(a.axial(550), a.axial(700));
}

TEST(GlassTransmittance, PathTransmittanceIsTheSameBothWays) {
  const optics::FocusedLens fl = focused();
  const optics::LensSystem& lens = *fl.lens;
  const optics::LensAbsorption a(lens);
  static const std::vector<Row> sf66 = itRows(kSchott, "N-SF66"), bk7 = itRows(kSchott, "N-BK7");
  // An oblique ray from the film; its path's segments in the two plates by the test's own
  // reading of which segment lies in which glass (surfaces 3-4: N-SF66, 4-5: N-BK7).
  std::vector<Vec3> path;
  const optics::TraceResult r = lens.traceFromFilmPoint({1.0, -0.5}, {0.8, 0.6}, {}, &path);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(path.size(), 7u);  // the film point, then surfaces 5 .. 0
  const double l_sf66 = length(path[2] - path[3]), l_bk7 = length(path[1] - path[2]);
  EXPECT_GT(l_sf66, kSf66_mm);
  for (double l : {420.0, 600.0}) {
    const double expected = std::exp(-alpha(sf66, l) * l_sf66 - alpha(bk7, l) * l_bk7);
    EXPECT_NEAR(a.alongPath(path, true, l), expected, 1e-12);
    // The same ray from the scene.
    std::vector<Vec3> back;
    const optics::Ray in{r.ray.origin + r.ray.direction * 10.0, -r.ray.direction};
    ASSERT_TRUE(lens.tracer().traceFromScene(in, {}, &back).ok());
    EXPECT_NEAR(a.alongPath(back, false, l), expected, 1e-9);
  }
}

namespace {

camera::RealisticSettings cameraSettings(bool absorb) {
  camera::RealisticSettings s;
  s.lens_path = writeLens();
  s.setup.aperture_diameter_mm = 4;
  s.setup.focus_distance_m = 10;
  s.film_diagonal_mm = 10;
  s.x_resolution = s.y_resolution = 64;
  s.glass_absorption = absorb;
  return s;
}

}  // namespace

// The camera's weight per wavelength: with absorption over without, for rays near the film
// centre, is the axial transmittance within the path length's spread: the beam's NA is about
// 0.07 (4 mm stop, f about 30 mm), so in the plates (n > 1.5) a path is at most
// 1 / cos(asin(0.07 / 1.5)) = 1.0011 times the axial one: T_axial^1.002 <= ratio <= T_axial.
TEST(GlassTransmittance, CameraWeighsEachWavelength) {
  const camera::RealisticCamera on(cameraSettings(true)), off(cameraSettings(false));
  const sampling::BoxFilter box;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  int hero = 0, each = 0;
  for (int k = 0; k < 400; ++k) {
    CameraSample s;
    s.film_raster = {32 + 0.4 * (u(rng) - 0.5), 32 + 0.4 * (u(rng) - 0.5)};
    s.lens = {u(rng), u(rng)};
    s.lambda_nm = {400 + 300 * u(rng), 400 + 300 * u(rng), 400 + 300 * u(rng), 400 + 300 * u(rng)};
    // Hero wavelength only (no filter): the hero's weight.
    const auto a = on.generateRay(s), b = off.generateRay(s);
    ASSERT_EQ(a.has_value(), b.has_value());
    if (a) {
      const double t = expectedAxial(s.lambda_nm[0]);
      EXPECT_LE(a->weight / b->weight, t * (1 + 1e-6));
      EXPECT_GE(a->weight / b->weight, std::pow(t, 1.002));
      ++hero;
    }
    // With the pixel filter: every wavelength its own transmittance.
    s.pixel_centre = {32, 32};
    s.filter = &box;
    const auto c = on.generateRay(s), d = off.generateRay(s);
    ASSERT_EQ(c.has_value(), d.has_value());
    if (!c) continue;
    ASSERT_TRUE(c->per_wavelength);
    for (int j = 0; j < kCameraWavelengths; ++j) {
      if (!(d->wavelength_weight[size_t(j)] > 0)) continue;
      const double t = expectedAxial(s.lambda_nm[size_t(j)]);
      const double ratio = c->wavelength_weight[size_t(j)] / d->wavelength_weight[size_t(j)];
      EXPECT_LE(ratio, t * (1 + 1e-6)) << j;
      EXPECT_GE(ratio, std::pow(t, 1.002)) << j;
      ++each;
    }
  }
  EXPECT_GT(hero, 300);
  EXPECT_GT(each, 1000);
}

TEST(GlassTransmittance, LensInfoReportsIt) {
  const std::string lens = writeLens();
  const auto r = test::runLensim("lens info " + lens + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const size_t b = r.out.find("{\n");
  ASSERT_NE(b, std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out.substr(b, r.out.rfind('}') - b + 1));
  const nlohmann::json& t = j["internal_transmittance"];
  ASSERT_TRUE(t["has_data"].get<bool>());
  ASSERT_EQ(t["wavelengths_nm"].size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const double l = t["wavelengths_nm"][i].get<double>();
    EXPECT_NEAR(t["on_axis"][i].get<double>(), expectedAxial(l), 1e-12) << l;
  }
  EXPECT_EQ(t["elements_without_data"], nlohmann::json::array({"1-2"}));
  const auto text = test::runLensim("lens info " + lens);
  ASSERT_EQ(text.status, 0);
  EXPECT_NE(text.out.find(fmt::format("on axis {:.4f} at 400 nm", expectedAxial(400))),
            std::string::npos)
      << text.out;
  EXPECT_NE(text.out.find("element 1-2 without data taken as 1"), std::string::npos);
  // A lens of constant indices: no data, stated.
  const auto plain = test::runLensim("lens info " + test::lensPath("dgauss.50mm.dat"));
  EXPECT_NE(plain.out.find("no glass has internal transmittance data; taken as 1"),
            std::string::npos)
      << plain.out;
}

// Renders: a uniform wall of narrow-band light (around 450 nm, then 650 nm) through the N-SF66
// landscape lens (5 mm on the axis), with and without "glassabsorption", path-traced
// (generateRay's per-wavelength weights) and light-traced (the camera's importance). The same
// seed makes both renders take the same samples, so their ratio is the transmittance the rays
// saw: the band's axial transmittance (weighted as the film sees it, by the band's trapezoid
// times CIE y-bar) within the element's thickness spread over the 5 mm beam (the meniscus is
// 2% thinner at its edge: 0.002 at 450 nm). The wall (2 m wide at 50 m) fills the 0.5-degree
// view and is small enough that the light tracer's paths reach the film.
TEST(GlassTransmittance, RendersShowTheWarmCast) {
  static const std::vector<Row> sf66 = itRows(kSchott, "N-SF66");
  const std::string lens = test::lensPath("landscape.sf66.dat");
  auto render = [&](double centre_nm, bool absorb, const char* integrator) {
    const std::string scene = fmt::format(
        R"(LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "{}" "float aperturediameter" 5 "float focusdistance" 1000
  "bool glassabsorption" {}
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "float diagonal" 0.5
Sampler "independent" "integer pixelsamples" 64
Integrator "{}" "integer maxdepth" 1
WorldBegin
AttributeBegin
  ReverseOrientation
  AreaLightSource "diffuse" "spectrum L" [{} 0 {} 1 {} 1 {} 0]
  Translate 0 0 50
  Shape "bilinearmesh" "point3 P" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]
AttributeEnd
)",
        lens, absorb ? "true" : "false", integrator, centre_nm - 12, centre_nm - 10, centre_nm + 10,
        centre_nm + 12);
    render::RenderOptions o;
    o.seed = 3;
    const render::RenderResult r = testutil::renderText(scene, o);
    double y = 0;
    for (int j = 0; j < r.image.height; ++j)
      for (int i = 0; i < r.image.width; ++i) y += testutil::luminanceAt(r.image, i, j);
    return y;
  };
  for (double band : {450.0, 650.0}) {
    double num = 0, den = 0;
    for (double l = band - 12; l <= band + 12; l += 0.5) {
      const double w = std::clamp((12 - std::abs(l - band)) / 2, 0.0, 1.0) * render::cieXyzBar(l).y;
      num += w * std::exp(-alpha(sf66, l) * 5);
      den += w;
    }
    const double expected = num / den;
    for (const char* integrator : {"path", "lighttracer"}) {
      SCOPED_TRACE(fmt::format("{} nm, {}", band, integrator));
      const double ratio = render(band, true, integrator) / render(band, false, integrator);
      std::printf("%.0f nm, %s: with / without absorption %.4f, axial %.4f\n", band, integrator,
                  ratio, expected);
      EXPECT_NEAR(ratio, expected, 0.004);
    }
  }
}
