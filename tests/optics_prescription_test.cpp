#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "lensim/optics/prescription.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using lensim::test::dataPath;
using lensim::test::lensPath;

namespace {
std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
std::string replaceAll(std::string s, const std::string& from, const std::string& to) {
  for (size_t pos = 0; (pos = s.find(from, pos)) != std::string::npos; pos += to.size())
    s.replace(pos, from.size(), to);
  return s;
}
}  // namespace

TEST(LensPrescription, ReadsTheFourClassicLenses) {
  struct Expect {
    const char* file;
    size_t surfaces;
    int stop;
    double stop_diameter;
  } expect[] = {{"dgauss.50mm.dat", 11, 5, 17.1},
                {"fisheye.10mm.dat", 12, 6, 6.08},
                {"wide.22mm.dat", 13, 5, 8.756},
                {"telephoto.250mm.dat", 7, 3, 40.5}};
  for (const Expect& e : expect) {
    SCOPED_TRACE(e.file);
    LensPrescription p = readLensFile(lensPath(e.file));
    EXPECT_EQ(p.layout, LensFileLayout::Pbrt);
    ASSERT_EQ(p.surfaces.size(), e.surfaces);
    ASSERT_TRUE(p.stopIndex());
    EXPECT_EQ(*p.stopIndex(), e.stop);
    EXPECT_DOUBLE_EQ(p.surfaces[e.stop].aperture_diameter_mm, e.stop_diameter);
    EXPECT_EQ(p.surfaces[e.stop].ior, 1.0);  // index 0 means air
    EXPECT_EQ(p.fileFilmDistance_mm(), 0.0);
    EXPECT_TRUE(p.diagnostics.empty()) << formatDiagnostics(p.diagnostics);
  }
}

TEST(LensPrescription, RowsKeepTheirValuesAndLines) {
  LensPrescription p = readLensFile(lensPath("dgauss.50mm.dat"));
  EXPECT_EQ(p.name, "D-GAUSS F/2 22deg HFOV");
  const LensSurface& s = p.surfaces[3];
  EXPECT_DOUBLE_EQ(s.radius_mm, 40.77);
  EXPECT_DOUBLE_EQ(s.thickness_mm, 3.275);
  EXPECT_DOUBLE_EQ(s.ior, 1.699);
  EXPECT_DOUBLE_EQ(s.aperture_diameter_mm, 23);
  EXPECT_EQ(s.loc.line, 9);  // five comment lines come first
}

TEST(LensPrescription, LineEndingsDoNotMatter) {
  const std::string crlf = slurp(lensPath("wide.22mm.dat"));
  ASSERT_NE(crlf.find("\r\n"), std::string::npos);
  const std::string lf = replaceAll(crlf, "\r\n", "\n");
  const std::string cr = replaceAll(crlf, "\r\n", "\r");
  std::string no_final = lf;
  no_final.pop_back();
  LensPrescription a = parseLensPrescription(crlf, "a.dat");
  for (const std::string& text : {lf, cr, no_final}) {
    LensPrescription b = parseLensPrescription(text, "b.dat");
    ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
    for (size_t i = 0; i < a.surfaces.size(); ++i) {
      EXPECT_EQ(a.surfaces[i].radius_mm, b.surfaces[i].radius_mm);
      EXPECT_EQ(a.surfaces[i].thickness_mm, b.surfaces[i].thickness_mm);
      EXPECT_EQ(a.surfaces[i].loc.line, b.surfaces[i].loc.line);
    }
  }
}

TEST(LensPrescription, ReadsIsetLayoutWithFocalLengthLine) {
  LensPrescription p = readLensFile(lensPath("isetcam/dgauss.22deg.50.0mm.dat"));
  EXPECT_EQ(p.layout, LensFileLayout::Iset);
  ASSERT_TRUE(p.nominal_focal_length_mm);
  EXPECT_DOUBLE_EQ(*p.nominal_focal_length_mm, 50.0);
  EXPECT_EQ(p.surfaces.size(), 11u);
  EXPECT_EQ(p.name, "dgauss.22deg.50mm");

  // Stop as the last row, N = 1 for the stop, no final newline.
  LensPrescription r = readLensFile(lensPath("isetcam/reversed.telephoto.37deg.100mm.dat"));
  EXPECT_EQ(r.layout, LensFileLayout::Iset);
  EXPECT_DOUBLE_EQ(*r.nominal_focal_length_mm, 100.0);
  ASSERT_TRUE(r.stopIndex());
  EXPECT_EQ(*r.stopIndex(), static_cast<int>(r.surfaces.size()) - 1);
}

TEST(LensPrescription, ReadsAllIsetLenses) {
  for (const char* f :
       {"dgauss.22deg.50.0mm.dat", "fisheye.87deg.50.0mm.dat", "petzval.12deg.50.0mm.dat",
        "reversed.telephoto.37deg.100mm.dat", "tessar.22deg.50.0mm.dat", "wide.40deg.50.0mm.dat",
        "wide.56deg.50.0mm.dat"}) {
    SCOPED_TRACE(f);
    EXPECT_NO_THROW(readLensFile(lensPath(std::string("isetcam/") + f)));
  }
}

