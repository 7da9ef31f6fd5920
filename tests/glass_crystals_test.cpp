// Built-in crystals and plastics and old glass names (issue 28 "Glasses", docs/glass.md): each
// crystal against its refractiveindex.info YAML file's formula, evaluated here from the file's
// own coefficients, and its valid range; Zemax's catalogue names keep their meaning; old names
// mapped to their successors where the source says so.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "lensim/optics/glass.h"
#include "lensim/util/error.h"

using namespace lensim;

namespace {

struct Yaml {
  int formula = 0;
  double lo_um = 0, hi_um = 0;
  std::vector<double> c;
};

// The formula entry of a refractiveindex.info YAML file, read line by line.
Yaml readYaml(const std::string& rel) {
  std::ifstream in(std::string(LENSIM_SHARED_DIR) + "/glass/refractiveindex.info/" + rel);
  EXPECT_TRUE(in.good()) << rel;
  Yaml y;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string key;
    s >> key;
    if (key == "-") s >> key;
    if (key == "type:") {
      std::string word;
      s >> word >> y.formula;
    } else if (key == "wavelength_range:") {
      s >> y.lo_um >> y.hi_um;
    } else if (key == "coefficients:") {
      for (double v; s >> v;) y.c.push_back(v);
    }
  }
  return y;
}

// refractiveindex.info's formulas 1 and 2 (its documentation): n^2 - 1 = C1 + sum_i C_2i l^2 /
// (l^2 - C_2i+1^2) (formula 1) or / (l^2 - C_2i+1) (formula 2).
double yamlIndex(const Yaml& y, double lambda_um) {
  const double l2 = lambda_um * lambda_um;
  double n2 = 1 + y.c.at(0);
  for (size_t i = 1; i + 1 < y.c.size(); i += 2) {
    const double b = y.formula == 1 ? y.c[i + 1] * y.c[i + 1] : y.c[i + 1];
    n2 += y.c[i] * l2 / (l2 - b);
  }
  return std::sqrt(n2);
}

struct Entry {
  const char* name;
  const char* file;
};
const Entry kEntries[] = {
    {"F_SILICA", "main/SiO2/nk/Malitson.yml"},
    {"SILICA", "main/SiO2/nk/Malitson.yml"},
    {"CAF2", "main/CaF2/nk/Malitson.yml"},
    {"MGF2", "main/MgF2/nk/Dodge-o.yml"},
    {"BAF2", "main/BaF2/nk/Malitson.yml"},
    {"SAPPHIRE", "main/Al2O3/nk/Malitson-o.yml"},
    {"PMMA", "organic/(C5H8O2)n - poly(methyl methacrylate)/nk/Szczurowski.yml"},
    {"POLYCARB", "organic/(C16H14O3)n - polycarbonate/nk/Sultanova.yml"},
    {"POLYSTYR", "organic/(C8H8)n - polystyrene/nk/Sultanova.yml"},
};

}  // namespace

TEST(CrystalGlasses, EachAgainstItsYamlFormula) {
  const optics::GlassCatalog& cat = optics::GlassCatalog::builtin();
  for (const Entry& e : kEntries) {
    SCOPED_TRACE(e.name);
    const Yaml y = readYaml(e.file);
    ASSERT_TRUE(y.formula == 1 || y.formula == 2);
    const optics::CatalogGlass* g = cat.find(std::string("rii:") + e.name);
    ASSERT_NE(g, nullptr);
    EXPECT_EQ(g->glass.describe(), std::string("rii:") + e.name);
    EXPECT_NEAR(g->glass.minWavelength_nm(), y.lo_um * 1000, 1e-9);
    EXPECT_NEAR(g->glass.maxWavelength_nm(), y.hi_um * 1000, 1e-9);
    // Three wavelengths inside every entry's range.
    for (double l : {0.45, optics::kLineD_nm / 1000, 0.95})
      EXPECT_NEAR(g->glass.index(l * 1000), yamlIndex(y, l), 1e-12) << l;
  }
}

