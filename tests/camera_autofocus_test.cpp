#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "lensim/camera/focus_search.h"
#include "lensim/camera/realistic.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::camera;
using lensim::test::lensPath;

namespace {

constexpr int kXRes = 400, kYRes = 300;

// A scene the test can trace without the renderer: textured planes facing the camera (camera
// space = world space), the plane at distance near_m on the left half of the view (x < 0) and
// far_m on the right. Radiance is a checkerboard of 1 and 0.2 with squares of `check_m` metres
// on the near plane, scaled with the distance on the far one so that both image to the same size
// on the film (2.2 pixels for 3 mm at 1 m through the 50 mm double Gauss: the far plane's
// squares at 3 mm would image to 0.7 pixel, below the pixel pitch, where the sharpness is noise
// and aliasing and the search landed wherever they peaked).
struct Planes {
  double near_m, far_m, check_m;
  double radiance(const CameraRay& r) const {
    // Which plane: the one the ray meets first on its side of the view.
    for (double z : {near_m, far_m}) {
      const double t = (z - r.origin.z) / r.direction.z;
      if (t <= 0) continue;
      const Vec3 p = r.origin + r.direction * t;
      const bool left = p.x < 0;
      if ((z == near_m) != left) continue;
      const double check = check_m * z / near_m;
      const long ix = static_cast<long>(std::floor(p.x / check));
      const long iy = static_cast<long>(std::floor(p.y / check));
      return ((ix + iy) & 1) ? 1.0 : 0.2;
    }
    return 0;
  }
};

// Renders a zone of the image with `spp` samples per pixel, the same random numbers for every
// call (common random numbers make the focus search smooth).
ZoneImage renderZone(const RealisticCamera& cam, const Planes& scene, const AfZone& z, int spp) {
  const int x0 = static_cast<int>(z.left * kXRes), x1 = static_cast<int>(z.right * kXRes);
  const int y0 = static_cast<int>(z.top * kYRes), y1 = static_cast<int>(z.bottom * kYRes);
  ZoneImage img;
  img.width = x1 - x0;
  img.height = y1 - y0;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(0, 1);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      double sum = 0;
      for (int s = 0; s < spp; ++s) {
        const Vec2 raster{x + u(rng), y + u(rng)};
        const Vec2 lens{u(rng), u(rng)};
        if (auto r = cam.generateRay({raster, lens, 0})) sum += r->weight * scene.radiance(*r);
      }
      img.pixels.push_back(sum / spp);
    }
  return img;
}

RealisticSettings settingsFor(const std::string& lens, double film_mm) {
  RealisticSettings s;
  s.lens_path = lensPath(lens);
  s.setup.film_distance_mm = film_mm;
  s.film_diagonal_mm = 35;
  s.x_resolution = kXRes;
  s.y_resolution = kYRes;
  return s;
}

struct Expected {
  double film_mm;    // exact best focus from the optics core
  double tolerance;  // depth of focus: working f-number x circle of confusion (2 pixels)
};

Expected expectedFocus(const std::string& lens, double distance_m) {
  optics::FocusedLens fl = optics::focusLens(
      optics::readLensFile(lensPath(lens)),
      {.focus_distance_m = distance_m, .focus_method = optics::FocusMethod::Exact});
  const optics::LensSystem& ls = *fl.lens;
  const double n_w = optics::workingFNumber(ls, fl.paraxial, ls.filmZ_mm() - distance_m * 1000);
  const double pitch = 35 / std::sqrt(1 + 0.75 * 0.75) / kXRes;
  return {ls.filmDistance_mm(), n_w * 2 * pitch};
}

double autofocusZone(const std::string& lens, const Planes& scene, const AfZone& zone, double lo_mm,
                     double hi_mm, double step_mm) {
  AutofocusOptions opts;
  opts.film_min_mm = lo_mm;
  opts.film_max_mm = hi_mm;
  opts.max_step_mm = step_mm;
  opts.refine_steps = 10;
  auto score = [&](double film_mm) {
    RealisticCamera cam(settingsFor(lens, film_mm));
    return sharpness(renderZone(cam, scene, zone, 4));
  };
  return autofocus(score, opts).film_distance_mm;
}

}  // namespace