TEST(LensPrescription, AxposLayoutEqualsScaledPbrtLayout) {
  // The 100 mm axpos tables are the 50 mm tables (dgauss) scaled by 2, shifted by one row.
  LensPrescription a = readLensFile(lensPath("axpos/dgauss.dat"));
  LensPrescription b = readLensFile(lensPath("dgauss.50mm.dat"));
  EXPECT_EQ(a.layout, LensFileLayout::Axpos);
  ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
  for (size_t i = 0; i < a.surfaces.size(); ++i) {
    EXPECT_NEAR(a.surfaces[i].radius_mm, 2 * b.surfaces[i].radius_mm, 1e-9);
    EXPECT_NEAR(a.surfaces[i].thickness_mm, 2 * b.surfaces[i].thickness_mm, 0.011);
    EXPECT_EQ(a.surfaces[i].ior, b.surfaces[i].ior);
  }
  ASSERT_FALSE(a.diagnostics.empty());
  EXPECT_EQ(a.diagnostics[0].severity, Severity::Note);
}

TEST(LensPrescription, CrossingSurfacesGiveAWarningWithBothLocations) {
  LensPrescription p = readLensFile(lensPath("isetcam/fisheye.87deg.50.0mm.dat"));
  ASSERT_FALSE(p.diagnostics.empty());
  const Diagnostic& d = p.diagnostics[0];
  EXPECT_EQ(d.severity, Severity::Warning);
  EXPECT_NE(d.message.find("crosses the previous one"), std::string::npos) << d.str();
  // Both rows are named: the diagnostic's own location and the previous row's in the text.
  EXPECT_GT(d.loc.line, 0);
  EXPECT_NE(d.message.find(p.path + ":" + std::to_string(d.loc.line - 1)), std::string::npos)
      << d.str();

  // A made-up pair that crosses in the middle: a thin meniscus whose back bulges forward.
  LensPrescription q =
      parseLensPrescription("50 0.5 1.5 30\n-20 10 1 30\n0 5 0 10\n-50 2 1.5 20\n", "x.dat");
  ASSERT_EQ(q.diagnostics.size(), 1u);
  EXPECT_EQ(q.diagnostics[0].loc.line, 2);
}

TEST(LensPrescription, NoStopIsValid) {
  LensPrescription p = parseLensPrescription("50 5 1.5 20\n-50 40 1 20\n", "single.dat");
  EXPECT_FALSE(p.stopIndex());
  EXPECT_EQ(p.fileFilmDistance_mm(), 40.0);
}

TEST(LensPrescription, AcceptsCommentsTabsAndTrailingComments) {
  LensPrescription p =
      parseLensPrescription("# name here\n\t50\t5  1.5\t20 # first\n\n-50 40 0 20\n", "c.dat");
  EXPECT_EQ(p.name, "name here");
  ASSERT_EQ(p.surfaces.size(), 2u);
  EXPECT_EQ(p.surfaces[1].ior, 1.0);
  EXPECT_EQ(p.surfaces[1].loc.line, 4);
}

// Every file of the malformed corpus gives its error at the expected place.
TEST(LensPrescription, MalformedCorpusGivesLocatedErrors) {
  std::ifstream manifest(dataPath("bad_lenses/expected.txt"));
  ASSERT_TRUE(manifest) << "missing manifest";
  std::string line;
  int count = 0;
  while (std::getline(manifest, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string file, l, c, msg;
    std::getline(ss, file, '|');
    std::getline(ss, l, '|');
    std::getline(ss, c, '|');
    std::getline(ss, msg);
    auto trim = [](std::string s) {
      s.erase(0, s.find_first_not_of(' '));
      s.erase(s.find_last_not_of(' ') + 1);
      return s;
    };
    file = trim(file);
    msg = trim(msg);
    const std::string path = dataPath("bad_lenses/" + file);
    SCOPED_TRACE(file);
    ++count;
    try {
      readLensFile(path);
      ADD_FAILURE() << "no error for " << file;
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().file, path);
      EXPECT_EQ(e.loc().line, std::stoi(l)) << e.what();
      EXPECT_EQ(e.loc().column, std::stoi(c)) << e.what();
      EXPECT_NE(e.message().find(msg), std::string::npos) << e.what();
      const std::string prefix = path + ":" + trim(l) + ":";
      EXPECT_EQ(std::string(e.what()).rfind(prefix, 0), 0u) << e.what();
    }
  }
  EXPECT_GE(count, 14);
}

TEST(LensPrescription, MissingFileIsAnError) {
  EXPECT_THROW(readLensFile(dataPath("no/such/lens.dat")), Error);
}
