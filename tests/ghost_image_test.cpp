// `lens plot ghosts --image` (issue 31, docs/flare.md "A point light's film image"): the film
// image of a distant point light, direct and ghosts, read back from the EXR it writes and checked
// against a chief ray traced here, against `lens ghosts --angle`'s intensities and traced spot
// centroids (the same rays), and for the refusal of bad options.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/io/image.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/prescription.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using nlohmann::json;

namespace {

std::string tmpPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("lensim_ghost_image_" + name)).string();
}

/// A layer's sum and centroid (film mm: x right from the centre, y up) from the pixels, with the
/// raster the docs define: 3:2, `diagonal_mm` across, square pixels, centres at (i + 0.5) px.
struct Moments {
  double sum = 0, x = 0, y = 0;
};
Moments moments(const io::Image& img, const std::string& channel, double diagonal_mm) {
  const int c = *img.channelIndex(channel);
  const double width = diagonal_mm * 3 / std::sqrt(13.0), px = width / img.width;
  const double height = px * img.height;
  Moments m;
  for (int j = 0; j < img.height; ++j)
    for (int i = 0; i < img.width; ++i) {
      const double v = img.at(i, j, c);
      m.sum += v;
      m.x += v * (-0.5 * width + (i + 0.5) * px);
      m.y += v * (0.5 * height - (j + 0.5) * px);
    }
  if (m.sum != 0) m.x /= m.sum, m.y /= m.sum;
  return m;
}

/// The real chief ray of a distant point `angle` off axis (x-z plane): the parallel ray that
/// crosses the aperture stop at its centre, by bisection on its height at the front vertex plane;
/// returns its x on the film plane.
double chiefRayFilmX(const LensSystem& lens, double angle) {
  const auto& s = lens.interfaces();
  int stop = -1;
  for (size_t k = 0; k < s.size(); ++k)
    if (s[k].is_stop) stop = int(k);
  EXPECT_GE(stop, 0);
  const LensTracer<double> tracer(s);
  const Vec3T<double> dir{std::sin(angle), 0.0, std::cos(angle)};
  const double back = 50;
  auto trace = [&](double x0, std::vector<Vec3T<double>>& pts) {
    pts.clear();
    return tracer.traceFromScene(Ray{{x0 - back * dir.x / dir.z, 0, s[0].z_mm - back}, dir}, {},
                                 &pts);
  };
  std::vector<Vec3T<double>> pts;
  // x at the stop grows with the entrance height (a positive lens in front of the stop).
  double lo = -s[0].semi_aperture_mm, hi = s[0].semi_aperture_mm;
  for (int it = 0; it < 80; ++it) {
    const double mid = 0.5 * (lo + hi);
    trace(mid, pts);
    (pts.size() > size_t(stop) + 1 && pts[size_t(stop) + 1].x < 0 ? lo : hi) = mid;
  }
  const TraceResult res = trace(0.5 * (lo + hi), pts);
  EXPECT_TRUE(res.ok());
  EXPECT_NEAR(pts[size_t(stop) + 1].x, 0, 1e-9);
  const double u = (lens.filmZ_mm() - res.ray.origin.z) / res.ray.direction.z;
  return res.ray.origin.x + u * res.ray.direction.x;
}

}  // namespace

// The direct image's centroid (read from the EXR's direct layer) lies at the real chief ray's
// film height, traced here, for a 4 mm stop 10 degrees off axis; the tone-mapped PNG shows light
// away from the direct image (the ghosts).
TEST(GhostImage, DirectImageLandsAtTheChiefRay) {
  const std::string lens_file = test::lensPath("dgauss.50mm.dat");
  const std::string exr = tmpPath("direct.exr"), png = tmpPath("direct.png");
  const test::CliResult r =
      test::runLensim("--quiet lens plot ghosts " + lens_file +
                      " --aperture-diameter 4 --image --angle 10 --grid 400 --size 600 -o " + png +
                      " --exr " + exr);
  ASSERT_EQ(r.status, 0) << r.out;
  const io::Image img = io::readImage(exr);
  ASSERT_EQ(img.width, 600);
  ASSERT_EQ(img.height, 400);
  LensSetup setup;
  setup.aperture_diameter_mm = 4;
  const FocusedLens fl = focusLens(readLensFile(lens_file), setup);
  const double want = chiefRayFilmX(*fl.lens, 10 * std::numbers::pi / 180);
  const Moments m = moments(img, "direct.G", 35);
  const double px = 35 * 3 / std::sqrt(13.0) / 600;
  std::printf("direct centroid x %.4f mm, chief ray %.4f mm (f tan 10 = %.4f), pixel %.4f mm\n",
              m.x, want, 50 * std::tan(10 * std::numbers::pi / 180), px);
  EXPECT_NEAR(m.x, want, 0.2 * px);
  EXPECT_NEAR(m.y, 0, 1e-3 * px);
  // The direct layer sums to 1 (its luminance is the unit) when all of it is on the film.
  const double lum = 0.2126 * moments(img, "direct.R", 35).sum +
                     0.7152 * moments(img, "direct.G", 35).sum +
                     0.0722 * moments(img, "direct.B", 35).sum;
  EXPECT_NEAR(lum, 1, 1e-5);
  // The display PNG: the brightest pixel is at the direct image; lit pixels far from it.
  const io::Image shown = io::readImage(png);
  ASSERT_EQ(shown.width, 600);
  int lit_far = 0;
  for (int j = 0; j < shown.height; ++j)
    for (int i = 0; i < shown.width; ++i) {
      const double x = -0.5 * 600 * px + (i + 0.5) * px;
      if (std::abs(x - want) > 5 && shown.at(i, j, 1) > 0.05f) ++lit_far;
    }
  EXPECT_GT(lit_far, 1000);
  std::remove(exr.c_str());
  std::remove(png.c_str());
}

