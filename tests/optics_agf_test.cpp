// Zemax AGF glass catalogues (issue 28): the reader, every dispersion formula number against the
// formula written out here, the built-in catalogues against the makers' published data sheets,
// encodings, the glass library's search order (GCAT, user catalogues) and refusals.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

#include "lensim/optics/glass.h"
#include "lensim/optics/glass/agf.h"
#include "lensim/optics/glass/library.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// A folder of this test process's own: ctest runs the tests of this file as parallel processes.
std::filesystem::path tempDir() {
  return std::filesystem::temp_directory_path() /
         ("lensim_agf_test-" + std::to_string(::getpid()));
}

std::string tempFile(const std::string& name, const std::string& bytes) {
  const auto dir = tempDir();
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

// UTF-16 with a byte-order mark, from ASCII/Latin-1 text.
std::string utf16(const std::string& latin1, bool little) {
  std::string out = little ? "\xFF\xFE" : "\xFE\xFF";
  for (char c : latin1) {
    const char hi = 0, lo = c;
    out += little ? lo : hi;
    out += little ? hi : lo;
  }
  return out;
}

}  // namespace

// The makers' data sheets (n_d to 5 decimals, V_d to 2): Schott N-BK7, F2, N-SF6, SF11 (SCHOTT
// optical glass data sheets); Ohara S-BSL7, S-TIH6, S-LAH64 (OHARA catalogue); CDGM H-K9L (CDGM
// catalogue); Hoya BSC7 (HOYA catalogue). N-BK7's sheet also lists n_F 1.52238, n_C 1.51432,
// n_g 1.52668 (435.8343 nm), n_i 1.53627 (365.0146 nm).
TEST(AgfCatalogs, DataSheetValues) {
  struct Sheet {
    const char* name;
    double n_d, v_d;
  };
  const Sheet sheets[] = {{"schott:N-BK7", 1.51680, 64.17}, {"schott:F2", 1.62004, 36.37},
                          {"schott:N-SF6", 1.80518, 25.36}, {"schott:SF11", 1.78472, 25.76},
                          {"ohara:S-BSL7", 1.51633, 64.14}, {"ohara:S-TIH6", 1.80518, 25.42},
                          {"ohara:S-LAH64", 1.78800, 47.37}, {"cdgm:H-K9L", 1.51680, 64.20},
                          {"hoya:BSC7", 1.51680, 64.20}};
  for (const Sheet& s : sheets) {
    SCOPED_TRACE(s.name);
    const CatalogGlass* g = GlassCatalog::builtin().find(s.name);
    ASSERT_NE(g, nullptr);
    EXPECT_EQ(g->glass.kind(), std::string("catalogue"));
    EXPECT_NEAR(g->glass.n_d(), s.n_d, 1e-5);
    EXPECT_NEAR(g->glass.v_d(), s.v_d, 0.01);
  }
  const Glass& bk7 = GlassCatalog::builtin().find("N-BK7")->glass;
  EXPECT_EQ(GlassCatalog::builtin().find("N-BK7")->catalog, "schott");
  EXPECT_EQ(bk7.formulaName(), "Sellmeier 1");
  EXPECT_NEAR(bk7.index(kLineF_nm), 1.52238, 1e-5);
  EXPECT_NEAR(bk7.index(kLineC_nm), 1.51432, 1e-5);
  EXPECT_NEAR(bk7.index(435.8343), 1.52668, 1e-5);
  EXPECT_NEAR(bk7.index(365.0146), 1.53627, 1e-5);
  EXPECT_DOUBLE_EQ(bk7.minWavelength_nm(), 300);  // LD 0.3 2.5
  EXPECT_DOUBLE_EQ(bk7.maxWavelength_nm(), 2500);
}

// Decimals a listed value is written to (the shortest form of the double, as the file wrote it).
static int decimals(double v) {
  const std::string s = fmt::format("{}", v);
  const size_t dot = s.find('.');
  return dot == std::string::npos ? 0 : int(s.size() - dot - 1);
}

