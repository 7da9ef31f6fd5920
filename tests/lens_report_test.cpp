// The lens-info JSON shared by `lensim lens info --json` and the explorer's /api/lens
// (optics/lens_report.h): lengths checked against sums of the file's thicknesses, for a plain
// lens and for a folded (two-mirror) one, through the explorer's JSON.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "lensim/optics/lens_report.h"
#include "lensim/optics/prescription.h"
#include "lensim/serve/lens_view.h"

namespace {

using namespace lensim;

struct Extent {
  double lens_lo = 0, lens_hi = 0, track_lo = 0, track_hi = 0, rear_vertex = 0;
};

// Surface z from the file's rows: the running sum of the (signed) thicknesses; the film lies
// the last row's thickness behind the last surface.
Extent extentFromRows(const optics::LensPrescription& pr, double film_distance_mm) {
  Extent e;
  double z = 0;
  for (size_t i = 0; i < pr.surfaces.size(); ++i) {
    e.lens_lo = std::min(e.lens_lo, z), e.lens_hi = std::max(e.lens_hi, z);
    e.rear_vertex = z;
    if (i + 1 < pr.surfaces.size()) z += pr.surfaces[i].thickness_mm;
  }
  const double film = z + film_distance_mm;
  e.track_lo = std::min(e.lens_lo, film), e.track_hi = std::max(e.lens_hi, film);
  return e;
}

serve::SetUpLens setUp(const std::string& path) {
  serve::LensSettings st;
  st.path = path;
  return serve::setUpLens(st);
}

TEST(LensReport, PlainLensLengthsAreVertexAndFilmDistances) {
  const auto s = setUp(std::string(LENSIM_SHARED_DIR) + "/lenses/dgauss.50mm.dat");
  const auto& lens = *s.lens.lens;
  ASSERT_EQ(lens.mirrorCount(), 0);
  const Extent e = extentFromRows(lens.prescription(), lens.filmDistance_mm());
  const nlohmann::json j = serve::firstOrderJson(s, 43.3);
  EXPECT_NEAR(j["lens_length_mm"].get<double>(), e.rear_vertex, 1e-9);
  EXPECT_NEAR(j["total_track_mm"].get<double>(), e.rear_vertex + lens.filmDistance_mm(), 1e-9);
  EXPECT_EQ(j["surfaces"], nullptr);  // the explorer's JSON carries first-order data only
  const nlohmann::json surfaces = optics::surfacesJson(lens);
  ASSERT_EQ(surfaces.size(), lens.prescription().surfaces.size());
  EXPECT_NEAR(surfaces.back()["z_mm"].get<double>(), e.rear_vertex, 1e-9);
  EXPECT_NEAR(surfaces.back()["thickness_mm"].get<double>(), lens.filmDistance_mm(), 1e-12);
}

// A folded lens: its length is the axial extent of its surfaces, not the rear vertex z (which
// lies at the front after two mirrors); /api/lens reported the rear vertex z before the two
// reports shared their code.
TEST(LensReport, FoldedLensLengthIsTheAxialExtent) {
  const auto s = setUp(std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/HoO-V2C18Ex03.zmx");
  const auto& lens = *s.lens.lens;
  ASSERT_EQ(lens.mirrorCount(), 2);
  const Extent e = extentFromRows(lens.prescription(), lens.filmDistance_mm());
  ASSERT_GT(e.lens_hi - e.lens_lo, 1.0);
  const nlohmann::json j = serve::firstOrderJson(s, 43.3);
  EXPECT_NEAR(j["lens_length_mm"].get<double>(), e.lens_hi - e.lens_lo, 1e-9);
  EXPECT_NEAR(j["total_track_mm"].get<double>(), e.track_hi - e.track_lo, 1e-9);
  EXPECT_NEAR(optics::lensLength(lens), e.lens_hi - e.lens_lo, 1e-9);
}

}  // namespace