// The ghost layer's light (pixel sums, over the direct layer's) equals the sum of the intensities
// `lens ghosts --angle` reports for the same rays (one wavelength, so the colour is grey and the
// ratio is the energy ratio), on a film large enough to hold every ghost; and ghost by ghost
// (--ghost I,J) for the three brightest.
TEST(GhostImage, GhostLightEqualsTheTracedIntensities) {
  const std::string lens_file = test::lensPath("dgauss.50mm.dat");
  const std::string exr = tmpPath("energy.exr");
  const std::string common = " --angle 10 --grid 32 --wavelengths 550";
  const test::CliResult gh = test::runLensim("lens ghosts " + lens_file + common + " --json");
  ASSERT_EQ(gh.status, 0) << gh.out;
  const json g = json::parse(gh.out);
  double want = 0;
  for (const json& h : g["ghosts"])
    if (!h["spot"].is_null()) want += h["spot"]["relative_intensity"].get<double>();
  const std::string image = "--quiet lens plot ghosts " + lens_file + common +
                            " --image --film-diagonal 3000 --size 300 -o " + exr;
  const test::CliResult r = test::runLensim(image);
  ASSERT_EQ(r.status, 0) << r.out;
  io::Image img = io::readImage(exr);
  const double got = moments(img, "ghost.G", 3000).sum / moments(img, "direct.G", 3000).sum;
  std::printf("ghosts / direct from the pixels %.6e, lens ghosts --angle %.6e\n", got, want);
  EXPECT_GT(want, 1e-3);
  EXPECT_NEAR(got, want, 1e-5 * want);
  for (int k = 0; k < 3; ++k) {
    const json& h = g["angle_ranking"][size_t(k)];
    const std::string ij = std::to_string(h["first_reflection_surface"].get<int>()) + "," +
                           std::to_string(h["second_reflection_surface"].get<int>());
    const test::CliResult one = test::runLensim(image + " --ghost " + ij);
    ASSERT_EQ(one.status, 0) << one.out;
    img = io::readImage(exr);
    const double rel = h["relative_intensity"].get<double>();
    EXPECT_NEAR(moments(img, "ghost.G", 3000).sum / moments(img, "direct.G", 3000).sum, rel,
                1e-5 * rel)
        << ij;
  }
  // With the multicoating instead of the file's (uncoated) surfaces: the same equality.
  const std::string multi = common + " --coating multi";
  const test::CliResult gm = test::runLensim("lens ghosts " + lens_file + multi + " --json");
  ASSERT_EQ(gm.status, 0) << gm.out;
  double want_multi = 0;
  const json g_multi = json::parse(gm.out);
  for (const json& h : g_multi["ghosts"])
    if (!h["spot"].is_null()) want_multi += h["spot"]["relative_intensity"].get<double>();
  const test::CliResult rm = test::runLensim("--quiet lens plot ghosts " + lens_file + multi +
                                             " --image --film-diagonal 3000 --size 300 -o " + exr);
  ASSERT_EQ(rm.status, 0) << rm.out;
  img = io::readImage(exr);
  const double got_multi = moments(img, "ghost.G", 3000).sum / moments(img, "direct.G", 3000).sum;
  EXPECT_LT(want_multi, 0.1 * want);
  EXPECT_NEAR(got_multi, want_multi, 1e-5 * want_multi);
  std::remove(exr.c_str());
}