// Every built-in AGF glass whose valid range covers F..C reproduces its listed n_d and V_d from
// its formula, to the last digit the catalogue lists (half a unit of it, plus 1e-6 for n_d and
// 0.01 for V_d: the makers round V_d from unrounded indices). The glasses whose formula does not
// give their listed n_d at all (by 1e-3: a CD line of zeros, as Liebetraut's liquids and LZOS's
// "new glass"; infrared and birefringent crystals whose listed n_d is not their formula's) are
// marked unusable (refused when a lens names them), and must stay those few.
TEST(AgfCatalogs, EveryGlassReproducesItsListedData) {
  int checked = 0, off = 0, unusable = 0, cdgm_fits = 0;
  for (const CatalogGlass& g : GlassCatalog::builtin().glasses()) {
    if (g.catalog == "csv") continue;
    if (!g.problem.empty()) {
      ++unusable;
      EXPECT_TRUE(g.catalog == "liebetraut" || g.catalog == "lzos" || g.catalog == "infrared" ||
                  g.catalog == "birefringent")
          << g.qualifiedName() << ": " << g.problem;
      continue;
    }
    if (!(g.glass.minWavelength_nm() <= kLineF_nm && g.glass.maxWavelength_nm() >= kLineC_nm))
      continue;
    ++checked;
    const double nd = g.glass.n_d(), vd = g.glass.v_d();
    double tol_n = 0.5 * std::pow(10.0, -decimals(g.listed_n_d)) + 1e-6;
    double tol_v = 0.5 * std::pow(10.0, -decimals(g.listed_v_d)) + 0.01;
    // CDGM's and Sumita's AGF files give formula fits that reproduce n_d to 5e-5 but miss the
    // listed V_d by up to 0.09 (CDGM) and 0.15 (Sumita's moulding glasses); where the maker's
    // spreadsheet agrees with its listing, lensim uses the spreadsheet's formula instead.
    if (g.catalog == "cdgm" || g.catalog == "sumita" || g.catalog == "zeon") {
      ++cdgm_fits;
      tol_n = 5e-5, tol_v = std::max(tol_v, 0.2);
    }
    // A listed V_d of 0: a material without dispersion data (n constant).
    const bool ok = std::abs(nd - g.listed_n_d) <= tol_n &&
                    (g.listed_v_d == 0 ? !std::isfinite(vd) : std::abs(vd - g.listed_v_d) <= tol_v);
    if (!ok && off++ < 20)
      ADD_FAILURE() << g.qualifiedName() << " (" << g.glass.formulaName() << "): n_d " << nd
                    << " listed " << g.listed_n_d << ", V_d " << vd << " listed " << g.listed_v_d;
  }
  EXPECT_GT(checked, 2000);
  EXPECT_EQ(off, 0);
  EXPECT_LE(unusable, 19);
  EXPECT_LT(cdgm_fits, 600);
}

