// The workbench with glasses (issue 10): `lens info` elements and --wavelength, --glass-match,
// the chromatic plots, spots and drawings per wavelength, the scene's glassmatch, and errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "lensim/optics/glass.h"
#include "test_paths.h"

using namespace lensim;
using lensim::test::lensPath;
using lensim::test::runLensim;
using nlohmann::json;

namespace {

json jsonOf(const test::CliResult& r) {
  // The JSON object is the last thing printed (notes and warnings go first, on stderr).
  const size_t b = r.out.find("{\n");
  EXPECT_NE(b, std::string::npos) << r.out;
  const size_t e = r.out.rfind("}");
  return json::parse(r.out.substr(b, e - b + 1));
}

std::string tempFile(const std::string& name, const std::string& text) {
  const std::string path = std::string(::testing::TempDir()) + name;
  std::ofstream(path) << text;
  return path;
}

const std::string kLandscape = lensPath("landscape.sf66.dat");

}  // namespace

TEST(LensGlassCli, InfoListsElementsWithTheirGlass) {
  const auto r = runLensim("lens info " + kLandscape + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = jsonOf(r);
  EXPECT_NEAR(j["wavelength_nm"].get<double>(), optics::kLineD_nm, 1e-9);
  EXPECT_TRUE(j["dispersive"].get<bool>());
  ASSERT_EQ(j["elements"].size(), 1u);
  const json& e = j["elements"][0];
  EXPECT_EQ(e["glass"], "schott:N-SF66");
  EXPECT_EQ(e["kind"], "catalogue");
  EXPECT_NEAR(e["n_d"].get<double>(), 1.92286, 1e-5);
  EXPECT_NEAR(e["v_d"].get<double>(), 20.88, 1e-2);
  const auto text = runLensim("lens info " + kLandscape);
  EXPECT_NE(text.out.find("schott:N-SF66"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("focus solved at the primary wavelength"), std::string::npos);
}

TEST(LensGlassCli, WavelengthChangesIndicesNotFocus) {
  const json d = jsonOf(runLensim("lens info " + kLandscape + " --json"));
  const json f = jsonOf(runLensim("lens info " + kLandscape + " --json --wavelength 486.1327"));
  const double nF = optics::GlassCatalog::builtin().find("N-SF66")->glass.index(486.1327);
  EXPECT_NEAR(f["elements"][0]["n"].get<double>(), nF, 1e-12);
  EXPECT_NEAR(f["wavelength_nm"].get<double>(), 486.1327, 1e-12);
  // Shorter focal length in the blue, the film where the d line focused it.
  EXPECT_LT(f["effective_focal_length_mm"].get<double>(),
            d["effective_focal_length_mm"].get<double>() - 0.3);
  EXPECT_EQ(f["film_distance_mm"].get<double>(), d["film_distance_mm"].get<double>());
  // The trace reports its wavelength too.
  const json t = jsonOf(
      runLensim("lens trace " + kLandscape + " --film 0,0 --rear 1,0 --wavelength 450 --json"));
  EXPECT_EQ(t["wavelength_nm"].get<double>(), 450);
  // A non-dispersive lens ignores the wavelength.
  const json a = jsonOf(runLensim("lens info " + lensPath("dgauss.50mm.dat") + " --json"));
  const json b =
      jsonOf(runLensim("lens info " + lensPath("dgauss.50mm.dat") + " --json --wavelength 450"));
  EXPECT_EQ(a["effective_focal_length_mm"], b["effective_focal_length_mm"]);
  EXPECT_FALSE(a["dispersive"].get<bool>());
}

TEST(LensGlassCli, GlassMatchPrintsItsChoices) {
  const auto r = runLensim("lens info " + lensPath("dgauss.50mm.dat") + " --glass-match --json");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("glass match"), std::string::npos) << r.out;
  const json j = jsonOf(r);
  EXPECT_TRUE(j["dispersive"].get<bool>());
  ASSERT_EQ(j["elements"].size(), 6u);
  for (const json& e : j["elements"])
    EXPECT_EQ(e["glass"].get<std::string>().rfind("schott:", 0), 0u);
}

TEST(LensGlassCli, ChromaticAndLateralColourPlots) {
  const std::string svg = std::string(::testing::TempDir()) + "plot.svg";
  const auto c = runLensim("lens plot chromatic " + kLandscape + " -o " + svg + " --json");
  ASSERT_EQ(c.status, 0) << c.out;
  const json cj = jsonOf(c);
  EXPECT_EQ(cj["wavelength_nm"].size(), 31u);
  EXPECT_EQ(cj["wavelength_nm"][0].get<double>(), 400);
  EXPECT_EQ(cj["wavelength_nm"][30].get<double>(), 700);
  // A positive singlet focuses the blue nearer: about -f/V_d between F and C.
  EXPECT_LT(cj["paraxial_f_minus_c_mm"].get<double>(), -1.0);
  const auto l = runLensim("lens plot lateral-color " + kLandscape + " -o " + svg + " --json");
  ASSERT_EQ(l.status, 0) << l.out;
  const json lj = jsonOf(l);
  EXPECT_EQ(lj["short_minus_primary_mm"][0].get<double>(), 0);
  EXPECT_LT(lj["short_minus_primary_mm"].back().get<double>(), -0.1);
  EXPECT_GT(lj["long_minus_primary_mm"].back().get<double>(), 0.05);
}

TEST(LensGlassCli, SpotsAndDrawingsPerWavelength) {
  const std::string svg = std::string(::testing::TempDir()) + "spots.svg";
  const auto s = runLensim("lens plot spot " + kLandscape +
                           " --wavelengths 486.1,587.6,656.3 --fields 0,1 -o " + svg + " --json");
  ASSERT_EQ(s.status, 0) << s.out;
  const json j = jsonOf(s);
  ASSERT_EQ(j["fields"].size(), 2u);
  const json& edge = j["fields"][1]["wavelengths"];
  ASSERT_EQ(edge.size(), 3u);
  // Lateral colour: the blue spot's centroid lies nearer the axis than the red one's.
  EXPECT_LT(edge[0]["centroid_mm"][0].get<double>(), edge[2]["centroid_mm"][0].get<double>() - 0.1);
  const std::string dsvg = std::string(::testing::TempDir()) + "draw.svg";
  const auto d = runLensim("lens draw " + kLandscape + " --wavelengths 450,650 -o " + dsvg);
  ASSERT_EQ(d.status, 0) << d.out;
  std::ifstream in(dsvg);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("wavelengths 450.0, 650.0 nm"), std::string::npos);
}