// Each of the ten brightest ghosts at 10 degrees: its centroid in the image (--ghost I,J, the
// ghost layer's pixels) against the centroid of its traced spot in `lens ghosts --angle` (the
// same rays counted unweighted: the coatings' weights shift it by a little of the spot's size).
TEST(GhostImage, GhostCentroidsMatchTheTracedSpots) {
  const std::string lens_file = test::lensPath("dgauss.50mm.dat");
  const std::string exr = tmpPath("centroid.exr");
  const std::string common = " --angle 10 --grid 48 --wavelengths 550";
  const test::CliResult gh =
      test::runLensim("lens ghosts " + lens_file + common + " --top 10 --json");
  ASSERT_EQ(gh.status, 0) << gh.out;
  const json g = json::parse(gh.out);
  const double diag = 3000, px = diag * 3 / std::sqrt(13.0) / 300;
  int checked = 0;
  double worst = 0;
  for (const json& h : g["ghosts"]) {
    if (h["spot"].is_null() || h["spot"]["rays_arrived"].get<int>() == 0) continue;
    const std::string ij = std::to_string(h["first_reflection_surface"].get<int>()) + "," +
                           std::to_string(h["second_reflection_surface"].get<int>());
    const test::CliResult r =
        test::runLensim("--quiet lens plot ghosts " + lens_file + common +
                        " --image --film-diagonal 3000 --size 300 --ghost " + ij + " -o " + exr);
    ASSERT_EQ(r.status, 0) << r.out;
    const Moments m = moments(io::readImage(exr), "ghost.G", diag);
    const json& s = h["spot"];
    const double rms = s["rms_radius_mm"].get<double>();
    const double dx = m.x - s["centroid_x_mm"].get<double>();
    const double dy = m.y - s["centroid_y_mm"].get<double>();
    worst = std::max(worst, std::hypot(dx, dy) / rms);
    EXPECT_LT(std::hypot(dx, dy), 0.05 * rms + 1e-3 * px) << ij << " rms " << rms;
    ++checked;
  }
  std::printf("%d ghosts: largest centroid difference %.2f %% of the spot's RMS radius\n", checked,
              100 * worst);
  EXPECT_GE(checked, 8);
  std::remove(exr.c_str());
}

// Bad options: exit status 1, a message naming the value, and no file written.
TEST(GhostImage, BadOptionsAreRefusedAndNothingIsWritten) {
  const std::string lens = test::lensPath("dgauss.50mm.dat");
  const std::string exr = tmpPath("bad.exr"), png = tmpPath("bad.png");
  std::remove(exr.c_str());
  std::remove(png.c_str());
  const std::string base = "lens plot ghosts " + lens + " ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--image --size 5 --grid 8 -o " + exr, "--size 5"},
      {"--image --grid 1 --size 32 -o " + exr, "--grid 1"},
      {"--image --angle 95 -o " + exr, "--angle 95"},
      {"--image --decades 0 -o " + exr, "--decades 0"},
      {"--image --ghost 3,3 -o " + exr, "ghost 3,3"},
      {"--image --ghost 40,1 -o " + exr, "ghost 40,1"},
      {"--image --ghost x -o " + exr, "ghost x"},
      {"--image --wavelengths 550:2 -o " + exr, "550:2"},
      {"--image --wavelengths 5000 -o " + exr, "5000"},
      {"--image --coating bogus -o " + exr, "bogus"},
      {"--image -o " + tmpPath("bad.svg"), "bad.svg"},
      {"--image -o " + png + " --exr " + tmpPath("bad.tif"), "bad.tif"},
      {"--image -o /nonexistent-dir/x.exr", "nonexistent-dir"},
      {"--size 32 -o " + exr, "--size applies to 'ghosts --image' only"},
  };
  for (const auto& [opts, what] : cases) {
    const test::CliResult r = test::runLensim(base + opts);
    EXPECT_EQ(r.status, 1) << opts << "\n" << r.out;
    EXPECT_NE(r.out.find(what), std::string::npos) << opts << "\n" << r.out;
    EXPECT_FALSE(std::filesystem::exists(exr)) << opts;
    EXPECT_FALSE(std::filesystem::exists(png)) << opts;
  }
  const test::CliResult spot =
      test::runLensim("lens plot spot " + lens + " --image -o " + tmpPath("bad.svg"));
  EXPECT_EQ(spot.status, 1) << spot.out;
  EXPECT_NE(spot.out.find("--image applies to 'ghosts'"), std::string::npos) << spot.out;
  EXPECT_FALSE(std::filesystem::exists(tmpPath("bad.svg")));
}