// Each Zemax formula number, parsed from an AGF CD line and evaluated by lensim, against the
// formula as the OpticStudio manual writes it, evaluated here (lambda in micrometres).
TEST(AgfFormulas, EveryFormulaNumberMatchesItsDefinition) {
  const double c[10] = {1.1, 0.0123, 0.45, 0.034, 0.71, 95.0, 0.05, 0.0021, 0.0003, 0.5};
  auto expected = [](int f, const double* k, double l) {
    const double l2 = l * l;
    switch (f) {
      case 1:
        return std::sqrt(k[0] + k[1] * l2 + k[2] / l2 + k[3] / std::pow(l, 4) +
                         k[4] / std::pow(l, 6) + k[5] / std::pow(l, 8));
      case 2:
        return std::sqrt(1 + k[0] * l2 / (l2 - k[1]) + k[2] * l2 / (l2 - k[3]) +
                         k[4] * l2 / (l2 - k[5]));
      case 3: {
        const double L = 1 / (l2 - 0.028);
        return k[0] + k[1] * L + k[2] * L * L + k[3] * l2 + k[4] * std::pow(l, 4) +
               k[5] * std::pow(l, 6);
      }
      case 4:
        return std::sqrt(1 + k[0] + k[1] * l2 / (l2 - k[2] * k[2]) + k[3] / (l2 - k[4] * k[4]));
      case 5:
        return k[0] + k[1] / l + k[2] / std::pow(l, 3.5);
      case 6:
        return std::sqrt(1 + k[0] * l2 / (l2 - k[1]) + k[2] * l2 / (l2 - k[3]) +
                         k[4] * l2 / (l2 - k[5]) + k[6] * l2 / (l2 - k[7]));
      case 7:
        return std::sqrt(k[0] + k[1] / (l2 - k[2]) - k[3] * l2);
      case 8:
        return std::sqrt(k[0] + k[1] * l2 / (l2 - k[2]) - k[3] * l2);
      case 9:
        return std::sqrt(k[0] + k[1] * l2 / (l2 - k[2]) + k[3] * l2 / (l2 - k[4]));
      case 10:
        return std::sqrt(k[0] + k[1] * l2 + k[2] / l2 + k[3] / std::pow(l, 4) +
                         k[4] / std::pow(l, 6) + k[5] / std::pow(l, 8) + k[6] / std::pow(l, 10) +
                         k[7] / std::pow(l, 12));
      case 11:
        return std::sqrt(1 + k[0] * l2 / (l2 - k[1]) + k[2] * l2 / (l2 - k[3]) +
                         k[4] * l2 / (l2 - k[5]) + k[6] * l2 / (l2 - k[7]) +
                         k[8] * l2 / (l2 - k[9]));
      case 12:
        return std::sqrt(k[0] + k[1] * l2 + k[2] / l2 + k[3] / std::pow(l, 4) +
                         k[4] / std::pow(l, 6) + k[5] / std::pow(l, 8) + k[6] * std::pow(l, 4) +
                         k[7] * std::pow(l, 6));
      case 13:
        return std::sqrt(k[0] + k[1] * l2 + k[2] * std::pow(l, 4) + k[3] / l2 +
                         k[4] / std::pow(l, 4) + k[5] / std::pow(l, 6) + k[6] / std::pow(l, 8) +
                         k[7] / std::pow(l, 10) + k[8] / std::pow(l, 12));
    }
    return 0.0;
  };
  for (int f = 1; f <= 13; ++f) {
    SCOPED_TRACE(fmt::format("formula {} ({})", f, zemaxFormulaName(f)));
    // a0 / A / n0 of the series formulas: 2.2 (n^2) or 1.1 (n); Herzberger's F scaled down.
    double cd[10];
    std::copy(std::begin(c), std::end(c), cd);
    if (f == 1 || f == 7 || f == 8 || f == 9 || f == 10 || f == 12 || f == 13) cd[0] = 2.2;
    if (f == 3) cd[5] = c[5] * 1e-6;
    if (f == 4) cd[4] = 0.1;  // lambda_2 of Sellmeier 2 below the wavelengths used
    std::string line = "CD";
    for (double v : cd) line += fmt::format(" {:.17g}", v);
    const std::string agf = fmt::format("NM TEST {} 0 1.5 50 0 0 0\n{}\nLD 0.3 2.5\n", f, line);
    const std::vector<AgfGlass> gs = parseAgf(agf, "test.agf");
    ASSERT_EQ(gs.size(), 1u);
    const GlassCatalog cat = GlassCatalog::fromAgf(agf, "test.agf", "test", "Test");
    const Glass& g = cat.glasses()[0].glass;
    EXPECT_EQ(g.formulaName(), zemaxFormulaName(f));
    for (double l : {0.4, 0.5876, 0.7, 1.0}) {
      const double want = expected(f, cd, l);
      ASSERT_TRUE(std::isfinite(want)) << l;
      EXPECT_NEAR(g.index(l * 1000), want, 1e-13 * want) << l;
    }
  }
  EXPECT_NE(errorOf([] { parseAgf("NM X 14 0 1.5 50 0 0\n", "bad.agf"); })
                .find("bad.agf:1:6: error: glass 'X': dispersion formula 14 is not one Zemax "
                      "defines"),
            std::string::npos);
}

