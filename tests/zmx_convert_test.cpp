// `lens convert` to .zmx (issue 28): every file of the shared Zemax corpus that lensim reads is
// written back to .zmx and read again with the same surfaces, first-order data and real rays, or
// refused by the writer with a reason; a curved stop inside glass keeps its glass.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "cli_run.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/placed_lens.h"
#include "lensim/util/error.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string zmxDir() {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/";
}

// A fresh directory for this process, removed at the end.
struct TempDir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / fmt::format("zmx-convert-test-{}", long(getpid()));
  TempDir() {
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

// The surfaces of a and b agree: shapes, media, apertures, stops, gratings, thicknesses.
void expectSameSurfaces(const LensPrescription& a, const LensPrescription& b) {
  ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
  for (size_t i = 0; i < a.surfaces.size(); ++i) {
    SCOPED_TRACE(fmt::format("surface row {}", i));
    const LensSurface &s = a.surfaces[i], &t = b.surfaces[i];
    EXPECT_NEAR(s.radius_mm, t.radius_mm, 1e-12 * std::abs(s.radius_mm));
    EXPECT_EQ(s.shape.conic, t.shape.conic);
    EXPECT_EQ(s.shape.poly, t.shape.poly);
    EXPECT_EQ(s.ior, t.ior);
    EXPECT_EQ(s.glass.name, t.glass.name);
    EXPECT_EQ(s.mirror, t.mirror);
    EXPECT_EQ(s.isStop(), t.isStop());
    EXPECT_EQ(s.semiAperture_mm(), t.semiAperture_mm());
    EXPECT_EQ(s.grating.has_value(), t.grating.has_value());
    if (s.grating && t.grating) {
      EXPECT_EQ(s.grating->order, t.grating->order);
      EXPECT_EQ(s.grating->lines_per_um, t.grating->lines_per_um);
    }
    if (!a.noncoaxial_loc) {
      EXPECT_NEAR(s.thickness_mm, t.thickness_mm, 1e-12);
    }
  }
}

// Real rays through a grid of the lens's front aperture, at two field angles, traced through a
// and b (placed in space for a tilted lens, along the axis for a coaxial one): the same rays come
// out.
template <typename TraceA, typename TraceB>
void expectSameRaysBy(const LensPrescription& a, const TraceA& ta, const TraceB& tb) {
  constexpr int kHalf = 30;  // a 61 x 61 grid over the front surface's aperture
  const double r = a.surfaces.front().semiAperture_mm();
  int compared = 0;
  for (const double angle : {0.0, 0.05})
    for (int i = -kHalf; i <= kHalf; ++i)
      for (int j = -kHalf; j <= kHalf; ++j) {
        const Vec3 d = normalize(Vec3{0.3 * angle, angle, 1});
        const Ray ray{Vec3{r * i / kHalf, r * j / kHalf, -5} - d * 5.0, d};
        const TraceResult ra = ta(ray), rb = tb(ray);
        ASSERT_EQ(ra.ok(), rb.ok());
        if (!ra.ok()) continue;
        ++compared;
        EXPECT_NEAR(length(ra.ray.origin - rb.ray.origin), 0, 1e-9);
        EXPECT_NEAR(length(ra.ray.direction - rb.ray.direction), 0, 1e-12);
      }
  EXPECT_GT(compared, 20);
}

void expectSameRays(const LensPrescription& a, const LensPrescription& b, double lambda) {
  if (a.noncoaxial_loc) {
    const PlacedLens pa(a, lambda), pb(b, lambda);
    expectSameRaysBy(
        a, [&](const Ray& r) { return pa.trace(r); }, [&](const Ray& r) { return pb.trace(r); });
    // The beams of two fields, wherever they pass (an off-axis mirror's may miss the grid).
    for (const double angle : {0.0, 0.5}) {
      const auto ua = pa.spot({true, 0, angle, {}}), ub = pb.spot({true, 0, angle, {}});
      ASSERT_EQ(ua.has_value(), ub.has_value());
      if (!ua) continue;
      EXPECT_EQ(ua->rays, ub->rays);
      EXPECT_NEAR(ua->rms_mm, ub->rms_mm, 1e-9);
      EXPECT_NEAR(ua->centroid.x, ub->centroid.x, 1e-9);
      EXPECT_NEAR(ua->centroid.y, ub->centroid.y, 1e-9);
    }
  } else {
    const LensSystem sa = LensSystem(a).atWavelength(lambda);
    const LensSystem sb = LensSystem(b).atWavelength(lambda);
    expectSameRaysBy(
        a, [&](const Ray& r) { return sa.tracer().traceFromScene(r); },
        [&](const Ray& r) { return sb.tracer().traceFromScene(r); });
  }
}

// Keys of `lens info --json` that name the file or a place in it.
bool skipKey(const std::string& key) {
  static const std::set<std::string> keys = {"line", "column"};
  return keys.count(key) > 0;
}

}  // namespace

