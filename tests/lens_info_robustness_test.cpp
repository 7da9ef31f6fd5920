// `lens info` on lenses it can read but not focus (issue 28, "Robustness"): an afocal lens, a lens
// no real ray passes, a film that would sit inside the lens are shown with warnings and the data
// that exist (exit 0); `render` refuses such a camera at the scene's Camera line, naming the lens
// file; a scene parameter's bad value is refused at its parameter; a Latin-1 lens file's JSON.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_run.h"
#include "test_paths.h"

using lensim::test::lensPath;
using lensim::test::runLensim;
using nlohmann::json;

namespace {

json jsonOf(const lensim::test::CliResult& r) {
  // The JSON object is the last thing printed (warnings go first, on stderr).
  const size_t b = r.out.find("{\n");
  EXPECT_NE(b, std::string::npos) << r.out;
  if (b == std::string::npos) return json::object();
  const size_t e = r.out.rfind("}");
  return json::parse(r.out.substr(b, e - b + 1));
}

std::string tempFile(const std::string& name, const std::string& text) {
  const std::string path = std::string(::testing::TempDir()) + name;
  std::ofstream(path) << text;
  return path;
}

bool has(const std::string& out, const std::string& what) {
  return out.find(what) != std::string::npos;
}

// A Keplerian telescope of two plano-convex singlets (n = 1.5, 2 mm thick, curved sides out):
// f1 = 25 / 0.5 = 50 mm, f2 = 12.5 / 0.5 = 25 mm; the gap puts the first's rear focal point on
// the second's front focal point: (f1 - t/n) + (f2 - t/n) = 72.3333 mm. Afocal, with angular
// magnification -f1/f2 = -2 (thin-lens algebra on the principal planes, which sit on the curved
// vertices: exact for plano-convex lenses).
const std::string kKeplerian = R"({"format": "lensim-lens", "name": "Keplerian telescope",
 "surfaces": [
  {"radius_mm": 25, "thickness_mm": 2, "ior": 1.5, "semi_aperture_mm": 10},
  {"radius_mm": 0, "thickness_mm": 72.33333333333333, "ior": 1, "semi_aperture_mm": 10},
  {"radius_mm": 0, "thickness_mm": 2, "ior": 1.5, "semi_aperture_mm": 6},
  {"radius_mm": -12.5, "thickness_mm": 5, "ior": 1, "semi_aperture_mm": 6},
  {"radius_mm": 0, "thickness_mm": 20, "ior": 1, "semi_aperture_mm": 5, "stop": true}
 ]})";

// A negative singlet (R1 = -50, R2 = +50 mm, 3 mm of n = 1.5) with no film distance in the file:
// its rear focal point lies 50.5 mm in front of the rear vertex, so the infinity focus would
// put the film inside the lens. Thick-lens EFL: 1/f = (n-1) (1/R1 - 1/R2 + (n-1) t / (n R1 R2)).
const std::string kNegative = R"({"format": "lensim-lens", "name": "negative singlet",
 "surfaces": [
  {"radius_mm": 0, "thickness_mm": 1, "ior": 1, "semi_aperture_mm": 8, "stop": true},
  {"radius_mm": -50, "thickness_mm": 3, "ior": 1.5, "semi_aperture_mm": 10},
  {"radius_mm": 50, "thickness_mm": 0, "ior": 1, "semi_aperture_mm": 10}
 ]})";

std::string scene(const std::string& name, const std::string& lens, const std::string& aperture) {
  return tempFile(name, "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"realistic\" \"string lensfile\" \"" +
                            lens + "\" \"float aperturediameter\" " + aperture +
                            "\nFilm \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                            "Sampler \"independent\" \"integer pixelsamples\" 1\nWorldBegin\n"
                            "LightSource \"infinite\" \"rgb L\" [1 1 1]\n");
}

}  // namespace

