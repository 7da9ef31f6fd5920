#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/paraxial.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using lensim::test::lensPath;

TEST(Paraxial, FocalLengthsMatchTheLensNames) {
  struct {
    const char* file;
    double f;
  } lenses[] = {{"dgauss.50mm.dat", 50},
                {"fisheye.10mm.dat", 10},
                {"wide.22mm.dat", 22},
                {"telephoto.250mm.dat", 250}};
  for (auto& l : lenses) {
    SCOPED_TRACE(l.file);
    LensSystem lens(readLensFile(lensPath(l.file)));
    ParaxialData p = computeParaxial(lens);
    EXPECT_NEAR(p.effective_focal_length_mm, l.f, 0.01 * l.f);
  }
}

TEST(Paraxial, DoubleGaussIsFTwo) {
  LensSystem lens(readLensFile(lensPath("dgauss.50mm.dat")));
  ParaxialData p = computeParaxial(lens);
  EXPECT_NEAR(p.f_number, 2.0, 0.03 * 2.0);
  EXPECT_EQ(p.aperture_stop_surface, 5);
  EXPECT_TRUE(p.stop_is_file_stop);
}

TEST(Paraxial, TelephotoBackFocalLengthAsPublished) {
  // ISETCam's copy of this prescription states EFL = 250 mm and BFL ~ 105 mm.
  LensSystem lens(readLensFile(lensPath("telephoto.250mm.dat")));
  ParaxialData p = computeParaxial(lens);
  EXPECT_NEAR(p.effective_focal_length_mm, 250, 1.0);
  EXPECT_NEAR(p.back_focal_length_mm, 105, 0.5);
  // A telephoto's rear principal plane lies in front of the lens.
  EXPECT_LT(p.principal_plane_back_z_mm, 0);
}

// A single thick lens against the lensmaker's equation and its closed-form cardinal points.
TEST(Paraxial, ThickLensMatchesLensmakersEquation) {
  const double R1 = 50, R2 = -80, t = 8, n = 1.6;
  LensSystem lens(
      parseLensPrescription(fmt::format("{} {} {} 30\n{} 0 1 30\n", R1, t, n, R2), "thick.dat"));
  ParaxialData p = computeParaxial(lens);
  const double phi = (n - 1) * (1 / R1 - 1 / R2 + (n - 1) * t / (n * R1 * R2));
  const double f = 1 / phi;
  EXPECT_NEAR(p.effective_focal_length_mm, f, 1e-9 * f);
  const double bfl = f * (1 - (n - 1) * t / (n * R1));
  const double ffl = f * (1 + (n - 1) * t / (n * R2));
  EXPECT_NEAR(p.back_focal_length_mm, bfl, 1e-9 * f);
  EXPECT_NEAR(p.front_focal_length_mm, ffl, 1e-9 * f);
  EXPECT_NEAR(p.principal_plane_back_z_mm, t + bfl - f, 1e-9 * f);
  EXPECT_NEAR(p.principal_plane_front_z_mm, -ffl + f, 1e-9 * f);
  // In air, nodal points coincide with principal points.
  EXPECT_NEAR(p.nodal_point_front_z_mm, p.principal_plane_front_z_mm, 1e-12 * f);
  EXPECT_NEAR(p.nodal_point_back_z_mm, p.principal_plane_back_z_mm, 1e-12 * f);
}

// Stop in front of a thick lens: the entrance pupil is the stop, the exit pupil its image.
TEST(Paraxial, PupilsOfAStopInFrontOfALens) {
  const double R1 = 40, R2 = -40, t = 6, n = 1.5, gap = 10, stop = 8;
  LensSystem lens(parseLensPrescription(
      fmt::format("0 {} 0 {}\n{} {} {} 30\n{} 0 1 30\n", gap, stop, R1, t, n, R2), "s.dat"));
  ParaxialData p = computeParaxial(lens);
  EXPECT_EQ(p.aperture_stop_surface, 0);
  EXPECT_NEAR(p.entrance_pupil_z_mm, 0, 1e-12);
  EXPECT_NEAR(p.entrance_pupil_diameter_mm, stop, 1e-12);
  // Exit pupil: image of the stop (object distance from the lens's front principal plane).
  const double f = p.effective_focal_length_mm;
  const double s_o = p.principal_plane_front_z_mm - 0;  // stop at z = 0
  const double s_i = 1 / (1 / f - 1 / s_o);             // real or virtual image distance
  EXPECT_NEAR(p.exit_pupil_z_mm, p.principal_plane_back_z_mm + s_i, 1e-9);
  EXPECT_NEAR(p.exit_pupil_diameter_mm, stop * std::abs(s_i / s_o), 1e-9);
  EXPECT_NEAR(p.f_number, f / stop, 1e-12);
}