// optiland's curved transmission grating is the stop and sits in N-BK7: lensim puts a plane
// stop just before it, in the same glass, so the lens writes to .zmx and reads back the same.
TEST(ZmxConvert, CurvedStopInGlassKeepsTheGlass) {
  const std::string path = zmxDir() + "optiland/curved_transmission_grating.zmx";
  const LensPrescription a = readLensFile(path);
  int stops = 0;
  for (size_t i = 1; i < a.surfaces.size(); ++i)
    if (a.surfaces[i].isStop() && a.surfaces[i].radius_mm == 0 && a.surfaces[i].thickness_mm == 0) {
      ++stops;
      EXPECT_EQ(a.surfaces[i].glass.name, "N-BK7");
      EXPECT_EQ(a.surfaces[i].glass.name, a.surfaces[i - 1].glass.name);
      EXPECT_EQ(a.surfaces[i].ior, a.surfaces[i - 1].ior);
      ASSERT_LT(i + 1, a.surfaces.size());
      EXPECT_TRUE(a.surfaces[i + 1].grating.has_value());  // the curved stop follows
    }
  EXPECT_EQ(stops, 1);
  const LensPrescription b = parseZmx(writeLensZmx(a), "back.zmx");
  expectSameSurfaces(a, b);
  for (const double lambda : {486.13, 550.0, 656.27}) expectSameRays(a, b, lambda);
}

// The same through the command line: `lens convert` writes it, and `lens info --json` gives the
// same numbers for both files.
TEST(ZmxConvert, CommandLineConvertKeepsLensInfo) {
  TempDir dir;
  const std::string in = zmxDir() + "optiland/curved_transmission_grating.zmx";
  const std::string out = dir.file("grating.zmx");
  const test::CliResult c = test::runLensim("lens convert " + in + " " + out);
  ASSERT_EQ(c.status, 0) << c.out;
  const test::CliResult ra = test::runLensim("lens info --json --field 0,10 " + in);
  const test::CliResult rb = test::runLensim("lens info --json --field 0,10 " + out);
  ASSERT_EQ(ra.status, 0) << ra.out;
  ASSERT_EQ(rb.status, 0) << rb.out;
  const auto ja = nlohmann::json::parse(ra.out.substr(ra.out.find('{')));
  const auto jb = nlohmann::json::parse(rb.out.substr(rb.out.find('{')));
  // Every number of a is in b with the same value; strings (file names, notes) may differ.
  int numbers = 0;
  auto compare = [&](auto&& self, const nlohmann::json& x, const nlohmann::json& y,
                     const std::string& at) -> void {
    if (x.is_number()) {
      ++numbers;
      ASSERT_TRUE(y.is_number()) << at;
      const double u = x.get<double>(), v = y.get<double>();
      EXPECT_NEAR(u, v, 1e-9 * (1 + std::abs(u))) << at;
    } else if (x.is_object()) {
      for (const auto& [key, value] : x.items()) {
        if (!skipKey(key)) {
          ASSERT_TRUE(y.contains(key)) << at << "/" << key;
          self(self, value, y.at(key), at + "/" + key);
        }
      }
    } else if (x.is_array()) {
      ASSERT_TRUE(y.is_array()) << at;
      ASSERT_EQ(x.size(), y.size()) << at;
      for (size_t i = 0; i < x.size(); ++i) self(self, x[i], y[i], fmt::format("{}[{}]", at, i));
    }
  };
  compare(compare, ja, jb, "");
  EXPECT_GT(numbers, 20);
}