// Encodings: the same catalogue as ASCII with LF, CRLF, CR and mixed line ends, UTF-16 LE and BE
// with a byte-order mark, and Latin-1 comments, reads the same; a CD line wrapped onto a second
// line (Nikon's catalogue) is one line.
TEST(AgfReader, EncodingsAndLineEnds) {
  const std::string body =
      "CC Cat\xe9logue (Latin-1)\n"
      "NM N-BK7 2 517642.251 1.5168 64.17 0 1\n"
      "GC step 0.5 available\n"
      "CD 1.039612120E+00 6.000698670E-03 2.317923440E-01\n"
      "2.001791440E-02 1.010469450E+00 1.035606530E+02 0.0 0.0\n"
      "LD 3.00000E-01 2.50000E+00\n"
      "IT 4.00000E-01 9.97000E-01 2.50000E+01\n"
      "NM OLD-1 2 0 1.5 60 0 2\n"
      "CD 1.0 0.01 0.2 0.02 1.0 100.0\n";
  auto with = [&](const std::string& eol) {
    std::string s;
    for (char c : body) s += c == '\n' ? eol : std::string(1, c);
    return s;
  };
  std::string mixed;
  int k = 0;
  for (char c : body) {
    if (c == '\n') {
      const char* ends[] = {"\r\n", "\n", "\r"};
      mixed += ends[k++ % 3];
    } else {
      mixed += c;
    }
  }
  const std::vector<std::string> variants = {with("\n"), with("\r\n"), with("\r"), mixed,
                                             utf16(with("\r\n"), true),
                                             utf16(with("\n"), false)};
  for (size_t v = 0; v < variants.size(); ++v) {
    SCOPED_TRACE(v);
    const std::vector<AgfGlass> gs = parseAgf(variants[v], "enc.agf");
    ASSERT_EQ(gs.size(), 2u);
    EXPECT_EQ(gs[0].name, "N-BK7");
    EXPECT_EQ(gs[0].formula, 2);
    EXPECT_EQ(gs[0].status, 1);
    EXPECT_DOUBLE_EQ(gs[0].coefficients[5], 103.560653);
    EXPECT_DOUBLE_EQ(gs[0].min_um, 0.3);
    ASSERT_EQ(gs[0].transmittance.size(), 1u);
    EXPECT_EQ(gs[0].loc.line, 2);
    EXPECT_EQ(gs[1].loc.line, 8);
    EXPECT_EQ(agfStatusName(gs[1].status), "obsolete");
  }
  // Latin-1 becomes UTF-8; UTF-8 stays.
  EXPECT_EQ(decodeTextFile("Cat\xe9", "x"), "Cat\xc3\xa9");
  EXPECT_EQ(decodeTextFile("Cat\xc3\xa9", "x"), "Cat\xc3\xa9");
  EXPECT_NE(errorOf([] { decodeTextFile("\xFF\xFE\x41", "odd.agf"); }).find("odd number of bytes"),
            std::string::npos);
}

