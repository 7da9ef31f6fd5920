// Multi-configuration (zoom) lenses: the Zemax MNUM operands and lensim JSON configurations
// read into per-configuration prescriptions, checked against an independent paraxial trace
// written here from the published table; the zoom to a focal length; refusals at their line.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_run.h"
#include "lensim/optics/configurations.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/util/error.h"
#include "test_paths.h"

namespace lensim {
namespace {

using optics::LensPrescription;

// Nikon 80-200 mm f/2.8 (JP S53-131852) as tabulated in W. J. Smith, Modern Lens Design, 2nd
// ed., fig. 20.3: radius, thickness, n_d of the medium after; three variable air gaps (wide,
// middle, tele). The table is the design at 1/1.4 scale; the test file scales it by 1.4.
struct Row {
  double r, t, n;
};
constexpr std::array<Row, 22> kTable = {{{148.570, 5.0, 1.564},   {-479.279, 0.357, 1},
                                         {192.855, 6.286, 1.589}, {-134.999, 2.214, 1.805},
                                         {-874.852, 0, 1},        {-285.712, 3.893, 1.755},
                                         {-44.764, 1.036, 1.517}, {59.357, 5.357, 1},
                                         {-45.071, 1.250, 1.589}, {166.174, 0, 1},
                                         {164.284, 5.000, 1.658}, {-33.928, 1.036, 1.795},
                                         {-85.047, 0, 1},         {30.464, 5.357, 1.670},
                                         {162.202, 3.071, 1},     {-374.997, 1.786, 1.805},
                                         {259.105, 17.857, 1},    {0, 18.000, 1},
                                         {-17.214, 1.714, 1.713}, {-30.230, 0.286, 1},
                                         {62.857, 3.071, 1.773},  {-466.815, 0, 1}}};
constexpr double kScale = 1.4;
// The variable gaps after rows 4, 9 and 12 (0-based), per configuration.
constexpr std::array<std::array<double, 3>, 3> kGaps = {
    {{1.86, 36.928, 16.55}, {25.27, 19.23, 10.84}, {48.678, 1.536, 5.133}}};

// Paraxial y-nu trace of a parallel ray: EFL = -y0 / u' (independent of lensim's matrices).
double yNuEfl(const std::array<double, 3>& gaps) {
  double y = 1, nu = 0, n = 1;
  for (size_t i = 0; i < kTable.size(); ++i) {
    const double c = kTable[i].r == 0 ? 0 : 1 / (kTable[i].r * kScale);
    nu -= y * (kTable[i].n - n) * c;
    n = kTable[i].n;
    if (i + 1 == kTable.size()) break;
    double t = kTable[i].t;
    if (i == 4) t = gaps[0];
    if (i == 9) t = gaps[1];
    if (i == 12) t = gaps[2];
    y += t * kScale * nu / n;
  }
  return -1 / nu;
}

std::string zoomPath() { return test::dataPath("lenses/nikon_zoom_80_200.zmx"); }

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Zoom, ZmxConfigurationsMatchIndependentParaxialTrace) {
  const LensPrescription p = optics::readLensFile(zoomPath());
  ASSERT_EQ(optics::configurationCount(p), 3);
  for (int n = 1; n <= 3; ++n) {
    const double expected = yNuEfl(kGaps[size_t(n - 1)]);
    EXPECT_NEAR(optics::configurationEfl_mm(p, n), expected, 1e-6 * expected) << "config " << n;
    // The moved gaps are what the operands say (mm, file surfaces 5, 10, 13 -> rows 4, 9, 12).
    const LensPrescription c = optics::selectConfiguration(p, n);
    EXPECT_NEAR(c.surfaces[4].thickness_mm, kGaps[size_t(n - 1)][0] * kScale, 1e-3);
    EXPECT_NEAR(c.surfaces[12].thickness_mm, kGaps[size_t(n - 1)][2] * kScale, 1e-3);
  }
  // The published focal lengths at the ends of the zoom: 80 and 200 mm.
  EXPECT_NEAR(optics::configurationEfl_mm(p, 1), 80.0, 0.5);
  EXPECT_NEAR(optics::configurationEfl_mm(p, 3), 200.0, 1.0);
  EXPECT_THROW(optics::selectConfiguration(p, 4), Error);
  EXPECT_THROW(optics::selectConfiguration(p, 0), Error);
}

TEST(Zoom, FocalLengthInterpolatesNeighbouringConfigurations) {
  const LensPrescription p = optics::readLensFile(zoomPath());
  for (double f : {80.5, 100.0, 130.0, 175.0}) {
    const optics::ZoomSetting z = optics::zoomToFocalLength(p, f);
    EXPECT_NEAR(z.achieved_efl_mm, f, 1e-6 * f);
    // Independently: the table's gaps interpolated linearly at the same t give that EFL.
    std::array<double, 3> g{};
    for (size_t k = 0; k < 3; ++k)
      g[k] = (1 - z.t) * kGaps[size_t(z.config_a - 1)][k] + z.t * kGaps[size_t(z.config_b - 1)][k];
    EXPECT_NEAR(yNuEfl(g), f, 1e-5 * f) << "f " << f;
    EXPECT_EQ(z.config_b, z.config_a + 1);
    EXPECT_EQ(z.config_a, f < optics::configurationEfl_mm(p, 2) ? 1 : 2);
  }
  try {
    optics::zoomToFocalLength(p, 300);
    FAIL() << "300 mm is outside the zoom";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("outside the zoom range"), std::string::npos) << e.what();
  }
}