// The paraxial matrices agree with the exact tracer in the small-height limit.
TEST(Paraxial, AgreesWithExactTracerForSmallHeights) {
  for (const char* file : lensim::test::kClassicLenses) {
    SCOPED_TRACE(file);
    LensSystem lens(readLensFile(lensPath(file)));
    ParaxialData p = computeParaxial(lens);
    const double h = 1e-4;
    TraceResult r = lens.tracer().traceFromScene(Ray{{h, 0, -1}, {0, 0, 1}});
    ASSERT_TRUE(r.ok());
    // The emerging ray crosses the axis at the rear focal point, and its slope gives the EFL.
    const double t = -r.ray.origin.x / r.ray.direction.x;
    const double z_focus = r.ray.origin.z + t * r.ray.direction.z;
    const double efl = -h * r.ray.direction.z / r.ray.direction.x;
    EXPECT_NEAR(efl, p.effective_focal_length_mm, 1e-6 * p.effective_focal_length_mm);
    EXPECT_NEAR(z_focus, p.back_focal_point_z_mm, 1e-6 * p.effective_focal_length_mm);
  }
}

TEST(Paraxial, ApertureOverrideIsClampedWithAWarning) {
  LensSystem big(readLensFile(lensPath("dgauss.50mm.dat")), {.aperture_diameter_mm = 40.0});
  EXPECT_DOUBLE_EQ(*big.stopDiameter_mm(), 17.1);
  ASSERT_EQ(big.diagnostics().size(), 1u);
  EXPECT_EQ(big.diagnostics()[0].severity, Severity::Warning);
  LensSystem small(readLensFile(lensPath("dgauss.50mm.dat")), {.aperture_diameter_mm = 8.55});
  ParaxialData p = computeParaxial(small);
  EXPECT_DOUBLE_EQ(*small.stopDiameter_mm(), 8.55);
  // Half the stop diameter doubles the f-number.
  ParaxialData full = computeParaxial(LensSystem(readLensFile(lensPath("dgauss.50mm.dat"))));
  EXPECT_NEAR(p.f_number, 2 * full.f_number, 1e-12);
  EXPECT_THROW(LensSystem(readLensFile(lensPath("dgauss.50mm.dat")), {.aperture_diameter_mm = 0.0}),
               Error);
}

TEST(Paraxial, WorkingFNumberGrowsAsFocusComesCloser) {
  FocusedLens inf = focusLens(readLensFile(lensPath("dgauss.50mm.dat")), {});
  const double n_inf = workingFNumber(*inf.lens, inf.paraxial, std::nullopt);
  EXPECT_NEAR(n_inf, inf.paraxial.f_number, 1e-9);
  FocusedLens close =
      focusLens(readLensFile(lensPath("dgauss.50mm.dat")), {.focus_distance_m = 0.3});
  const double z_obj = close.lens->filmZ_mm() - 300;
  const double n_close = workingFNumber(*close.lens, close.paraxial, z_obj);
  // Paraxial: N_w = N (1 + |m| / m_p), m the magnification, m_p the pupil magnification.
  const ParaxialData& p = close.paraxial;
  const double s_o = p.principal_plane_front_z_mm - z_obj;
  const double s_i = 1 / (1 / p.effective_focal_length_mm - 1 / s_o);
  const double m = s_i / s_o;
  const double mp = p.exit_pupil_diameter_mm / p.entrance_pupil_diameter_mm;
  EXPECT_NEAR(n_close, p.f_number * (1 + m / mp), 1e-6 * n_close);
}