TEST(LensInfoRobustness, AfocalLensIsShownWithItsAngularMagnification) {
  const std::string lens = tempFile("keplerian.json", kKeplerian);
  const auto t = runLensim("lens info " + lens);
  EXPECT_EQ(t.status, 0) << t.out;
  EXPECT_TRUE(has(t.out, "warning: the lens is afocal")) << t.out;
  EXPECT_TRUE(has(t.out, "angular magnification -2.000000")) << t.out;
  EXPECT_TRUE(has(t.out, "glass")) << t.out;  // the element table is still there
  const auto r = runLensim("lens info --json " + lens);
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = jsonOf(r);
  EXPECT_FALSE(j.value("focused", true));
  EXPECT_TRUE(j.value("afocal", false));
  EXPECT_NEAR(j.value("angular_magnification", 0.0), -2.0, 1e-9);
  EXPECT_EQ(j["surfaces"].size(), 5u);
  EXPECT_EQ(j["elements"].size(), 2u);
}

TEST(LensInfoRobustness, LensNoRealRayPassesShowsItsParaxialDataAndTheBlockingSurface) {
  const std::string dg = lensPath("dgauss.50mm.dat");
  const json normal = jsonOf(runLensim("lens info --json " + dg));
  const auto r = runLensim("lens info --json " + dg + " --aperture-diameter 1e-320");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r.out, "warning: no real ray parallel to the axis gets through")) << r.out;
  const json j = jsonOf(r);
  EXPECT_FALSE(j.value("focused", true));
  // First-order data do not depend on the stop's size; the stop is the file's row 6 (surface 5).
  EXPECT_NEAR(j.value("effective_focal_length_mm", 0.0),
              normal.value("effective_focal_length_mm", 1.0), 1e-9);
  EXPECT_EQ(j.value("axial_ray_blocked_at_surface", -1), 5);
  EXPECT_EQ(j.value("axial_ray_blocked_reason", std::string()), "aperture");
}

TEST(LensInfoRobustness, FilmInsideTheLensIsShownButAGivenFocusIsRefused) {
  const std::string lens = tempFile("negative.json", kNegative);
  const auto r = runLensim("lens info --json " + lens);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r.out, "inside the lens")) << r.out;
  const json j = jsonOf(r);
  EXPECT_FALSE(j.value("focused", true));
  const double n = 1.5, r1 = -50, r2 = 50, t = 3;
  const double f = 1 / ((n - 1) * (1 / r1 - 1 / r2 + (n - 1) * t / (n * r1 * r2)));
  EXPECT_NEAR(j.value("effective_focal_length_mm", 0.0), f, 1e-9);
  // A focus distance the user asks for and the lens cannot reach is the option's error.
  const auto e = runLensim("lens info " + lens + " --focus-distance 2");
  EXPECT_EQ(e.status, 1) << e.out;
  EXPECT_TRUE(has(e.out, "error: focusing at 2 m puts the film")) << e.out;
}

