// Glasses the refractiveindex.info database gives only as a table of n (issue 28, docs/glass.md):
// each built-in table glass against its YAML file's table, read here; B 270 against Schott's
// datasheet; the valid range is the table's; Thorlabs' ACL3026U asphere (B 270) reads and focuses
// where a paraxial trace written here and the file's own OpticStudio focus solve say.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "lensim/optics/glass.h"
#include "lensim/optics/glass/embedded.h"
#include "lensim/optics/glass/library.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/util/error.h"
#include "lensim/render/spectra/spectrum_data.h"
#include "render_test_util.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The "tabulated n" entry of a refractiveindex.info YAML file: (lambda um, n) pairs.
std::vector<std::pair<double, double>> readTable(const std::string& rel) {
  std::ifstream in(std::string(LENSIM_SHARED_DIR) + "/glass/refractiveindex.info/" + rel);
  EXPECT_TRUE(in.good()) << rel;
  std::vector<std::pair<double, double>> table;
  bool in_n = false, in_data = false;
  for (std::string line; std::getline(in, line);) {
    std::istringstream s(line);
    std::string first;
    s >> first;
    if (first == "-") {
      std::string key, type, what;
      s >> key >> type >> what;
      in_n = type == "tabulated" && what == "n";
      in_data = false;
    } else if (first == "data:") {
      in_data = in_n;
    } else if (in_data) {
      std::istringstream nums(line);
      double l = 0, n = 0;
      if (nums >> l >> n)
        table.emplace_back(l, n);
      else
        in_data = false;
    }
  }
  return table;
}

const Glass& builtinGlass(const std::string& name) {
  const CatalogGlass* g = GlassCatalog::builtin().find(name);
  if (!g) throw std::runtime_error("no built-in glass " + name);
  return g->glass;
}

}  // namespace

// Every point of each table: the fitted formula agrees within half a unit of the table's last
// decimal (the values are rounded to 4 decimals), and the valid range is the table's span.
TEST(TabulatedGlass, ReproducesEveryTabulatedPoint) {
  const std::pair<const char*, const char*> glasses[] = {
      {"B270", "specs/schott/misc/B270.yml"},
      {"EAGLEXG", "specs/corning/EagleXG.yml"},
  };
  for (const auto& [name, yml] : glasses) {
    SCOPED_TRACE(name);
    const auto table = readTable(yml);
    ASSERT_GE(table.size(), 7u);
    const Glass& g = builtinGlass(std::string("rii:") + name);
    EXPECT_EQ(&builtinGlass(name), &g) << "a bare name finds it";
    for (const auto& [l_um, n] : table) EXPECT_NEAR(g.index(l_um * 1000), n, 5e-5) << l_um;
    // The copy lensim carries (glass/crystal_data.cpp) is the file's table.
    int copies = 0;
    for (const embedded::CrystalGlass& c : embedded::crystalGlasses()) {
      if (std::string(c.name) != name) continue;
      ++copies;
      EXPECT_EQ(std::string(c.source), yml);
      ASSERT_EQ(size_t(c.table_points), table.size());
      for (size_t i = 0; i < table.size(); ++i) {
        EXPECT_EQ(c.table[2 * i], table[i].first);
        EXPECT_EQ(c.table[2 * i + 1], table[i].second);
      }
    }
    EXPECT_EQ(copies, 1);
    EXPECT_DOUBLE_EQ(g.minWavelength_nm(), table.front().first * 1000);
    EXPECT_DOUBLE_EQ(g.maxWavelength_nm(), table.back().first * 1000);
  }
}

// Schott's B 270 technical details (schott.com): n_g 1.5341, n_F' 1.5297, n_F 1.5292,
// n_e 1.5251, n_d 1.5230, n_D 1.5229, n_C' 1.5207, n_C 1.5203; Abbe number nu_e 58.3 +- 0.6.
TEST(TabulatedGlass, B270MatchesSchottsDatasheet) {
  const Glass& g = builtinGlass("B270");
  EXPECT_NEAR(g.index(435.8343), 1.5341, 5e-5);  // g
  EXPECT_NEAR(g.index(479.9914), 1.5297, 5e-5);  // F'
  EXPECT_NEAR(g.index(kLineF_nm), 1.5292, 5e-5);
  EXPECT_NEAR(g.index(546.0740), 1.5251, 5e-5);  // e
  EXPECT_NEAR(g.n_d(), 1.5230, 5e-5);
  EXPECT_NEAR(g.index(589.2938), 1.5229, 5e-5);  // D
  EXPECT_NEAR(g.index(643.8469), 1.5207, 5e-5);  // C'
  EXPECT_NEAR(g.index(kLineC_nm), 1.5203, 5e-5);
  const double nu_e = (g.index(546.0740) - 1) / (g.index(479.9914) - g.index(643.8469));
  EXPECT_NEAR(nu_e, 58.3, 0.6);
  // nu_d from the datasheet's own rounded n_d, n_F, n_C: 58.76, uncertain by their rounding
  // (+-5e-5 each on n_F - n_C = 0.0089: +-0.66).
  EXPECT_NEAR(g.v_d(), 0.5230 / (1.5292 - 1.5203), 0.66);
}