TEST(FieldOfView, RealChiefRaysGiveTheFieldOfView) {
  // The double Gauss is nearly distortion free: real and paraxial fields agree closely.
  LensSystem dg = *focusLens(readLensFile(lensPath("dgauss.50mm.dat")), {}).lens;
  ParaxialData pd = computeParaxial(dg);
  FieldOfView f = fieldOfView(dg, pd, 35);
  ASSERT_TRUE(f.real_deg);
  EXPECT_NEAR(*f.real_deg, f.paraxial_deg, 0.02 * f.paraxial_deg);
  // The fisheye covers about 156 degrees (its design value) on an image circle smaller than a
  // 35 mm diagonal.
  LensSystem fe = *focusLens(readLensFile(lensPath("fisheye.10mm.dat")), {}).lens;
  ParaxialData pf = computeParaxial(fe);
  FieldOfView ff = fieldOfView(fe, pf, 35);
  EXPECT_FALSE(ff.real_deg);
  ASSERT_TRUE(ff.image_circle_diameter_mm);
  EXPECT_LT(*ff.image_circle_diameter_mm, 35);
  EXPECT_NEAR(*ff.real_max_deg, 155.9, 5.0);
}

// An anamorphic lens's image area is not a circle: lentil:2001 (a 2x anamorphic) sees the scene
// much farther out along x than along y. Its image circle is the largest circle inside that area,
// checked here by brute force (a grid of rays over the rear element from film points at 36
// azimuths): every film point just inside the circle sees the scene, some just outside does not,
// while on the x axis the lens still sees it well beyond (where an x-axis-only search put the
// circle: 7.30 mm instead of 3.90 mm).
TEST(FieldOfView, AnamorphicImageCircleIsTheLargestCircleInsideTheImageArea) {
  LensSetup setup;
  setup.focus_distance_m = 3.3;
  const FocusedLens fl = focusLens(readLensFile("lentil:2001"), setup);
  const LensSystem& lens = *fl.lens;
  const FieldOfView f = fieldOfView(lens, fl.paraxial, 43.3);
  ASSERT_TRUE(f.image_circle_diameter_mm);
  const double r = *f.image_circle_diameter_mm / 2;
  const double rear = lens.interfaces().back().semi_aperture_mm;
  auto sees = [&](Vec2 film) {
    constexpr int kGrid = 64;
    for (int iy = 0; iy < kGrid; ++iy)
      for (int ix = 0; ix < kGrid; ++ix) {
        const Vec2 a{rear * (2.0 * (ix + 0.5) / kGrid - 1), rear * (2.0 * (iy + 0.5) / kGrid - 1)};
        if (a.x * a.x + a.y * a.y <= rear * rear && lens.traceFromFilmPoint(film, a).ok())
          return true;
      }
    return false;
  };
  int dark_inside = 0, dark_outside = 0;
  for (int k = 0; k < 36; ++k) {
    const Vec2 u{std::cos(2 * std::numbers::pi * k / 36), std::sin(2 * std::numbers::pi * k / 36)};
    dark_inside += !sees(u * (0.98 * r));
    dark_outside += !sees(u * (1.03 * r));
  }
  EXPECT_EQ(dark_inside, 0);
  EXPECT_GT(dark_outside, 0);
  EXPECT_TRUE(sees({1.5 * r, 0}));
}

TEST(ChiefRay, PassesThroughTheStopCentre) {
  LensSystem lens = *focusLens(readLensFile(lensPath("wide.22mm.dat")), {}).lens;
  ParaxialData p = computeParaxial(lens);
  for (double h : {2.0, 8.0, 15.0}) {
    auto c = chiefRayFromFilm(lens, p, h);
    ASSERT_TRUE(c) << h;
    std::vector<Vec3> path;
    lens.tracer().traceFromFilm(c->film_ray, {false}, &path);
    const int n = lens.surfaceCount();
    EXPECT_NEAR(path[n - p.aperture_stop_surface].x, 0, 1e-9) << h;
    // Scene side: the chief ray at that field angle lands at the same film height.
    auto s = chiefRayFromScene(lens, p, c->field_angle_deg);
    ASSERT_TRUE(s) << h;
    EXPECT_NEAR(s->film_height_mm, h, 1e-6) << h;
  }
}