TEST(LensGlassCli, ErrorsAreLocatedAndExitOne) {
  const std::string bad =
      tempFile("badglass.dat", "0 12 0 5\n-40 5 1.9 22 - N-SF666\n-18 0 0 26\n");
  const auto r = runLensim("lens info " + bad);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find(bad + ":2:16: error: unknown glass 'N-SF666'; did you mean schott:N-SF66"),
            std::string::npos)
      << r.out;
  const std::string badvd = tempFile("badvd.dat", "0 12 0 5\n-40 5 1.9 22 -3\n-18 0 0 26\n");
  const auto v = runLensim("lens info " + badvd);
  EXPECT_EQ(v.status, 1);
  EXPECT_NE(v.out.find(badvd + ":2:14: error: Abbe number V_d -3 must be > 0"), std::string::npos)
      << v.out;
  const auto w = runLensim("lens info " + kLandscape + " --wavelength 50");
  EXPECT_EQ(w.status, 1);
  EXPECT_NE(w.out.find("--wavelength"), std::string::npos) << w.out;
  // Outside a formula's valid range (Schott's AGF: N-SF66 390-2500 nm): an error; with
  // --glass-extrapolate a warning, and the formula is used.
  const auto e = runLensim("lens info " + kLandscape + " --wavelength 350");
  EXPECT_EQ(e.status, 1) << e.out;
  EXPECT_NE(e.out.find("error: --wavelength 350 nm is outside the valid range of schott:N-SF66 "
                       "(390-2500 nm"),
            std::string::npos)
      << e.out;
  const auto o = runLensim("lens info " + kLandscape + " --wavelength 350 --glass-extrapolate");
  EXPECT_EQ(o.status, 0) << o.out;
  EXPECT_NE(o.out.find("outside the valid range"), std::string::npos) << o.out;
}

TEST(LensGlassCli, SceneGlassMatchMakesTheCameraDisperse) {
  const std::string scene = tempFile("gm.pbrt", R"(LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" ")" + lensPath("dgauss.50mm.dat") +
                                                    R"(" "float aperturediameter" 10
  "float focusdistance" 3 "bool glassmatch" true
Film "rgb" "integer xresolution" 16 "integer yresolution" 16
Sampler "independent" "integer pixelsamples" 4
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
)");
  const std::string out = std::string(::testing::TempDir()) + "gm.exr";
  const auto r = runLensim("render " + scene + " -o " + out + " --stats");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("glass match"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dispersive (focused at 587.56 nm"), std::string::npos) << r.out;
}
