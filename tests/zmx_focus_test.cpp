// Zemax focus positions read as a focus group (docs/zoom.md): the Tessar test lens whose middle
// element focuses, its group position for a focus distance against a paraxial y-nu trace and a
// bisection written here, and the ambiguous files refused at their line.
#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli_run.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/util/error.h"
#include "test_paths.h"

namespace lensim {
namespace {

// The Tessar of tests/data/lenses/tessar_inner_focus.zmx (ISETCam's tessar.22deg.50.0mm.dat):
// radius, thickness, index after; the gaps after rows 1 and 3 are the moving ones.
struct Row {
  double r, t, n;
};
constexpr std::array<Row, 8> kTessar = {{{16.2, 3.0, 1.62},
                                         {-289.9, 3.3, 1},
                                         {-29.25, 1.45, 1.578},
                                         {13.8, 2.0, 1},
                                         {0, 1.3, 1},
                                         {-289.9, 1.1, 1.532},
                                         {13.1, 4.4, 1.62},
                                         {-21.2, 0, 1}}};

// (y, u) traced from the front vertex through the lens with the middle element moved x mm
// toward the film; returns {y, u, z of the rear vertex}.
std::array<double, 3> trace(double x, double y, double u) {
  double n = 1, z = 0;
  for (size_t i = 0; i < kTessar.size(); ++i) {
    const double c = kTessar[i].r == 0 ? 0 : 1 / kTessar[i].r;
    const double nu = n * u - y * (kTessar[i].n - n) * c;
    n = kTessar[i].n;
    u = nu / n;
    if (i + 1 == kTessar.size()) break;
    const double t = kTessar[i].t + (i == 1 ? x : i == 3 ? -x : 0);
    y += t * u;
    z += t;
  }
  return {y, u, z};
}

// The film's distance from the front vertex: the infinity focus with the element at rest.
double track() {
  const auto r = trace(0, 1, 0);
  return r[2] - r[0] / r[1];
}

// Where the axial image of an object d_m from the film lies behind the film, element at x.
double imageBehindFilm(double x, double d_m) {
  const double s = track() - d_m * 1000, u0 = 1e-3;
  const auto r = trace(x, -s * u0, u0);
  return r[2] - r[0] / r[1] - track();
}

// The element position that images the object on the film: bisection over [0, 1.99] mm.
double solvedPosition(double d_m) {
  double lo = 0, hi = 1.99;
  const bool lo_sign = imageBehindFilm(lo, d_m) > 0;
  EXPECT_NE(lo_sign, imageBehindFilm(hi, d_m) > 0) << d_m;
  for (int it = 0; it < 200; ++it) {
    const double m = 0.5 * (lo + hi);
    ((imageBehindFilm(m, d_m) > 0) == lo_sign ? lo : hi) = m;
  }
  return 0.5 * (lo + hi);
}

std::string lensPath() {
  return test::dataPath("lenses/tessar_inner_focus.zmx");
}

std::string readText(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(ZmxFocus, ConfigurationsBecomeOneFocusGroup) {
  const optics::LensPrescription p = optics::parseZmx(readText(lensPath()), "tessar.zmx");
  EXPECT_TRUE(p.configurations.empty());
  const std::vector<std::pair<int, double>> group = {{1, 1.0}, {3, -1.0}};
  EXPECT_EQ(p.focus_group, group);
  // The lens at rest is the infinity configuration.
  EXPECT_EQ(p.surfaces[1].thickness_mm, 3.3);
  EXPECT_EQ(p.surfaces[3].thickness_mm, 2.0);
  EXPECT_FALSE(p.object_distance_mm);
  bool noted = false;
  for (const Diagnostic& d : p.diagnostics)
    noted = noted || d.message.find("focus positions of one focus group") != std::string::npos;
  EXPECT_TRUE(noted);
  // The JSON writer keeps the group.
  EXPECT_EQ(optics::parseLensJson(optics::writeLensJson(p), "t.json").focus_group, group);
}

TEST(ZmxFocus, GroupPositionMatchesIndependentTrace) {
  const optics::LensPrescription p = optics::parseZmx(readText(lensPath()), "tessar.zmx");
  // The file's positions (object 2000, 1000, 500 mm from the front vertex; gaps to 4 decimals)
  // are where the independent trace focuses those objects.
  const double file_x[] = {0.3248, 0.6577, 1.3491};
  const double front_mm[] = {2000, 1000, 500};
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(solvedPosition((front_mm[k] + track()) / 1000), file_x[k], 6e-5) << k;
  // lensim's group position for other distances too (thick method: paraxial).
  for (double d_m : {3.0, 1.2, 0.7, 0.45}) {
    optics::LensSetup setup;
    setup.focus_distance_m = d_m;
    const optics::FocusedLens fl = optics::focusLens(p, setup);
    const auto& rows = fl.lens->prescription().surfaces;
    const double x = solvedPosition(d_m);
    EXPECT_NEAR(rows[1].thickness_mm - 3.3, x, 1e-7) << d_m;
    EXPECT_NEAR(rows[3].thickness_mm - 2.0, -x, 1e-7) << d_m;
    EXPECT_NEAR(fl.lens->filmZ_mm(), track(), 1e-6) << d_m;
    EXPECT_NEAR(fl.paraxial.effective_focal_length_mm, -1 / trace(x, 1, 0)[1], 1e-8) << d_m;
  }
  // Real rays (the exact method): the group puts the on-axis bundle's smallest RMS spot on the
  // fixed film (the spot grows when the film moves 0.02 mm either way), the element moves as one
  // and the film stays; spherical aberration makes it differ from the paraxial position.
  optics::LensSetup exact;
  exact.focus_distance_m = 1.0;
  exact.focus_method = optics::FocusMethod::Exact;
  const optics::FocusedLens fl = optics::focusLens(p, exact);
  const auto& rows = fl.lens->prescription().surfaces;
  EXPECT_NEAR(rows[1].thickness_mm + rows[3].thickness_mm, 5.3, 1e-9);
  // The film stays where real rays focus infinity with the element at rest.
  optics::LensSetup at_rest = exact;
  at_rest.focus_distance_m = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(fl.lens->filmZ_mm(), optics::focusLens(p, at_rest).lens->filmZ_mm(), 1e-9);
  EXPECT_GT(std::abs(rows[1].thickness_mm - 3.3 - solvedPosition(1.0)), 0.01);
  optics::LensSystem& lens = *fl.lens;
  const double film = lens.filmDistance_mm();
  const double best = optics::axialRmsSpot_mm(lens, fl.paraxial, 1.0);
  for (double dz : {-0.02, 0.02}) {
    lens.setFilmDistance_mm(film + dz);
    EXPECT_GT(optics::axialRmsSpot_mm(lens, fl.paraxial, 1.0), best) << dz;
  }
}

// The file with `from` replaced by `to` (once); the line `to` lands on.
std::string edited(const std::string& text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  std::string out = text;
  out.replace(at, from.size(), to);
  return out;
}
int lineOf(const std::string& text, const std::string& needle) {
  const size_t at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
}

TEST(ZmxFocus, AmbiguousFilesRefusedAtTheLine) {
  const std::string text = readText(lensPath());
  const std::string tail = " 0 0 0 1 1 1 0 0 \"\" 0\n";
  struct Case {
    std::string text, at, needle;
  };
  const std::vector<Case> cases = {
      // A curvature changes too (zoom and focus in one file).
      {text + "CURV 3 1 -0.0341880342" + tail + "CURV 3 2 -0.035" + tail, "CURV 3 2",
       "focus positions, which may change lens gaps"},
      // The image distance moves.
      {text + "THIC 8 1 40.930877" + tail + "THIC 8 2 41.5" + tail, "THIC 8 2", "moves the film"},
      // The lens's length changes (only the gap before the element moves in configuration 3).
      {edited(text, "THIC 4 3 1.3423", "THIC 4 3 2"), "THIC 2 3", "changes the lens's length"},
      // No configuration has the object at infinity.
      {edited(text, "THIC 0 1 10000000000", "THIC 0 1 5000"), "THIC 0 1", "object at infinity"},
      // Two configurations at one distance with different gaps.
      {edited(text, "THIC 0 3 1000", "THIC 0 3 2000"), "THIC 2 3", "ambiguous"},
  };
  for (const Case& c : cases) {
    try {
      optics::parseZmx(c.text, "tessar.zmx");
      ADD_FAILURE() << c.needle;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(c.needle), std::string::npos) << what;
      EXPECT_EQ(e.loc().line, lineOf(c.text, c.at)) << what;
    }
  }
  // The same lens at several object distances, no gap moving: configurations as before.
  std::string same = text;
  for (const char* row : {"THIC 2 2 3.6248", "THIC 2 3 3.9577", "THIC 2 4 4.6491",
                          "THIC 4 2 1.6752", "THIC 4 3 1.3423", "THIC 4 4 0.6509"})
    same = edited(same, row, std::string(row).substr(0, 9) + (row[5] == '2' ? "3.3" : "2"));
  const optics::LensPrescription q = optics::parseZmx(same, "tessar.zmx");
  EXPECT_EQ(q.configurations.size(), 4u);
  EXPECT_TRUE(q.focus_group.empty());
}

// Two groups moving in a fixed ratio (the element x toward the film, the rear group 0.2 x toward
// the scene), their gaps written to 4 decimals: one focus group with those rates.
TEST(ZmxFocus, GroupsInAFixedRatioAreOneFocusGroup) {
  std::string text = readText(lensPath());
  for (const auto& [from, to] :
       std::vector<std::pair<std::string, std::string>>{{"THIC 4 2 1.6752", "THIC 4 2 1.6102"},
                                                        {"THIC 4 3 1.3423", "THIC 4 3 1.2108"},
                                                        {"THIC 4 4 0.6509", "THIC 4 4 0.3811"}})
    text = edited(text, from, to);
  const std::string tail = " 0 0 0 1 1 1 0 0 \"\" 0\n";
  for (const char* row : {"THIC 5 1 1.3", "THIC 5 2 1.3650", "THIC 5 3 1.4315", "THIC 5 4 1.5698"})
    text += row + tail;
  const optics::LensPrescription p = optics::parseZmx(text, "tessar.zmx");
  ASSERT_EQ(p.focus_group.size(), 3u);
  const double want[][2] = {{1, 1 / 1.2}, {3, -1}, {4, 0.2 / 1.2}};
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(p.focus_group[i].first, want[i][0]);
    EXPECT_NEAR(p.focus_group[i].second, want[i][1], 1e-4);
  }
}

TEST(ZmxFocus, CliInfoFocusesWithTheGroup) {
  const test::CliResult r =
      test::runLensim("lens info --json --focus-distance 0.7 " + lensPath() + " 2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  EXPECT_TRUE(j["group_focusing"].get<bool>());
  const double x = solvedPosition(0.7);
  EXPECT_NEAR(j["surfaces"][1]["thickness_mm"].get<double>() - 3.3, x, 1e-6);
  // Magnification u / u' of an axial ray from the object, traced here.
  const double s = track() - 700, u0 = 1e-3;
  EXPECT_NEAR(j["magnification"].get<double>(), u0 / trace(x, -s * u0, u0)[1], 1e-7);
}

// lentil's database (the shared copy, ../shared/lenses/lentil/lenses.json) has no zoom or focus
// data: every design is a prime, none sits in the legend's zoom range 1500-1999, every thickness
// is one number, and no key beyond those lensim reads or ignores (listed here) appears.
TEST(LentilZoom, DatabaseHasNoZoomOrFocusData) {
  const auto db = nlohmann::json::parse(
      readText(std::string(LENSIM_SHARED_DIR) + "/lenses/lentil/lenses.json"));
  const std::set<std::string> design_keys = {"commercial",
                                             "company",
                                             "focal-length-mm-patent",
                                             "focal-length-mm-raytraced",
                                             "fstop",
                                             "lt-jacobian-fix-required",
                                             "max-fstop-aperture-radius",
                                             "notes",
                                             "notes-to-self",
                                             "optical-elements-adjusted",
                                             "optical-elements-patent",
                                             "patent-location",
                                             "patent-number",
                                             "polynomial-optics",
                                             "prime",
                                             "product-name",
                                             "production-ready",
                                             "year"};
  const std::set<std::string> element_keys = {"abbe",           "aspherical-equation",
                                              "housing-radius", "ior",
                                              "lens-geometry",  "material",
                                              "radius",         "thickness"};
  EXPECT_EQ(db.size(), 24u);
  for (const auto& [key, lens] : db.items()) {
    EXPECT_TRUE(lens.at("prime").get<bool>()) << key;
    const int number = std::stoi(key);
    EXPECT_FALSE(number >= 1500 && number <= 1999) << key;
    for (const auto& [k, v] : lens.items()) EXPECT_TRUE(design_keys.count(k)) << key << ": " << k;
    for (const char* arr : {"optical-elements-patent", "optical-elements-adjusted"}) {
      if (!lens.contains(arr)) continue;
      for (const auto& e : lens[arr]) {
        EXPECT_TRUE(e.at("thickness").is_number()) << key;
        for (const auto& [k, v] : e.items()) EXPECT_TRUE(element_keys.count(k)) << key << ": " << k;
      }
    }
  }
}

TEST(LentilZoom, DesignMarkedAsZoomIsRefused) {
  const std::string text = R"({"1501": {"company": "x", "product-name": "zoom", "prime": false,
  "optical-elements-patent": [
    {"radius": 50, "thickness": 5, "ior": 1.5, "abbe": 60, "housing-radius": 10,
     "material": "abbe", "lens-geometry": "spherical"},
    {"radius": -50, "thickness": 40, "ior": 1, "housing-radius": 10, "material": "air",
     "lens-geometry": "spherical"}]}})";
  try {
    optics::parseLensJson(text, "zoom.json", "1501");
    ADD_FAILURE() << "read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("\"prime\": false"), std::string::npos) << e.what();
    EXPECT_EQ(e.loc().line, 1) << e.what();
  }
  // The same design as a prime is read.
  std::string prime = text;
  prime.replace(prime.find("false"), 5, "true");
  EXPECT_EQ(optics::parseLensJson(prime, "zoom.json", "1501").surfaces.size(), 2u);
}

}  // namespace
}  // namespace lensim
