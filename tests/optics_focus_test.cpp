#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "lensim/optics/focus.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using lensim::test::kClassicLenses;
using lensim::test::lensPath;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

TEST(Focus, InfinityPutsTheFilmAtTheBackFocalPoint) {
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    FocusedLens fl = focusLens(readLensFile(lensPath(file)), {});
    EXPECT_TRUE(std::isinf(fl.focus_distance_m));
    EXPECT_NEAR(fl.lens->filmDistance_mm(), fl.paraxial.back_focal_length_mm, 1e-12);
  }
}

// Thick-lens focus: the Gaussian lens equation between the principal planes.
TEST(Focus, ThickMethodObeysTheLensEquation) {
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    LensSystem lens(readLensFile(lensPath(file)));
    ParaxialData p = computeParaxial(lens);
    const double D = 3 * closestFocusDistance_m(lens, p);
    const double s = filmDistanceForFocus(lens, p, D, FocusMethod::Thick);
    const double z_film = lens.rearVertexZ_mm() + s;
    const double s_i = z_film - p.principal_plane_back_z_mm;
    const double s_o = p.principal_plane_front_z_mm - (z_film - D * 1000);
    EXPECT_NEAR(1 / s_o + 1 / s_i, 1 / p.effective_focal_length_mm, 1e-12);
    // And the inverse gives the distance back.
    EXPECT_NEAR(focusDistanceForFilm(lens, p, s, FocusMethod::Thick), D, 1e-9 * D);
  }
}

TEST(Focus, CloserThanPossibleNamesTheClosestDistance) {
  LensSystem lens(readLensFile(lensPath("dgauss.50mm.dat")));
  ParaxialData p = computeParaxial(lens);
  const double closest = closestFocusDistance_m(lens, p);
  // 4f plus the principal-plane separation.
  EXPECT_NEAR(
      closest * 1000,
      4 * p.effective_focal_length_mm + p.principal_plane_back_z_mm - p.principal_plane_front_z_mm,
      1e-9);
  try {
    filmDistanceForFocus(lens, p, 0.9 * closest, FocusMethod::Thick);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(fmt::format("{:.4f} m", closest)), std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(filmDistanceForFocus(lens, p, 1.01 * closest, FocusMethod::Thick));
}

// Exact focus minimises the real on-axis spot: moving the film either way makes it larger, and
// it beats the thick-lens film position.
TEST(Focus, ExactMethodMinimisesTheRealSpot) {
  for (const char* file : kClassicLenses) {
    SCOPED_TRACE(file);
    for (double D : {kInf, 5.0, 1.5}) {
      LensSystem lens(readLensFile(lensPath(file)));
      ParaxialData p = computeParaxial(lens);
      if (D < 1.2 * closestFocusDistance_m(lens, p)) continue;
      const double s_exact = filmDistanceForFocus(lens, p, D, FocusMethod::Exact);
      const double s_thick = filmDistanceForFocus(lens, p, D, FocusMethod::Thick);
      auto spotAt = [&](double s) {
        lens.setFilmDistance_mm(s);
        return axialRmsSpot_mm(lens, p, D);
      };
      const double best = spotAt(s_exact);
      const double step = 1e-3 * p.effective_focal_length_mm;
      EXPECT_LT(best, spotAt(s_exact + step)) << D;
      EXPECT_LT(best, spotAt(s_exact - step)) << D;
      EXPECT_LE(best, spotAt(s_thick) * (1 + 1e-9)) << D;
      // Both methods agree to within a fraction of the focal length (spherical aberration
      // moves the best real focus).
      EXPECT_NEAR(s_exact, s_thick, 0.02 * p.effective_focal_length_mm) << D;
    }
  }
}

TEST(Focus, ExactInverseFindsTheDistanceInFocus) {
  LensSystem lens(readLensFile(lensPath("dgauss.50mm.dat")), {.aperture_diameter_mm = 4.0});
  ParaxialData p = computeParaxial(lens);
  for (double D : {0.5, 1.0, 2.2, 10.0}) {
    const double s = filmDistanceForFocus(lens, p, D, FocusMethod::Exact);
    const double back = focusDistanceForFilm(lens, p, s, FocusMethod::Exact);
    // Stopped down, aberrations are small and the two best-focus definitions meet.
    EXPECT_NEAR(back, D, 0.01 * D) << D;
  }
  // A film inside the infinity focus is focused beyond infinity.
  const double s_inf = filmDistanceForFocus(lens, p, kInf, FocusMethod::Exact);
  EXPECT_TRUE(std::isinf(focusDistanceForFilm(lens, p, 0.99 * s_inf, FocusMethod::Exact)));
  EXPECT_TRUE(std::isinf(focusDistanceForFilm(lens, p, 0.99 * s_inf, FocusMethod::Thick)));
}

TEST(Focus, FocusLensUsesTheFileFilmDistanceWhenGiven) {
  FocusedLens fl = focusLens(parseLensPrescription("50 5 1.5 20\n-50 60 1 20\n", "single.dat"), {});
  EXPECT_DOUBLE_EQ(fl.lens->filmDistance_mm(), 60);
  EXPECT_FALSE(std::isinf(fl.focus_distance_m));
  EXPECT_THROW(focusLens(parseLensPrescription("50 5 1.5 20\n-50 60 1 20\n", "s.dat"),
                         {.focus_distance_m = 1.0, .film_distance_mm = 40.0}),
               Error);
}

// The legacy dof-dragons scene gives filmdistance 36.77 mm for the double Gauss: in focus at a
// few metres (the scene's background), which both methods agree on.
TEST(Focus, LegacyFilmDistanceOfTheAssignment) {
  LensSystem lens(readLensFile(lensPath("dgauss.50mm.dat")));
  ParaxialData p = computeParaxial(lens);
  const double thick = focusDistanceForFilm(lens, p, 36.77, FocusMethod::Thick);
  EXPECT_GT(thick, 2.0);
  EXPECT_LT(thick, 6.0);
}