// Every file of ../shared/lenses/zmx/ that lensim reads: written to .zmx and read back with the
// same surfaces, the same first-order data (coaxial lenses, at each file wavelength) and the same
// real rays; or refused by the writer with the reason listed here.
TEST(ZmxConvert, EveryCorpusFileWritesAndReadsBack) {
  // Refused by the reader (lensfile_zmx_test.cpp's table says why).
  const std::set<std::string> unread = {"optiland/lens_floa.zmx"};
  // Refused by the writer, with a word of the reason.
  const std::map<std::string, std::string> unwritten = {
      {"optiland/one_mirror_up_45deg.zmx", "folded by mirrors"},
      {"optiland/simple_fold_mirror_up.zmx", "folded by mirrors"},
      {"optiland/thorlabs_lj1598l1.zmx", "rotationally symmetric surfaces only"},
  };
  size_t written = 0, files = 0;
  for (const auto& dir : {zmxDir(), zmxDir() + "optiland/"})
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      if (e.path().extension() != ".zmx") continue;
      ++files;
      const std::string name = std::filesystem::relative(e.path(), zmxDir()).string();
      SCOPED_TRACE(name);
      LensPrescription a;
      try {
        a = readLensFile(e.path().string());
      } catch (const Error& err) {
        EXPECT_TRUE(unread.count(name)) << err.what();
        continue;
      }
      EXPECT_FALSE(unread.count(name)) << "reads now";
      std::string text;
      try {
        text = writeLensZmx(a);
      } catch (const Error& err) {
        ASSERT_TRUE(unwritten.count(name)) << err.what();
        EXPECT_NE(std::string(err.what()).find(unwritten.at(name)), std::string::npos)
            << err.what();
        continue;
      }
      EXPECT_FALSE(unwritten.count(name)) << "written now";
      ++written;
      const LensPrescription b = parseZmx(text, "back.zmx");
      expectSameSurfaces(a, b);
      EXPECT_EQ(a.wavelengths_nm, b.wavelengths_nm);
      std::vector<double> waves = a.wavelengths_nm;
      if (waves.empty()) waves.push_back(primaryWavelength_nm(a));
      for (const double lambda : waves) {
        SCOPED_TRACE(fmt::format("{} nm", lambda));
        expectSameRays(a, b, lambda);
        if (a.noncoaxial_loc) continue;
        const ParaxialData pa = computeParaxial(LensSystem(a).atWavelength(lambda));
        const ParaxialData pb = computeParaxial(LensSystem(b).atWavelength(lambda));
        auto near = [](double u, double v) { return std::abs(u - v) <= 1e-9 * (1 + std::abs(u)); };
        EXPECT_PRED2(near, pa.effective_focal_length_mm, pb.effective_focal_length_mm);
        EXPECT_PRED2(near, pa.back_focal_length_mm, pb.back_focal_length_mm);
        EXPECT_PRED2(near, pa.front_focal_length_mm, pb.front_focal_length_mm);
        EXPECT_PRED2(near, pa.principal_plane_back_z_mm, pb.principal_plane_back_z_mm);
        EXPECT_EQ(pa.aperture_stop_surface, pb.aperture_stop_surface);
        EXPECT_PRED2(near, pa.entrance_pupil_z_mm, pb.entrance_pupil_z_mm);
        EXPECT_PRED2(near, pa.entrance_pupil_diameter_mm, pb.entrance_pupil_diameter_mm);
        EXPECT_PRED2(near, pa.exit_pupil_z_mm, pb.exit_pupil_z_mm);
        EXPECT_PRED2(near, pa.exit_pupil_diameter_mm, pb.exit_pupil_diameter_mm);
        EXPECT_PRED2(near, pa.f_number, pb.f_number);
        EXPECT_PRED2(near, pa.real_f_number, pb.real_f_number);
      }
    }
  EXPECT_EQ(files, 19u);
  EXPECT_EQ(written + unread.size() + unwritten.size(), files);
}
