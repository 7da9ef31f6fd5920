// Floating focus from Zemax focus positions (docs/zoom.md): the double Gauss test lens whose two
// inner doublets move at different rates; the moved gaps piecewise linear in the object vergence
// between the file's positions, the position for a focus distance against a paraxial y-nu trace,
// the same interpolation and a bisection written here; real rays; the range refused beyond.
#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_run.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/util/error.h"
#include "test_paths.h"

namespace lensim {
namespace {

// tests/data/lenses/dgauss_floating_focus.zmx: radius, thickness, index after (US 2,673,491 as
// in Smith's Modern Lens Design, scaled to 50 mm); the image distance is the paraxial BFL.
struct Row {
  double r, t, n;
};
constexpr std::array<Row, 11> kLens = {{{29.475, 3.76, 1.67},
                                        {84.83, 0.12, 1},
                                        {19.275, 4.025, 1.67},
                                        {40.77, 3.275, 1.699},
                                        {12.75, 5.705, 1},
                                        {0, 4.5, 1},
                                        {-14.495, 1.18, 1.603},
                                        {40.77, 6.065, 1.658},
                                        {-20.385, 0.19, 1},
                                        {437.065, 3.22, 1.717},
                                        {-39.73, 0, 1}}};
// The moved rows and their thicknesses at each focus position of the file (object 5000, 3000,
// 2000 mm from the front vertex), by object vergence (1/m).
constexpr std::array<size_t, 4> kRows = {1, 4, 5, 8};
constexpr std::array<double, 4> kVergence = {0, 0.2, 1.0 / 3, 0.5};
constexpr std::array<std::array<double, 4>, 4> kGaps = {{{0.12, 5.705, 4.5, 0.19},
                                                         {1.4319, 4.3931, 4.2376, 0.4524},
                                                         {2.4194, 3.4056, 3.6952, 0.9948},
                                                         {3.7743, 2.0507, 2.6729, 2.0171}}};

// The gaps at vergence u, linear between the neighbouring positions.
std::array<double, 4> gapsAt(double u) {
  size_t k = 0;
  while (k + 2 < kVergence.size() && u > kVergence[k + 1]) ++k;
  const double s = (u - kVergence[k]) / (kVergence[k + 1] - kVergence[k]);
  std::array<double, 4> g{};
  for (size_t i = 0; i < 4; ++i) g[i] = (1 - s) * kGaps[k][i] + s * kGaps[k + 1][i];
  return g;
}

// (y, u) from the front vertex through the lens with gaps g; returns {y, u, rear vertex z}.
std::array<double, 3> trace(const std::array<double, 4>& g, double y, double u) {
  double n = 1, z = 0;
  for (size_t i = 0; i < kLens.size(); ++i) {
    const double c = kLens[i].r == 0 ? 0 : 1 / kLens[i].r;
    const double nu = n * u - y * (kLens[i].n - n) * c;
    n = kLens[i].n;
    u = nu / n;
    if (i + 1 == kLens.size()) break;
    double t = kLens[i].t;
    for (size_t k = 0; k < 4; ++k)
      if (kRows[k] == i) t = g[k];
    y += t * u;
    z += t;
  }
  return {y, u, z};
}

double track() {
  const auto r = trace(kGaps[0], 1, 0);
  return r[2] - r[0] / r[1];
}

// Where the lens at vergence parameter u images an object d_m from the film, behind the film.
double imageBehindFilm(double u, double d_m) {
  const double s = d_m * 1000 - track(), u0 = 1e-3;
  const auto r = trace(gapsAt(u), s * u0, u0);
  return r[2] - r[0] / r[1] - track();
}

double solvedParameter(double d_m) {
  double lo = 0, hi = 0.5;
  const bool lo_sign = imageBehindFilm(lo, d_m) > 0;
  EXPECT_NE(lo_sign, imageBehindFilm(hi, d_m) > 0) << d_m;
  for (int it = 0; it < 200; ++it) {
    const double m = 0.5 * (lo + hi);
    ((imageBehindFilm(m, d_m) > 0) == lo_sign ? lo : hi) = m;
  }
  return 0.5 * (lo + hi);
}

std::string lensPath() { return test::dataPath("lenses/dgauss_floating_focus.zmx"); }

optics::LensPrescription readLens() { return optics::readLensFile(lensPath()); }

TEST(FloatingFocus, ReadFromTheFocusPositions) {
  const optics::LensPrescription p = readLens();
  ASSERT_TRUE(p.floating_focus);
  EXPECT_TRUE(p.configurations.empty());
  EXPECT_TRUE(p.focus_group.empty());
  const auto& f = *p.floating_focus;
  EXPECT_EQ(f.rows, (std::vector<int>{1, 4, 5, 8}));
  ASSERT_EQ(f.vergence_dpt.size(), 4u);
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_NEAR(f.vergence_dpt[k], kVergence[k], 1e-15);
    for (size_t i = 0; i < 4; ++i) EXPECT_EQ(f.thickness_mm[k][i], kGaps[k][i]);
  }
  for (size_t i = 0; i < 4; ++i) EXPECT_EQ(p.surfaces[kRows[i]].thickness_mm, kGaps[0][i]);
  EXPECT_FALSE(p.object_distance_mm);
  bool noted = false;
  for (const Diagnostic& d : p.diagnostics)
    noted = noted || d.message.find("floating focus") != std::string::npos;
  EXPECT_TRUE(noted);
  // No lensim format holds it: the writers refuse rather than drop it.
  EXPECT_THROW(optics::writeLensJson(p), Error);
  EXPECT_THROW(optics::writeLensZmx(p), Error);
}

TEST(FloatingFocus, PositionMatchesIndependentTrace) {
  const optics::LensPrescription p = readLens();
  // At the file's own distances the parameter is the position's vergence (gaps to 4 decimals).
  for (size_t k = 1; k < 4; ++k)
    EXPECT_NEAR(solvedParameter((1 / kVergence[k] * 1000 + track()) / 1000), kVergence[k], 2e-4)
        << k;
  for (double d_m : {8.0, 4.0, 2.5, 2.1}) {
    const double u = solvedParameter(d_m);
    const std::array<double, 4> g = gapsAt(u);
    optics::LensSetup setup;
    setup.focus_distance_m = d_m;
    const optics::FocusedLens fl = optics::focusLens(p, setup);
    const auto& rows = fl.lens->prescription().surfaces;
    for (size_t i = 0; i < 4; ++i) EXPECT_NEAR(rows[kRows[i]].thickness_mm, g[i], 1e-7) << d_m;
    EXPECT_NEAR(fl.lens->filmZ_mm(), track(), 1e-6) << d_m;
    EXPECT_NEAR(fl.paraxial.effective_focal_length_mm, -1 / trace(g, 1, 0)[1], 1e-8) << d_m;
  }
}

TEST(FloatingFocus, RealRaysFocusOnTheFixedFilm) {
  const optics::LensPrescription p = readLens();
  optics::LensSetup exact;
  exact.focus_distance_m = 2.5;
  exact.focus_method = optics::FocusMethod::Exact;
  optics::FocusedLens fl = optics::focusLens(p, exact);
  optics::LensSetup at_rest = exact;
  at_rest.focus_distance_m = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(fl.lens->filmZ_mm(), optics::focusLens(p, at_rest).lens->filmZ_mm(), 1e-9);
  // The moved gaps keep the length and lie on the interpolation (some vergence parameter).
  const auto& rows = fl.lens->prescription().surfaces;
  double sum = 0;
  for (size_t i = 0; i < 4; ++i) sum += rows[kRows[i]].thickness_mm;
  EXPECT_NEAR(sum, 10.515, 1e-9);
  // The parameter from the first gap (increasing along the positions), span by span.
  const double t1 = rows[1].thickness_mm;
  size_t k = 0;
  while (k + 2 < kVergence.size() && t1 > kGaps[k + 1][0]) ++k;
  const double u = kVergence[k] + (t1 - kGaps[k][0]) / (kGaps[k + 1][0] - kGaps[k][0]) *
                                      (kVergence[k + 1] - kVergence[k]);
  EXPECT_GT(std::abs(u - solvedParameter(2.5)), 1e-4);  // real rays differ from paraxial
  for (size_t i = 0; i < 4; ++i) EXPECT_NEAR(rows[kRows[i]].thickness_mm, gapsAt(u)[i], 1e-9);
  optics::LensSystem& lens = *fl.lens;
  const double film = lens.filmDistance_mm();
  const double best = optics::axialRmsSpot_mm(lens, fl.paraxial, 2.5);
  for (double dz : {-0.02, 0.02}) {
    lens.setFilmDistance_mm(film + dz);
    EXPECT_GT(optics::axialRmsSpot_mm(lens, fl.paraxial, 2.5), best) << dz;
  }
}

TEST(FloatingFocus, OutsideTheFileRangeRefused) {
  const optics::LensPrescription p = readLens();
  optics::LensSetup setup;
  setup.focus_distance_m = 1.0;  // the nearest position is 2 m from the front vertex
  try {
    optics::focusLens(p, setup);
    FAIL() << "1 m is closer than the file's positions";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("does not extrapolate"), std::string::npos) << e.what();
    EXPECT_EQ(e.loc().line, p.floating_focus->loc.line);
  }
  // A focus position with the object behind the front vertex is refused at its line.
  std::ifstream in(lensPath(), std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::string from = "THIC 0 4 2000";
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, from.size(), "THIC 0 4 -2000");
  const int line = 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
  try {
    optics::parseZmx(text, "dgauss.zmx");
    FAIL() << "negative object distance";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("object in front of the lens"), std::string::npos)
        << e.what();
    EXPECT_EQ(e.loc().line, line) << e.what();
  }
}

