// `lensim autofocus` through a lens that focuses by moving a group (docs/zoom.md): the film stays
// and the group moves as focusdistance moves it; the group position found by rendering a
// checkerboard plane matches the group position solved with real rays for the plane's distance,
// within the depth of focus expressed as group travel.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "test_paths.h"

namespace lensim {
namespace {

constexpr double kAperture_mm = 8;  // stop diameter (mm), below the one the file's ENPD gives
constexpr double kPlane_m = 1.0;    // the checkerboard's distance from the film
constexpr int kXRes = 200, kYRes = 150;

TEST(AutofocusGroup, MovesTheGroupToThePlane) {
  const std::string lens = test::dataPath("lenses/tessar_inner_focus.zmx");
  const std::string dir = ::testing::TempDir();
  const std::string scene = dir + "/af_group.pbrt", zones = dir + "/af_group_zones.txt";
  {
    std::ofstream f(scene);
    f << "Camera \"realistic\" \"string lensfile\" \"" << lens << "\" \"float aperturediameter\" "
      << kAperture_mm << " \"float focusdistance\" 10 \"string focusmethod\" \"exact\"\n"
      << "Film \"rgb\" \"integer xresolution\" " << kXRes << " \"integer yresolution\" " << kYRes
      << " \"float diagonal\" 35\n"
      << "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n"
      << "Texture \"checks\" \"spectrum\" \"checkerboard\" \"float uscale\" 100 \"float vscale\" "
         "100\n"
      << "  \"rgb tex1\" [0.9 0.9 0.9] \"rgb tex2\" [0.1 0.1 0.1]\n"
      << "Material \"diffuse\" \"texture reflectance\" \"checks\"\n"
      << "Shape \"bilinearmesh\" \"point3 P\" [-1 -1 " << kPlane_m << "  1 -1 " << kPlane_m
      << "  -1 1 " << kPlane_m << "  1 1 " << kPlane_m << "]\n"
      << "  \"point2 uv\" [0 0 1 0 0 1 1 1]\n";
    std::ofstream z(zones);
    z << "# centre\n0.45 0.55 0.43 0.57\n";
  }
  const test::CliResult r = test::runLensim("autofocus --json --spp 4 --threads 2 --zones " +
                                            zones + " " + scene + " 2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  ASSERT_TRUE(j["group_focusing"].get<bool>()) << r.out;
  ASSERT_TRUE(j["group_travel_mm"].is_number()) << r.out;
  const double travel = j["group_travel_mm"].get<double>();

  // The group position real rays give for the plane's true distance, on the film the rest
  // position's real-ray infinity focus places.
  const optics::LensPrescription p = optics::readLensFile(lens);
  optics::LensSetup setup;
  setup.aperture_diameter_mm = kAperture_mm;
  setup.focus_method = optics::FocusMethod::Exact;
  const optics::GroupFocus want = optics::focusByGroup(p, setup, kPlane_m);
  // The film stays: the camera's film is the rest position's (front vertex to film fixed).
  setup.focus_distance_m = std::numeric_limits<double>::infinity();
  const optics::FocusedLens rest = optics::focusLens(p, setup);
  const double moved_thickness = j["moved_thickness_mm"]["1"].get<double>();
  EXPECT_NEAR(moved_thickness - p.surfaces[1].thickness_mm, travel, 1e-9);
  EXPECT_NEAR(j["moved_thickness_mm"]["3"].get<double>(), p.surfaces[3].thickness_mm - travel,
              1e-9);
  EXPECT_NEAR(j["film_distance_mm"].get<double>(), rest.lens->filmDistance_mm(), 1e-6);

  // Tolerance: the depth of focus (working f-number x 2 pixels) as group travel, through the
  // image shift per mm of travel (a central difference of the real-ray focus).
  setup.focus_distance_m = kPlane_m;
  const optics::FocusedLens at = optics::focusLens(p, setup);
  const optics::LensSystem& ls = *at.lens;
  const double n_w = optics::workingFNumber(ls, at.paraxial, ls.filmZ_mm() - kPlane_m * 1000);
  const double pitch = 35 / std::sqrt(1 + 0.75 * 0.75) / kXRes;
  const double depth = n_w * 2 * pitch;
  auto imageZ = [&](double x) {
    optics::LensPrescription q = p;
    q.surfaces[1].thickness_mm += x;
    q.surfaces[3].thickness_mm -= x;
    optics::LensSystemOptions o;
    o.aperture_diameter_mm = kAperture_mm;
    optics::LensSystem s(q, o);
    const optics::ParaxialData para = optics::computeParaxial(s);
    return s.rearVertexZ_mm() +
           optics::filmDistanceForFocus(s, para, kPlane_m, optics::FocusMethod::Exact);
  };
  const double h = 0.05;
  const double rate = std::abs(imageZ(want.shift_mm + h) - imageZ(want.shift_mm - h)) / (2 * h);
  const double tolerance = depth / rate;
  std::printf("autofocus group travel %.4f mm (%d renders); real rays %.4f mm +- %.4f\n", travel,
              j["renders"].get<int>(), want.shift_mm, tolerance);
  EXPECT_NEAR(travel, want.shift_mm, tolerance);
  // The group moved farther than that tolerance: an autofocus that moved the film instead (the
  // group at rest) would fail.
  EXPECT_GT(travel, tolerance);
  EXPECT_NEAR(j["focus_distance_m"].get<double>(), kPlane_m, 0.15);

  // The text report says so.
  const test::CliResult t = test::runLensim("autofocus --spp 1 --threads 2 --zones " + zones +
                                            " " + scene + " 2>/dev/null");
  ASSERT_EQ(t.status, 0) << t.out;
  EXPECT_NE(t.out.find("group focusing: in focus at"), std::string::npos) << t.out;
  EXPECT_NE(t.out.find("group moved"), std::string::npos) << t.out;
}

}  // namespace
}  // namespace lensim