TEST(AgfReader, MalformedLinesAreErrorsAtLineAndColumn) {
  auto err = [](const std::string& text) {
    return errorOf([&] { parseAgf(text, "m.agf"); });
  };
  EXPECT_NE(err("NM A 2 0 1.5 50 0 0\nCD 1 2 x3 4 5 6\n").find("m.agf:2:8: error: CD coefficient: "
                                                              "expected a number, found 'x3'"),
            std::string::npos);
  EXPECT_NE(err("NM A 2 0 1.5\n").find("m.agf:1:1: error: NM line"), std::string::npos);
  EXPECT_NE(err("CD 1 2 3\n").find("m.agf:1:1: error: CD line before any NM"), std::string::npos);
  EXPECT_NE(err("NM A 2 0 1.5 50 0 0\nCD 1 2 3\n").find("needs 6 CD coefficients, found 3"),
            std::string::npos);
  EXPECT_NE(err("NM A 2 0 1.5 50 0 0\nLD 0.7 0.4\n").find("m.agf:2:4: error: glass 'A': "
                                                         "wavelength range 0.7-0.4 um is empty"),
            std::string::npos);
  // IT rows without a usable transmittance (as in the makers' files) are skipped, and counted.
  const std::vector<AgfGlass> it =
      parseAgf("NM A 2 0 1.5 50 0 0\nIT 0.4 1.2 10\nIT 0.29 25\nIT 0.4 0.9 0\nIT 0.5 0.9 10\n", "m.agf");
  EXPECT_EQ(it[0].transmittance.size(), 1u);
  EXPECT_EQ(it[0].skipped_transmittance_rows, 3);
  EXPECT_NE(err("NM A 2 0 1.5 50 0 0\nIT 0.4 x 10\n").find("m.agf:2:8: error: IT value: expected a "
                                                          "number, found 'x'"),
            std::string::npos);
  EXPECT_NE(err("NM A 2 0 1.5 50 0 9\n").find("m.agf:1:19: error: glass 'A': status 9"),
            std::string::npos);
}

// IT rows: at a row's wavelength and thickness the transmittance is the row's; Beer-Lambert in
// thickness; between rows the absorption coefficient is interpolated linearly.
TEST(AgfReader, InternalTransmittance) {
  const GlassCatalog cat = GlassCatalog::fromAgf(
      "NM G 2 0 1.5 60 0 0\nCD 1.0 0.01 0.2 0.02 1.0 100.0\nLD 0.3 2.5\n"
      "IT 0.45 0.90 10\nIT 0.40 0.50 25\n",
      "it.agf", "it", "It");
  const Glass& g = cat.glasses()[0].glass;
  ASSERT_TRUE(g.hasTransmittance());
  EXPECT_NEAR(g.internalTransmittance(400, 25), 0.50, 1e-12);
  EXPECT_NEAR(g.internalTransmittance(450, 10), 0.90, 1e-12);
  EXPECT_NEAR(g.internalTransmittance(450, 20), 0.81, 1e-12);
  const double a400 = -std::log(0.5) / 25, a450 = -std::log(0.9) / 10;
  EXPECT_NEAR(g.internalTransmittance(425, 5), std::exp(-5 * (a400 + a450) / 2), 1e-12);
  EXPECT_NEAR(g.internalTransmittance(700, 10), 0.90, 1e-12);  // held beyond the last row
  EXPECT_EQ(g.internalTransmittance(400, 0), 1.0);
  // Schott's N-BK7 row: 0.971 at 365 nm through 25 mm.
  const Glass& bk7 = GlassCatalog::builtin().find("schott:N-BK7")->glass;
  EXPECT_NEAR(bk7.internalTransmittance(365, 25), 0.971, 1e-9);
}

TEST(AgfReader, WavelengthRangeRefusedUnlessAllowed) {
  const Glass& g = GlassCatalog::builtin().find("schott:N-BK7")->glass;
  setGlassExtrapolationAllowed(false);
  EXPECT_NO_THROW(checkGlassRange(g, 400, FileLoc{"l.zmx", 3, 6}, "--wavelength"));
  EXPECT_NE(errorOf([&] { checkGlassRange(g, 2600, FileLoc{"l.zmx", 3, 6}, "--wavelength"); })
                .find("l.zmx:3:6: error: --wavelength 2600 nm is outside the valid range of "
                      "schott:N-BK7 (300-2500 nm"),
            std::string::npos);
  setGlassExtrapolationAllowed(true);
  std::vector<Diagnostic> w;
  checkGlassRange(g, 2600, FileLoc{"l.zmx", 3, 6}, "--wavelength", &w);
  EXPECT_EQ(w.size(), 1u);
  setGlassExtrapolationAllowed(false);
}