// Focus positions may list each distance's own fields (object heights there): they describe
// the object, not the lens, and the lens keeps the infinity configuration's.
TEST(FloatingFocus, FocusPositionsMayChangeTheFields) {
  std::ifstream in(lensPath(), std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  text.replace(text.find("SURF 0"), 6, "FTYP 0 0 2 1 0 0 0\nYFLN 0 20 0 0\nSURF 0");
  const std::string tail = " 0 0 0 1 1 1 0 0 \"\" 0\n";
  for (const char* row : {"YFIE 2 1 20", "YFIE 2 2 19.5", "YFIE 2 3 19", "YFIE 2 4 18.5"})
    text += row + tail;
  const optics::LensPrescription p = optics::parseZmx(text, "dgauss.zmx");
  ASSERT_TRUE(p.floating_focus);
  ASSERT_TRUE(p.fields);
  EXPECT_EQ(p.fields->xy.size(), 2u);
  EXPECT_EQ(p.fields->xy[1].second, 20.0);
}

TEST(FloatingFocus, CliInfoReportsIt) {
  const test::CliResult r =
      test::runLensim("lens info --json --focus-distance 2.5 " + lensPath() + " 2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  EXPECT_TRUE(j["floating_focus"].get<bool>());
  EXPECT_TRUE(j["group_focusing"].get<bool>());
  const std::array<double, 4> g = gapsAt(solvedParameter(2.5));
  for (size_t i = 0; i < 4; ++i)
    EXPECT_NEAR(j["surfaces"][kRows[i]]["thickness_mm"].get<double>(), g[i], 1e-6);
}

}  // namespace
}  // namespace lensim