// The file with one line replaced or appended: a refusal must name that line.
std::string withLine(const std::string& text, const std::string& line) { return text + line + "\n"; }

int lineCount(const std::string& text) {
  return int(std::count(text.begin(), text.end(), '\n'));
}

TEST(Zoom, ZmxRefusesUnmodelledOperandsAtTheirLine) {
  const std::string text = readText(zoomPath());
  const int next = lineCount(text) + 1;
  struct Case {
    std::string line, needle;
  };
  for (const Case& c : {Case{"PRAM 4 1 0.5 0 0 0 1 1 1 0 0 \"\" 0", "PRAM is not supported"},
                        Case{"THIC 5 7 1.0 0 0 0 1 1 1 0 0 \"\" 0", "configuration 7"},
                        Case{"THIC 40 2 1.0 0 0 0 1 1 1 0 0 \"\" 0", "expected a surface"},
                        Case{"STPS 0 2 2.5 0 0 0 1 1 1 0 0 \"\" 0", "STPS 2.5"},
                        Case{"THIC 5 2 abc 0 0 0 1 1 1 0 0 \"\" 0", "expected a number"}}) {
    try {
      optics::parseZmx(withLine(text, c.line), "zoom.zmx");
      FAIL() << c.line;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(c.needle), std::string::npos) << what;
      EXPECT_EQ(e.loc().line, next) << what;
    }
  }
}

TEST(Zoom, JsonConfigurationsRoundTrip) {
  const LensPrescription p = optics::readLensFile(zoomPath());
  const std::string json = optics::writeLensJson(p);
  const LensPrescription q = optics::parseLensJson(json, "zoom.json");
  ASSERT_EQ(optics::configurationCount(q), 3);
  for (int n = 1; n <= 3; ++n)
    EXPECT_NEAR(optics::configurationEfl_mm(q, n), yNuEfl(kGaps[size_t(n - 1)]), 1e-6 * 200);
  // A configuration naming a surface the lens does not have is refused.
  const std::string bad = R"({"format": "lensim-lens", "surfaces": [
    {"radius_mm": 50, "thickness_mm": 5, "semi_aperture_mm": 10, "ior": 1.5},
    {"radius_mm": -50, "thickness_mm": 45, "semi_aperture_mm": 10}],
  "configurations": [{"thickness_mm": {"1": 40}}, {"thickness_mm": {"7": 40}}]})";
  try {
    optics::parseLensJson(bad, "bad.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("surface index \"7\""), std::string::npos) << e.what();
    EXPECT_EQ(e.loc().line, 4) << e.what();
  }
}