TEST(LensInfoRobustness, RenderRefusesTheseLensesAtTheCameraLine) {
  const std::string out = std::string(::testing::TempDir()) + "robust.exr";
  const std::string kep = tempFile("keplerian.json", kKeplerian);
  const std::string s1 = scene("afocal.pbrt", kep, "5");
  const auto a = runLensim("render " + s1 + " -o " + out);
  EXPECT_EQ(a.status, 1) << a.out;
  EXPECT_TRUE(has(a.out, s1 + ":2:1: error: realistic camera: the lens is afocal")) << a.out;
  EXPECT_TRUE(has(a.out, "(lens file " + kep)) << a.out;

  const std::string neg = tempFile("negative.json", kNegative);
  const std::string s2 = scene("inside.pbrt", neg, "5");
  const auto b = runLensim("render " + s2 + " -o " + out);
  EXPECT_EQ(b.status, 1) << b.out;
  EXPECT_TRUE(has(b.out, s2 + ":2:1: error: realistic camera: ")) << b.out;
  EXPECT_TRUE(has(b.out, "inside the lens (lens file " + neg)) << b.out;

  // The scene's aperture lets no ray through: the Camera line, with the lens file and value.
  const std::string s3 = scene("tiny.pbrt", lensPath("dgauss.50mm.dat"), "1e-320");
  const auto c = runLensim("render " + s3 + " -o " + out);
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_TRUE(has(c.out, s3 + ":2:1: error: realistic camera: no real ray")) << c.out;
  EXPECT_TRUE(has(c.out, "aperturediameter 1e-320 mm")) << c.out;

  // A value no lens can take: refused at the parameter itself.
  const std::string s4 = scene("negative-aperture.pbrt", lensPath("dgauss.50mm.dat"), "-2");
  const auto d = runLensim("render " + s4 + " -o " + out);
  EXPECT_EQ(d.status, 1) << d.out;
  EXPECT_TRUE(has(d.out, s4 + ":2:")) << d.out;
  EXPECT_TRUE(has(d.out, "-2 mm: expected a finite aperture diameter > 0")) << d.out;
  EXPECT_FALSE(has(d.out, "lens file")) << d.out;
}

// The Thorlabs file of ../shared/lenses/zmx/optiland/ is ISO-8859-1 ("Ø18 mm" in its name):
// the JSON carries the name in UTF-8 and parses.
TEST(LensInfoRobustness, Latin1LensFileGivesUtf8Json) {
  const std::string path =
      std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/optiland/lens_thorlabs_iso_8859_1.zmx";
  const auto r = runLensim("lens info --json " + path);
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = jsonOf(r);
  const std::string name = j["lens"].value("name", std::string());
  EXPECT_TRUE(has(name,
                  "\xC3\x98"
                  "18 mm"))
      << name;  // U+00D8 in UTF-8
  EXPECT_GT(j.value("effective_focal_length_mm", 0.0), 14.9);
}

// `lens info --configs` lists a configuration that cannot be focused with its reason and goes on
// with the others: the Keplerian telescope's gap of 72.333 mm (afocal) and 60 mm (focusable).
// The focusable one's EFL is checked by a y-nu trace written here.
TEST(LensInfoRobustness, ConfigsTableListsAnUnfocusableConfiguration) {
  std::string text = kKeplerian;
  const std::string end = "\n ]}";
  text.replace(text.rfind(end), end.size(),
               "\n ],\n \"configurations\": [{\"thickness_mm\": {\"1\": 72.33333333333333}},"
               " {\"thickness_mm\": {\"1\": 60}}]}");
  const std::string lens = tempFile("keplerian-zoom.json", text);
  const auto r = runLensim("lens info --configs --json " + lens);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r.out, "warning: configuration 1: the lens is afocal")) << r.out;
  const json j = jsonOf(r);
  ASSERT_EQ(j["configurations"].size(), 2u) << r.out;
  EXPECT_FALSE(j["configurations"][0].value("focused", true));
  EXPECT_TRUE(has(j["configurations"][0].value("not_focused_reason", std::string()), "afocal"));
  EXPECT_TRUE(j["configurations"][1].value("focused", false));
  // y-nu trace of a parallel ray (y = 1): rows (radius, thickness after, index after).
  const double rows[4][3] = {{25, 2, 1.5}, {0, 60, 1}, {0, 2, 1.5}, {-12.5, 0, 1}};
  double y = 1, nu = 0, n = 1;
  for (const auto& row : rows) {
    if (row[0] != 0) nu -= y * (row[2] - n) / row[0];
    n = row[2];
    y += row[1] * nu / n;
  }
  EXPECT_NEAR(j["configurations"][1].value("effective_focal_length_mm", 0.0), -1 / nu, 1e-9);
  const auto t = runLensim("lens info --configs " + lens);
  EXPECT_EQ(t.status, 0) << t.out;
  EXPECT_TRUE(has(t.out, "not focused: the lens is afocal")) << t.out;
}