// Outside its table a tabulated glass is refused (docs/glass.md: the formula's valid range);
// --glass-extrapolate makes it a warning.
TEST(TabulatedGlass, OutsideTheTableIsRefusedUnlessAllowed) {
  const Glass& g = builtinGlass("B270");
  const FileLoc loc{"lens.zmx", 96, 3};
  EXPECT_NO_THROW(checkGlassRange(g, 550, loc, "wavelength"));
  for (const double l : {400.0, 435.0, 657.0, 700.0}) {
    SCOPED_TRACE(l);
    try {
      checkGlassRange(g, l, loc, "wavelength");
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, 96);
      EXPECT_NE(std::string(e.what()).find("rii:B270"), std::string::npos) << e.what();
    }
  }
  setGlassExtrapolationAllowed(true);
  std::vector<Diagnostic> d;
  EXPECT_NO_THROW(checkGlassRange(g, 700, loc, "wavelength", &d));
  setGlassExtrapolationAllowed(false);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].severity, Severity::Warning);
}

// Thorlabs' ACL3026U (part number: 30 mm across, f 26 mm; B 270, plano-convex even asphere at
// 587 nm). Its EFL against the plano-convex closed form with the datasheet's n_d, R / (n_d - 1)
// (the asphere's r^2 term is 0: the paraxial power is the base curvature's), and the part
// number's 26 mm within 1%; its back focal length against the file's own image distance,
// OpticStudio's paraxial focus solve with its B 270 (18.0921 mm; lensim 18.0963 mm: the two
// n(587 nm) differ by 1e-4, a tenth of the +-0.001 Schott gives B 270's index): within 2e-4 in
// n, 8.9 um (dBFL/dn = -44 mm).
TEST(TabulatedGlass, Acl3026uFocusesWhereThorlabsSays) {
  const std::string path = std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/ACL3026U-Zemax(ZMX).zmx";
  const std::string bytes = slurp(path);
  ASSERT_FALSE(bytes.empty());
  const LensPrescription p = parseZmx(bytes, path);
  const double r_mm = 1 / 7.379474728988791300E-002, t_mm = 11.9, n_d = 1.5230;
  const double efl_closed = r_mm / (n_d - 1);
  const LensSystem lens(p);
  const ParaxialData d = computeParaxial(lens.atWavelength(kLineD_nm));
  EXPECT_NEAR(d.effective_focal_length_mm, efl_closed, 5e-5 / (n_d - 1) * efl_closed);
  EXPECT_NEAR(d.effective_focal_length_mm, 26.0, 0.26);
  EXPECT_NEAR(efl_closed - t_mm / n_d, d.back_focal_length_mm, 5e-5 * 45);
  const ParaxialData at587 = computeParaxial(lens.atWavelength(587.0));
  EXPECT_NEAR(at587.back_focal_length_mm, 18.09209481007, 9e-3);
}

// A render traces 360-830 nm, beyond B 270's table (436-656 nm): the camera is refused at the
// scene's Camera line, naming the glass and its range; with --glass-extrapolate it renders.
TEST(TabulatedGlass, RenderRefusesB270AtTheCameraLine) {
  const std::string scene = fmt::format(
      R"(LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "{}/lenses/zmx/ACL3026U-Zemax(ZMX).zmx"
  "float aperturediameter" 10 "float focusdistance" 1000
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "float diagonal" 1
Sampler "independent" "integer pixelsamples" 4
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
)",
      LENSIM_SHARED_DIR);
  try {
    testutil::renderText(scene);
    ADD_FAILURE() << "rendered";
  } catch (const Error& e) {
    EXPECT_EQ(e.loc().line, 2) << e.what();
    for (const char* word :
         {"rii:B270", "435.83-656.27 nm", "405-700 nm", "--glass-extrapolate"})
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
  setGlassExtrapolationAllowed(true);
  const auto r = testutil::renderText(scene);
  setGlassExtrapolationAllowed(false);
  EXPECT_EQ(r.image.width, 4);
}

// The span a glass must cover for renders (405-700 nm) holds all but 0.7 % of each CIE 1931
// colour-matching function's weight over 360-830 nm (5 nm samples); B 270's table (436-656 nm)
// leaves out a quarter of z-bar's: extrapolation would decide the blue.
TEST(TabulatedGlass, RenderSpanHoldsTheObserversWeight) {
  auto outside = [](double lo, double hi, int k) {
    double out = 0, all = 0;
    for (int i = 0; i < 95; ++i) {
      const double l = render::data::kCieFirst_nm + i * render::data::kCieStep_nm;
      const double w = render::data::kCie1931_5nm[i][k];
      all += w;
      if (l < lo || l > hi) out += w;
    }
    return out / all;
  };
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(outside(kRenderGlassFrom_nm, kRenderGlassTo_nm, k), 0.007) << k;
    EXPECT_GT(outside(kRenderGlassFrom_nm, kRenderGlassTo_nm, k), 0.0003) << k;
  }
  EXPECT_GT(outside(435.83, 656.27, 2), 0.25);
}