TEST(Zoom, CliConfigsTable) {
  const test::CliResult r = test::runLensim("lens info --configs --json " + zoomPath());
  ASSERT_EQ(r.status, 0) << r.out;
  for (int n = 1; n <= 3; ++n) {
    const std::string key = "\"effective_focal_length_mm\": ";
    size_t at = 0;
    for (int k = 0; k < n; ++k) at = r.out.find(key, at) + key.size();
    EXPECT_NEAR(std::stod(r.out.substr(at)), yNuEfl(kGaps[size_t(n - 1)]), 1e-4) << r.out;
  }
  const test::CliResult bad = test::runLensim("lens info --config 9 " + zoomPath());
  EXPECT_EQ(bad.status, 1) << bad.out;
  EXPECT_NE(bad.out.find("configurations 1 to 3"), std::string::npos) << bad.out;
}

// Paraxial image height of a field angle: a chief ray (through the front vertex, surface 1 being
// the stop) traced with the marginal ray from infinity by y-nu to where the latter crosses the
// axis (the paraxial image plane).
double yNuImageHeight(const std::array<double, 3>& gaps, double field_deg) {
  double yc = 0, nuc = std::tan(field_deg * std::acos(-1.0) / 180), ym = 1, num = 0, n = 1;
  for (size_t i = 0; i < kTable.size(); ++i) {
    const double c = kTable[i].r == 0 ? 0 : 1 / (kTable[i].r * kScale);
    nuc -= yc * (kTable[i].n - n) * c;
    num -= ym * (kTable[i].n - n) * c;
    n = kTable[i].n;
    if (i + 1 == kTable.size()) break;
    double t = kTable[i].t;
    if (i == 4) t = gaps[0];
    if (i == 9) t = gaps[1];
    if (i == 12) t = gaps[2];
    yc += t * kScale * nuc / n;
    ym += t * kScale * num / n;
  }
  return std::abs(yc - ym / num * nuc);
}

// The fields per configuration (YFIE rows appended to the file; config 1's in YFLN): each
// configuration carries its own, and lens info reports its largest with its image height.
TEST(Zoom, ZmxFieldsPerConfiguration) {
  const LensPrescription p = optics::readLensFile(zoomPath());
  constexpr std::array<std::array<double, 2>, 3> kFields = {
      {{10.71, 15.12}, {6.63, 9.43}, {4.32, 6.16}}};  // the file's YFIE values
  for (int n = 1; n <= 3; ++n) {
    const LensPrescription c = optics::selectConfiguration(p, n);
    ASSERT_TRUE(c.fields) << n;
    EXPECT_EQ(c.fields->kind, optics::FileFields::Kind::Angle);
    ASSERT_EQ(c.fields->xy.size(), 3u);
    EXPECT_EQ(c.fields->xy[0].second, 0.0);
    EXPECT_EQ(c.fields->xy[1].second, kFields[size_t(n - 1)][0]);
    EXPECT_EQ(c.fields->xy[2].second, kFields[size_t(n - 1)][1]);
  }
  // The fields hold at the configurations only: a zoom between two that differ drops them.
  EXPECT_FALSE(optics::zoomToFocalLength(p, 100).prescription.fields);

  const test::CliResult r = test::runLensim("lens info --configs --json " + zoomPath());
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  ASSERT_EQ(j["configurations"].size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    const auto& f = j["configurations"][k]["file_field"];
    EXPECT_EQ(f["kind"], "angle");
    EXPECT_EQ(f["field"], 3);
    EXPECT_NEAR(f["value"].get<double>(), kFields[k][1], 1e-12);
    // Against the y-nu trace written here (and f tan(theta): the two agree paraxially).
    const double h = yNuImageHeight(kGaps[k], kFields[k][1]);
    EXPECT_NEAR(f["paraxial_image_height_mm"].get<double>(), h, 1e-6 * h) << k;
    EXPECT_NEAR(h, yNuEfl(kGaps[k]) * std::tan(kFields[k][1] * std::acos(-1.0) / 180), 1e-9 * h);
  }
  // --config N reports that configuration's.
  const test::CliResult one = test::runLensim("lens info --json --config 2 " + zoomPath());
  ASSERT_EQ(one.status, 0) << one.out;
  const auto j2 = nlohmann::json::parse(one.out.substr(one.out.find('{')));
  EXPECT_NEAR(j2["file_field"]["value"].get<double>(), kFields[1][1], 1e-12);
  const test::CliResult text = test::runLensim("lens info --configs " + zoomPath());
  EXPECT_NE(text.out.find("9.4300 deg (angle 3), paraxial image height"), std::string::npos)
      << text.out;

  // Refused at their line: a field the file does not list, operands not modelled.
  const std::string file = readText(zoomPath());
  const int next = lineCount(file) + 1;
  for (const auto& [line, needle] :
       std::array<std::pair<const char*, const char*>, 3>{
           {{"YFIE 4 2 1.0 0 0 0 1 1 1 0 0 \"\" 0", "expected a field 1 to 3"},
            {"FLWT 2 2 1.0 0 0 0 1 1 1 0 0 \"\" 0", "FLWT is not supported"},
            {"FVDY 2 2 0.1 0 0 0 1 1 1 0 0 \"\" 0", "FVDY is not supported"}}}) {
    try {
      optics::parseZmx(withLine(file, line), "zoom.zmx");
      ADD_FAILURE() << line;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(e.loc().line, next) << e.what();
    }
  }
  // A file without fields cannot set one.
  std::string no_fields = file;
  no_fields.replace(no_fields.find("FTYP"), 4, "NOTE");
  for (const char* key : {"XFLN", "YFLN"}) no_fields.replace(no_fields.find(key), 4, "NOTE");
  try {
    optics::parseZmx(no_fields, "zoom.zmx");
    ADD_FAILURE() << "YFIE without fields";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lists no fields"), std::string::npos) << e.what();
  }
}