TEST(AfZones, ReadsTheAssignmentsZoneFiles) {
  const std::string dir = std::string(LENSIM_SHARED_DIR) + "/scenes/cs348b-hw3/";
  for (const char* f : {"dgauss_bg_zones.txt", "dgauss_closeup_zones.txt", "telephoto_zones.txt",
                        "bunnies_zones.txt", "afspheres_zones.txt"}) {
    SCOPED_TRACE(f);
    std::vector<AfZone> zones;
    try {
      zones = readAfZones(dir + f);
    } catch (const Error& e) {
      if (std::string(e.what()).find("cannot open") != std::string::npos)
        GTEST_SKIP() << "shared scenes not present: " << e.what();
      throw;
    }
    ASSERT_FALSE(zones.empty());
    for (const AfZone& z : zones) {
      EXPECT_LT(z.left, z.right);
      EXPECT_LT(z.top, z.bottom);
    }
  }
  EXPECT_EQ(readAfZones(dir + "dgauss_bg_zones.txt").size(), 1u);
}

TEST(AfZones, SkipsCommentsAndIndentedLinesAndRejectsBadOnes) {
  auto z = parseAfZones("# c\n\n .1 .2 .3 .4\n\t.1 .2 .3 .4\n.25 .5 .5 .75\r\n", "z.txt");
  ASSERT_EQ(z.size(), 1u);
  EXPECT_DOUBLE_EQ(z[0].left, 0.25);
  EXPECT_EQ(z[0].loc.line, 5);
  auto expectError = [](const std::string& text, int line, int col, const std::string& msg) {
    try {
      parseAfZones(text, "z.txt");
      ADD_FAILURE() << "no error for " << text;
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, line) << e.what();
      EXPECT_EQ(e.loc().column, col) << e.what();
      EXPECT_NE(e.message().find(msg), std::string::npos) << e.what();
    }
  };
  expectError(".1 .2 .3\n", 1, 9, "expected 4 numbers");
  expectError(".1 .2 x .4\n", 1, 7, "expected a number, found 'x'");
  expectError(".1 .2 .3 1.4\n", 1, 10, "outside [0, 1]");
  expectError(".5 .2 .3 .4\n", 1, 1, "empty zone");
  expectError("# nothing\n", 1, 0, "no zones");
}

TEST(Sharpness, PrefersTheSharperImage) {
  ZoneImage sharp{32, 32, {}}, soft{32, 32, {}};
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      sharp.pixels.push_back(((x / 4 + y / 4) & 1) ? 1.0 : 0.2);
      soft.pixels.push_back(0.6 + 0.4 * std::sin(x * 0.3) * std::sin(y * 0.3));
    }
  EXPECT_GT(sharpness(sharp), sharpness(soft));
  // Exposure does not matter.
  ZoneImage brighter = sharp;
  for (double& p : brighter.pixels) p *= 7;
  EXPECT_NEAR(sharpness(brighter), sharpness(sharp), 1e-9 * sharpness(sharp));
}

// A textured plane at a known distance: autofocus through the real lens lands within the depth of
// focus of the optics core's film distance for that distance.
TEST(Autofocus, FindsTheFilmDistanceOfAPlane) {
  struct Case {
    const char* lens;
    double distance_m, check_m;
  } cases[] = {{"dgauss.50mm.dat", 1.5, 0.004}, {"telephoto.250mm.dat", 8.0, 0.004}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.lens);
    const Expected e = expectedFocus(c.lens, c.distance_m);
    const Planes scene{c.distance_m, c.distance_m, c.check_m};
    const AfZone centre{0.45, 0.55, 0.43, 0.57, {}};
    const double found =
        autofocusZone(c.lens, scene, centre, 0.9 * e.film_mm, 1.15 * e.film_mm, e.tolerance);
    EXPECT_NEAR(found, e.film_mm, e.tolerance) << "tolerance " << e.tolerance;
  }
}

// Two zones on objects at different distances give two answers in the right order: the nearer
// object needs the film farther from the lens.
TEST(Autofocus, TwoZonesAtDifferentDistances) {
  const Planes scene{1.0, 3.0, 0.003};
  const Expected near = expectedFocus("dgauss.50mm.dat", 1.0);
  const Expected far = expectedFocus("dgauss.50mm.dat", 3.0);
  const AfZone left{0.25, 0.35, 0.43, 0.57, {}}, right{0.65, 0.75, 0.43, 0.57, {}};
  const double lo = 0.95 * far.film_mm, hi = 1.05 * near.film_mm;
  const double a = autofocusZone("dgauss.50mm.dat", scene, left, lo, hi, far.tolerance);
  const double b = autofocusZone("dgauss.50mm.dat", scene, right, lo, hi, far.tolerance);
  EXPECT_GT(a - b, near.tolerance + far.tolerance) << a << " " << b;
  // The zones sit 6 mm off the axis, where field curvature moves the best focus by a fraction of
  // a millimetre from the axial best focus the optics core computes.
  EXPECT_NEAR(a, near.film_mm, 3 * near.tolerance);
  EXPECT_NEAR(b, far.film_mm, 3 * far.tolerance);
}