namespace {

// A one-element lens in a .zmx file: GCAT line (if any), the element's glass on surface 1.
std::string zmxWithGlass(const std::string& gcat, const std::string& glas) {
  std::string s = "VERS 190513 80 123457 L123457\nMODE SEQ\nUNIT MM X W X CM MR CPMM\n"
                  "ENPD 10\nWAVM 1 0.5875618 1\n";
  if (!gcat.empty()) s += "GCAT " + gcat + "\n";
  s += "SURF 0\n  TYPE STANDARD\n  CURV 0.0\n  DISZ INFINITY\n"
       "SURF 1\n  STOP\n  TYPE STANDARD\n  CURV 0.02\n  DISZ 4\n  GLAS " + glas +
       "\n  DIAM 8 1\n"
       "SURF 2\n  TYPE STANDARD\n  CURV -0.02\n  DISZ 45\n  DIAM 8 1\n"
       "SURF 3\n  TYPE STANDARD\n  CURV 0.0\n  DISZ 0\n  DIAM 5 1\n";
  return s;
}

// The medium after the surface whose GLAS line names the glass.
Glass elementGlass(const std::string& zmx) {
  const LensPrescription p = parseZmx(zmx, "t.zmx");
  const std::vector<Glass> g = resolveGlasses(p);
  for (size_t i = 0; i < p.surfaces.size(); ++i)
    if (!p.surfaces[i].glass.name.empty() || p.surfaces[i].glass.v_d) return g[i];
  throw Error("no glass in the lens");
}

}  // namespace

// BAF3 is in CDGM's catalogue (n_d 1.57960) and Hikari's (1.58267): without GCAT the default
// order decides; GCAT puts its catalogues first, in its order.
TEST(GlassLibrary, GcatOrder) {
  // Hoya has a BAF3 too, and comes before CDGM and Hikari in the default order.
  EXPECT_EQ(elementGlass(zmxWithGlass("", "BAF3 0 0 1.5 50")).describe(), "hoya:BAF3");
  EXPECT_NEAR(elementGlass(zmxWithGlass("CDGM", "BAF3 0 0 1.5 50")).n_d(), 1.57960, 1e-5);
  EXPECT_EQ(elementGlass(zmxWithGlass("HIKARI CDGM", "BAF3 0 0 1.5 50")).describe(),
            "hikari:BAF3");
  EXPECT_NEAR(elementGlass(zmxWithGlass("HIKARI CDGM", "BAF3 0 0 1.5 50")).n_d(), 1.58267, 1e-5);
  EXPECT_EQ(elementGlass(zmxWithGlass("CDGM HIKARI", "BAF3 0 0 1.5 50")).describe(), "cdgm:BAF3");
  // A name only in a catalogue GCAT does not name is still found (the rest follow).
  EXPECT_EQ(elementGlass(zmxWithGlass("HIKARI", "S-LAH64 0 0 1.5 50")).describe(),
            "ohara:S-LAH64");
  // A GCAT catalogue lensim lacks: a warning at its column.
  const LensPrescription p = parseZmx(zmxWithGlass("SCHOTT NOSUCHCAT", "N-BK7"), "t.zmx");
  bool warned = false;
  for (const Diagnostic& d : p.diagnostics)
    warned = warned || (d.message.find("no glass catalogue 'NOSUCHCAT'") != std::string::npos &&
                        d.loc.line == 6 && d.loc.column == 13);
  EXPECT_TRUE(warned);
}