// The same materials in Zemax's own catalogues (MISC, INFRARED; other measurements or fits):
// their n_d agree with the refractiveindex.info entries to the spread between sources.
TEST(CrystalGlasses, AgreeWithZemaxsCataloguesAndDoNotShadowThem) {
  const optics::GlassCatalog& cat = optics::GlassCatalog::builtin();
  const struct {
    const char* rii;
    const char* zemax;
    double tol;
  } pairs[] = {{"F_SILICA", "misc:F_SILICA", 2e-5},     {"CAF2", "misc:CAF2", 2e-5},
               {"MGF2", "infrared:MGF2", 2e-4},         {"BAF2", "infrared:BAF2", 2e-4},
               {"SAPPHIRE", "infrared:SAPPHIRE", 2e-4}, {"PMMA", "misc:PMMA", 2e-3},
               {"POLYCARB", "misc:POLYCARB", 3e-3},     {"POLYSTYR", "misc:POLYSTYR", 3e-3}};
  for (const auto& p : pairs) {
    SCOPED_TRACE(p.rii);
    const optics::CatalogGlass* a = cat.find(std::string("rii:") + p.rii);
    const optics::CatalogGlass* z = cat.find(p.zemax);
    ASSERT_NE(a, nullptr);
    ASSERT_NE(z, nullptr);
    EXPECT_NEAR(a->glass.n_d(), z->glass.n_d(), p.tol);
    // A bare name is the makers' catalogues' (searched first), never the rii entry.
    const optics::CatalogGlass* bare = cat.find(p.rii);
    ASSERT_NE(bare, nullptr);
    EXPECT_NE(bare->catalog, "rii");
  }
  // BAF2 bare is a maker's barium flint glass (Hoya's, CDGM's), not the crystal (n_d 1.4745).
  EXPECT_GT(cat.find("BAF2")->glass.n_d(), 1.55);
  EXPECT_TRUE(cat.hasCatalog("rii"));
  // A GCAT line naming RII puts it first.
  EXPECT_EQ(cat.find("CAF2", {"RII"})->glass.describe(), "rii:CAF2");
}

// Old names: refractiveindex.info's glass/optical/BK7/about.yml names the glass type BK7, BSL7,
// K9L, BSC7 and lists its makers' glasses (SCHOTT N-BK7, OHARA S-BSL7, CDGM H-K9L, ...). BK7
// (found in no catalogue) maps to Schott's N-BK7 and K9L to CDGM's H-K9L, with a warning; the
// listed glasses the catalogues have agree with the successor in n_d (1e-3) and V_d (0.5).
TEST(OldGlassNames, MappedToTheSuccessorTheSourceNames) {
  const optics::GlassCatalog& cat = optics::GlassCatalog::builtin();
  std::ifstream in(std::string(LENSIM_SHARED_DIR) +
                   "/glass/refractiveindex.info/glass/optical/BK7/about.yml");
  std::stringstream text;
  text << in.rdbuf();
  const std::string about = text.str();
  for (const char* n : {"- BK7", "- K9L", "<td>N-BK7</td>", "<td>H-K9L</td>", "<td>S-BSL7</td>"})
    EXPECT_NE(about.find(n), std::string::npos) << n;
  const optics::CatalogGlass* nbk7 = cat.find("schott:N-BK7");
  ASSERT_NE(nbk7, nullptr);
  for (const char* analogue : {"ohara:S-BSL7", "cdgm:H-K9L", "sumita:K-BK7", "nikon:J-BK7A"}) {
    const optics::CatalogGlass* a = cat.find(analogue);
    ASSERT_NE(a, nullptr) << analogue;
    EXPECT_NEAR(a->listed_n_d, nbk7->listed_n_d, 1e-3) << analogue;
    EXPECT_NEAR(a->listed_v_d, nbk7->listed_v_d, 0.5) << analogue;
  }
  EXPECT_EQ(cat.find("BK7"), nullptr);  // no catalogue has the old name itself

  const struct {
    const char* name;
    const char* successor;
    const char* maker;
  } cases[] = {{"BK7", "schott:N-BK7", "Schott"}, {"k9l", "cdgm:H-K9L", "CDGM"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    optics::GlassSpec spec;
    spec.name = c.name;
    spec.loc = FileLoc{"lens.zmx", 12, 5};
    spec.model_needs_option = true;
    std::vector<Diagnostic> d;
    const optics::Glass g = optics::resolveGlass(spec, 1.5, &d);
    EXPECT_EQ(g.describe(), c.successor);
    EXPECT_NEAR(g.n_d(), cat.find(c.successor)->glass.n_d(), 1e-15);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].severity, Severity::Warning);
    const std::string expected = fmt::format(
        "lens.zmx:12:5: warning: {} is {}'s old name; using {} (n_d {:.6f}, "
        "V_d {:.2f})",
        c.name, c.maker, c.successor, g.n_d(), cat.find(c.successor)->listed_v_d);
    EXPECT_NE(d[0].str().find(expected), std::string::npos) << d[0].str();
  }
  // BSC7, Hoya's current name for the type, is no one's old name: Hoya's glass, no warning.
  optics::GlassSpec bsc7;
  bsc7.name = "BSC7";
  std::vector<Diagnostic> d;
  EXPECT_EQ(optics::resolveGlass(bsc7, 1.5, &d).describe(), "hoya:BSC7");
  EXPECT_TRUE(d.empty());
}