// Group focusing: a three-element lens whose middle element moves (gap 1 grows by x, gap 3
// shrinks by x). Checked by a y-nu trace written here: the film stays at the infinity focus's
// place, and the object at the focus distance images onto it.
constexpr std::array<Row, 6> kGroupLens = {
    {{50, 4, 1.6}, {-200, 10, 1}, {40, 4, 1.6}, {100, 10, 1}, {-30, 3, 1.6}, {-60, 0, 1}}};
const char* const kGroupLensJson = R"({"format": "lensim-lens", "surfaces": [
  {"radius_mm": 50, "thickness_mm": 4, "semi_aperture_mm": 6, "ior": 1.6},
  {"radius_mm": -200, "thickness_mm": 10, "semi_aperture_mm": 6},
  {"radius_mm": 40, "thickness_mm": 4, "semi_aperture_mm": 6, "ior": 1.6, "stop": false},
  {"radius_mm": 100, "thickness_mm": 10, "semi_aperture_mm": 6},
  {"radius_mm": -30, "thickness_mm": 3, "semi_aperture_mm": 6, "ior": 1.6},
  {"radius_mm": -60, "thickness_mm": 0, "semi_aperture_mm": 6}],
  "focus_group": {"1": 1, "3": -1}})";

// Traces (y, nu) through the group lens with gaps a, b; returns {y, u} after the last surface
// and the rear vertex z.
std::array<double, 3> traceGroupLens(double a, double b, double y, double u) {
  double n = 1, z = 0;
  for (size_t i = 0; i < kGroupLens.size(); ++i) {
    const double nu = n * u - y * (kGroupLens[i].n - n) / kGroupLens[i].r;
    n = kGroupLens[i].n;
    u = nu / n;
    if (i + 1 == kGroupLens.size()) break;
    const double t = i == 1 ? a : i == 3 ? b : kGroupLens[i].t;
    y += t * u;
    z += t;
  }
  return {y, u, z};
}