// A glass in no catalogue is refused at its GLAS line's name, with hints; --model-glass uses the
// file's n_d and V_d, reported as a model glass.
TEST(GlassLibrary, UnknownGlassRefusedUnlessModelGlass) {
  setModelGlassAllowed(false);
  // (BK7 itself is Schott's old name, mapped to N-BK7: glass_crystals_test.)
  const std::string zmx = zmxWithGlass("SCHOTT", "BK-7 0 0 1.5168 64.17");
  const std::string e = errorOf([&] { elementGlass(zmx); });
  EXPECT_NE(e.find("t.zmx:16:8: error: unknown glass 'BK-7'; did you mean schott:N-BK7"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("--model-glass"), std::string::npos);
  setModelGlassAllowed(true);
  const Glass g = elementGlass(zmx);
  EXPECT_EQ(g.kind(), std::string("model"));
  EXPECT_NEAR(g.n_d(), 1.5168, 1e-12);
  EXPECT_NEAR(g.v_d(), 64.17, 1e-9);
  setModelGlassAllowed(false);
}

// The issue's moulded glasses: RPO's L-TIM28_MOLD and LightPath's D-ZK3M are catalogue glasses
// now, with their catalogues' listed n_d and V_d (not the placeholder on a GLAS line).
TEST(GlassLibrary, MouldedGlassesFromTheIssue) {
  const CatalogGlass* tim = GlassCatalog::builtin().find("L-TIM28_MOLD");
  ASSERT_NE(tim, nullptr);
  EXPECT_EQ(tim->catalog, "rpo");
  EXPECT_NEAR(tim->glass.n_d(), 1.684030, 5e-6);
  EXPECT_NEAR(tim->glass.v_d(), 30.856565, 1e-3);
  const CatalogGlass* zk = GlassCatalog::builtin().find("D-ZK3M");
  ASSERT_NE(zk, nullptr);
  EXPECT_EQ(zk->catalog, "lightpath");
  EXPECT_NEAR(zk->glass.n_d(), 1.586420, 5e-6);
  EXPECT_NEAR(zk->glass.v_d(), 60.713872, 1e-3);
  // In a lens file whose GLAS line carries the placeholder 1.5: the catalogue's glass is used.
  EXPECT_NEAR(elementGlass(zmxWithGlass("RPO", "L-TIM28_MOLD 0 0 1.5 0")).n_d(), 1.684030, 5e-6);
}

// User catalogues come before the built-in ones; a file added twice counts once; a missing file
// is an error at the place that named it.
TEST(GlassLibrary, UserCatalogueFirst) {
  // Zeon's E48R exists built in; a user catalogue with another E48R wins.
  ASSERT_NE(GlassCatalog::builtin().find("E48R"), nullptr);
  const std::string path = tempFile("mine.agf",
                                    "NM E48R 2 0 1.59523 40 0 0\nCD 1.5 0.01 0 0 0 0\nLD 0.3 2.0\n"
                                    "NM MY-GLASS 2 0 1.59523 40 0 0\nCD 1.5 0.01 0 0 0 0\n");
  addGlassCatalogFile(path);
  addGlassCatalogFile(path);
  const GlassCatalog& lib = glassLibrary();
  EXPECT_EQ(lib.find("E48R")->catalog, "mine");
  EXPECT_EQ(lib.find("zeon:E48R")->catalog, "zeon");
  EXPECT_NE(lib.find("MY-GLASS"), nullptr);
  int mine = 0;
  for (const CatalogGlass& g : lib.glasses()) mine += g.catalog == "mine";
  EXPECT_EQ(mine, 2);
  const double l = 0.55, l2 = l * l;
  EXPECT_NEAR(elementGlass(zmxWithGlass("", "MY-GLASS")).index(550),
              std::sqrt(1 + 1.5 * l2 / (l2 - 0.01)), 1e-14);
  EXPECT_NE(errorOf([] { addGlassCatalogFile("/nonexistent/x.agf", FileLoc{"s.pbrt", 4, 9}); })
                .find("s.pbrt:4:9: error: glass catalogue '/nonexistent/x.agf': no such file"),
            std::string::npos);
  const std::string bad = tempFile("bad.agf", "NM A 2 0 1.5 50 0 0\nCD 1 2 x\n");
  EXPECT_NE(errorOf([&] { addGlassCatalogFile(bad); }).find("bad.agf:2:8: error:"),
            std::string::npos);
}

namespace {

struct ShellRun {
  int status;
  std::string out;
};

ShellRun runShell(const std::string& cmd) {
  const std::string out_path = tempFile("cli.out", "");
  const int rc = std::system((cmd + " > " + out_path + " 2>&1").c_str());
  std::ifstream in(out_path);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, ss.str()};
}

}  // namespace