TEST(GroupFocus, FilmStaysAndTheObjectImagesOnIt) {
  const LensPrescription p = optics::parseLensJson(kGroupLensJson, "group.json");
  ASSERT_EQ(p.focus_group.size(), 2u);
  // Infinity focus with the group at rest: the film is the BFL behind the rear vertex.
  const auto inf = traceGroupLens(10, 10, 1, 0);
  const double track = inf[2] - inf[0] / inf[1];
  for (double d_m : {2.0, 1.0, 0.5}) {
    optics::LensSetup setup;
    setup.focus_distance_m = d_m;
    const optics::FocusedLens fl = optics::focusLens(p, setup);
    const auto& rows = fl.lens->prescription().surfaces;
    const double a = rows[1].thickness_mm, b = rows[3].thickness_mm;
    EXPECT_NEAR(a + b, 20, 1e-9);  // the group moved as one
    EXPECT_LT(a, 10);              // closer focus: the middle element moves forward
    EXPECT_NEAR(fl.lens->filmZ_mm(), track, 1e-6);
    // The axial object d_m from the film images on the film.
    const double s = track - d_m * 1000;  // object z (front vertex at 0)
    const double u0 = 1e-3;
    const auto out = traceGroupLens(a, b, -s * u0, u0);
    const double image_z = out[2] - out[0] / out[1];
    EXPECT_NEAR(image_z, track, 1e-6 * track) << d_m;
    // Breathing: the focal length is that of the moved group, not of the lens at rest.
    EXPECT_NEAR(fl.paraxial.effective_focal_length_mm,
                -1 / traceGroupLens(a, b, 1, 0)[1], 1e-9 * 60);
  }
  // Unit focusing of the same lens keeps the spacings.
  LensPrescription unit = p;
  unit.focus_group.clear();
  optics::LensSetup setup;
  setup.focus_distance_m = 1.0;
  EXPECT_EQ(optics::focusLens(unit, setup).lens->prescription().surfaces[1].thickness_mm, 10);
  // Round trip through the JSON writer keeps the group.
  EXPECT_EQ(optics::parseLensJson(optics::writeLensJson(p), "g.json").focus_group, p.focus_group);
}

TEST(GroupFocus, CliBreathingPlot) {
  const std::string lens = test::dataPath("lenses/group_focus_triplet.json");
  const test::CliResult r = test::runLensim("lens plot breathing --json --film-diagonal 20 -o " +
                                            ::testing::TempDir() + "/breathing.svg " + lens);
  ASSERT_EQ(r.status, 0) << r.out;
  const size_t at = r.out.find('{');
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::string js = r.out.substr(at);
  // Both curves, and the group curve's focal lengths are those of the moved group: shorter
  // than at rest when focused close (the middle element moves forward), see the test above.
  for (const char* key : {"\"unit\"", "\"group\""})
    EXPECT_NE(js.find(key), std::string::npos) << js;
  const size_t g = js.find("\"group\"");
  const std::string efl_key = "\"effective_focal_length_mm\": ";
  const double first_group_efl = std::stod(js.substr(js.find(efl_key, g) + efl_key.size()));
  EXPECT_LT(first_group_efl, -1 / traceGroupLens(10, 10, 1, 0)[1] - 0.5) << js;
}

TEST(GroupFocus, CliInfoMagnificationAtTheFocusedDistance) {
  const std::string lens = test::dataPath("lenses/group_focus_triplet.json");
  const test::CliResult r =
      test::runLensim("lens info --json --focus-distance 1 " + lens + " 2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  const double a = j["surfaces"][1]["thickness_mm"], b = j["surfaces"][3]["thickness_mm"];
  EXPECT_NEAR(a + b, 20, 1e-9);
  // Independent: m = u / u' of an axial ray from the object (y-nu trace above).
  const auto inf = traceGroupLens(10, 10, 1, 0);
  const double track = inf[2] - inf[0] / inf[1];
  const double s = track - 1000, u0 = 1e-3;
  const auto out = traceGroupLens(a, b, -s * u0, u0);
  EXPECT_NEAR(j["magnification"].get<double>(), u0 / out[1], 1e-9);
  EXPECT_TRUE(j["group_focusing"].get<bool>());
}

}  // namespace
}  // namespace lensim