// The command line: LENSIM_GLASS_PATH (a folder of .agf files), --glass-catalog before it,
// --model-glass, and lens info naming the glass used.
TEST(GlassLibrary, CommandLineAndEnvironment) {
  const std::string lens = tempFile("envlens.zmx", zmxWithGlass("", "ENV-GLASS 0 0 1.5 50"));
  const auto dir = tempDir() / "envcat";
  std::filesystem::create_directories(dir);
  std::ofstream((dir / "envcat.agf").string(), std::ios::binary)
      << "NM ENV-GLASS 2 0 1.59523 40 0 0\nCD 1.5 0.01 0 0 0 0\nLD 0.3 2.0\n";
  const std::string other = tempFile("first.agf",
                                     "NM ENV-GLASS 2 0 1.68929 40 0 0\nCD 1.8 0.01 0 0 0 0\n"
                                     "LD 0.3 2.0\n");
  const std::string bin = LENSIM_BINARY;
  const ShellRun refused = runShell(bin + " lens info " + lens);
  EXPECT_EQ(refused.status, 1) << refused.out;
  EXPECT_NE(refused.out.find("envlens.zmx:15:8: error: unknown glass 'ENV-GLASS'"),
            std::string::npos)
      << refused.out;
  const ShellRun model = runShell(bin + " lens info " + lens + " --model-glass");
  EXPECT_EQ(model.status, 0) << model.out;
  EXPECT_NE(model.out.find("model n_d 1.5 V_d 50 (Cauchy)"), std::string::npos) << model.out;
  const ShellRun env = runShell("LENSIM_GLASS_PATH=" + dir.string() + " " + bin + " lens info " + lens);
  EXPECT_EQ(env.status, 0) << env.out;
  EXPECT_NE(env.out.find("envcat:ENV-GLASS"), std::string::npos) << env.out;
  const ShellRun both = runShell("LENSIM_GLASS_PATH=" + dir.string() + " " + bin + " lens info " +
                            lens + " --glass-catalog " + other);
  EXPECT_EQ(both.status, 0) << both.out;
  EXPECT_NE(both.out.find("first:ENV-GLASS"), std::string::npos) << both.out;
}

// The scene's realistic camera: "string glasscatalog" adds a catalogue for its lens's glasses;
// a catalogue file that is not there is an error at that scene line.
TEST(GlassLibrary, SceneGlassCatalogue) {
  const std::string lens = tempFile("scenelens.zmx", zmxWithGlass("", "SCENE-GLASS"));
  const std::string cat = tempFile("scenecat.agf",
                                   "NM SCENE-GLASS 2 0 1.59523 40 0 0\nCD 1.5 0.01 0 0 0 0\n"
                                   "LD 0.3 2.0\n");
  auto scene = [&](const std::string& catalogue) {
    return tempFile("glass.pbrt", "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"realistic\" \"string "
                                  "lensfile\" \"" + lens + "\" \"float focusdistance\" 3\n"
                                  "  \"string glasscatalog\" \"" + catalogue + "\"\n"
                                  "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                                  "Sampler \"independent\" \"integer pixelsamples\" 1\n"
                                  "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n");
  };
  const std::string bin = LENSIM_BINARY;
  const std::string out = tempFile("glass.exr", "");
  const ShellRun ok = runShell(bin + " render " + scene(cat) + " -o " + out + " --quiet");
  EXPECT_EQ(ok.status, 0) << ok.out;
  const ShellRun missing =
      runShell(bin + " render " + scene("/nonexistent/none.agf") + " -o " + out + " --quiet");
  EXPECT_EQ(missing.status, 1) << missing.out;
  EXPECT_NE(missing.out.find("glass.pbrt:3:"), std::string::npos) << missing.out;
}
