// Tilt and shift (optics/tilt_shift.h): the film placement against the documented rotation, the
// Scheimpflug/hinge closed forms against the thick lens's collinear imaging, and real rays from
// the predicted plane of focus converging on the tilted film.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/tilt_shift.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

constexpr double kDeg = M_PI / 180;

FocusedLens dgauss(double focus_m, double aperture_mm) {
  LensSetup setup;
  setup.focus_distance_m = focus_m;
  setup.aperture_diameter_mm = aperture_mm;
  return focusLens(readLensFile(lensim::test::lensPath("dgauss.50mm.dat")), setup);
}

// The thick lens's paraxial (collinear) image of a lens-space object point: distances from the
// principal planes, Newton's lens equation and the lateral magnification -v/d.
Vec3 paraxialImage(const ParaxialData& p, const Vec3& obj) {
  const double f = p.effective_focal_length_mm;
  const double d = p.principal_plane_front_z_mm - obj.z;  // object in front (> 0)
  const double v = f * d / (d - f);
  return {-obj.x * v / d, -obj.y * v / d, p.principal_plane_back_z_mm + v};
}

}  // namespace

// The film frame to lens space by hand: a point (0, h) of a film tilted about x by a lies at
// (0, h cos a, z_film - h sin a); a point (w, 0) of one tilted about y by b at (w cos b, 0,
// z_film + w sin b); the shift's point sits on the axis.
TEST(TiltShift, PlacementIsTheDocumentedRigidMap) {
  const double zf = 80, a = 7 * kDeg, b = -11 * kDeg;
  {
    const FilmPlacement pl(TiltShift{{7, 0}, {0, 0}}, zf);
    const Vec3 q = pl.lensFromFilm({0, 5});
    EXPECT_NEAR(q.x, 0, 1e-12);
    EXPECT_NEAR(q.y, 5 * std::cos(a), 1e-12);
    EXPECT_NEAR(q.z, zf - 5 * std::sin(a), 1e-12);
  }
  {
    const FilmPlacement pl(TiltShift{{0, -11}, {0, 0}}, zf);
    const Vec3 q = pl.lensFromFilm({4, 0});
    EXPECT_NEAR(q.x, 4 * std::cos(b), 1e-12);
    EXPECT_NEAR(q.y, 0, 1e-12);
    EXPECT_NEAR(q.z, zf + 4 * std::sin(b), 1e-12);
  }
  const FilmPlacement pl(TiltShift{{7, -11}, {3, -2}}, zf);
  const Vec3 o = pl.lensFromFilm({3, -2});
  EXPECT_NEAR(o.x, 0, 1e-12);
  EXPECT_NEAR(o.y, 0, 1e-12);
  EXPECT_NEAR(o.z, zf, 1e-12);
  // Rigid: distances kept, round trips exact, the normal unit and at cos(a) cos(b) to the axis.
  const Vec3 p1 = pl.lensFromFilm({10, 4}), p2 = pl.lensFromFilm({-6, 9});
  EXPECT_NEAR(length(p1 - p2), std::hypot(16.0, 5.0), 1e-12);
  const Vec3 back = pl.filmFromLensPoint(p1);
  EXPECT_NEAR(back.x, 10, 1e-12);
  EXPECT_NEAR(back.y, 4, 1e-12);
  EXPECT_NEAR(back.z, 0, 1e-12);
  EXPECT_NEAR(length(pl.filmNormal()), 1, 1e-12);
  EXPECT_NEAR(pl.filmNormal().z, std::cos(a) * std::cos(b), 1e-12);
  EXPECT_NEAR(dot(pl.filmNormal(), p1 - p2), 0, 1e-12);
}

// J = f / sin(tilt), the hinge at J from the front nodal point in the front focal plane, and
// every point of the predicted plane of focus imaged (thick lens, paraxial) onto the film plane.
TEST(TiltShift, ScheimpflugPlaneImagesOntoTheTiltedFilm) {
  const FocusedLens fl = dgauss(2.0, 10);
  const ParaxialData& p = fl.paraxial;
  const double f = p.effective_focal_length_mm;
  for (const TiltShift ts :
       {TiltShift{{-6, 0}, {0, 0}}, TiltShift{{3, 4}, {2, -1}}, TiltShift{{0, 1.5}, {0, 0}}}) {
    const FilmPlacement pl(ts, fl.lens->filmZ_mm());
    const ScheimpflugData s = scheimpflug(p, pl);
    const double theta = std::acos(std::cos(ts.tilt_deg.x * kDeg) * std::cos(ts.tilt_deg.y * kDeg));
    EXPECT_NEAR(s.tilt_deg, theta / kDeg, 1e-9);
    EXPECT_NEAR(s.hinge_distance_mm, f / std::sin(theta), 1e-9 * f / std::sin(theta));
    const Vec3 h{0, 0, p.nodal_point_front_z_mm};
    EXPECT_NEAR(length(s.hinge_point_mm - h), f / std::sin(theta), 1e-9 * f / std::sin(theta));
    EXPECT_NEAR(s.hinge_point_mm.z, p.front_focal_point_z_mm, 1e-9 * f);
    // The hinge lies in the plane through the front nodal point parallel to the film.
    EXPECT_NEAR(dot(pl.filmNormal(), s.hinge_point_mm - h), 0, 1e-9 * f);
    // The axial point in focus: the untilted lens equation.
    const double v = pl.filmZ_mm() - p.principal_plane_back_z_mm;
    EXPECT_NEAR(s.object_distance_mm, 1 / (1 / f - 1 / v), 1e-9 * s.object_distance_mm);
    // Points of the plane (two directions in it) image onto the film plane.
    const Vec3 n = s.focus_plane_normal;
    const Vec3 e1 = normalize(cross(n, Vec3{0, 0, 1}));
    const Vec3 e2 = normalize(cross(n, e1));
    const Vec3 origin{0, 0, s.focus_plane_axis_z_mm};
    for (double a : {-400.0, 0.0, 300.0})
      for (double b : {-500.0, 0.0, 250.0}) {
        const Vec3 obj = origin + e1 * a + e2 * b;
        if (!(p.principal_plane_front_z_mm - obj.z > 1.5 * f)) continue;  // real images only
        EXPECT_NEAR(distanceToFocusPlane(s, obj), 0, 1e-9 * 1000);
        const Vec3 img = paraxialImage(p, obj);
        EXPECT_NEAR(dot(pl.filmNormal(), img - pl.lensFromFilm(ts.shift_mm)), 0, 1e-9 * 100)
            << a << " " << b;
      }
    // And a point off the plane images off the film (the check can fail).
    const Vec3 off = origin + n * 200.0;
    EXPECT_GT(std::abs(dot(pl.filmNormal(), paraxialImage(p, off) - pl.lensFromFilm(ts.shift_mm))),
              0.05);
  }
  EXPECT_THROW(scheimpflug(p, FilmPlacement(TiltShift{{0, 0}, {1, 0}}, fl.lens->filmZ_mm())),
               Error);
}

namespace {

// Real rays from an object point (lens space) through a grid on the front vertex plane: the
// displacement along the film normal of the tightest RMS spot from the film plane (mm), and the
// RMS spot radius there and on the film.
struct Focus {
  double best_offset_mm = 0, best_rms_mm = 0, film_rms_mm = 0;
};

Focus bestFocus(const LensSystem& lens, const FilmPlacement& pl, const Vec3& obj) {
  std::vector<Ray> out;
  const double r = lens.interfaces().front().semi_aperture_mm;
  const int n = 160;
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) {
      const Vec3 q{r * (2 * (i + 0.5) / n - 1), r * (2 * (k + 0.5) / n - 1), 0};
      if (q.x * q.x + q.y * q.y > r * r) continue;
      const TraceResult t = lens.tracer().traceFromScene(Ray{obj, normalize(q - obj)});
      if (t.ok()) out.push_back(t.ray);
    }
  const Vec3 nrm = pl.filmNormal(), p0 = pl.lensFromFilm(pl.tiltShift().shift_mm);
  auto rms = [&](double delta) {
    std::vector<Vec3> hits;
    Vec3 c{0, 0, 0};
    for (const Ray& ray : out) {
      const double t = (delta - dot(nrm, ray.origin - p0)) / dot(nrm, ray.direction);
      hits.push_back(ray.origin + ray.direction * t);
      c = c + hits.back();
    }
    c = c / double(hits.size());
    double s = 0;
    for (const Vec3& h : hits) s += dot(h - c, h - c);
    return std::sqrt(s / double(hits.size()));
  };
  Focus f;
  f.best_rms_mm = 1e30;
  for (double d = -3; d <= 3; d += 0.01)
    if (const double v = rms(d); v < f.best_rms_mm) f.best_rms_mm = v, f.best_offset_mm = d;
  f.film_rms_mm = rms(0);
  EXPECT_GT(out.size(), 100u);
  return f;
}

}  // namespace

// Real rays (the exact tracer) from points of the predicted plane of focus, across the field,
// come to their tightest spot within the depth of focus (+-N c, c = 0.03 mm) of the tilted film;
// points of the untilted plane through the same axial point do not, off the hinge's axis.
TEST(TiltShift, RealRaysFromThePredictedPlaneConvergeOnTheTiltedFilm) {
  const FocusedLens fl = dgauss(1.5, 50.0 / 8);
  const LensSystem& lens = *fl.lens;
  const TiltShift ts{{-8, 0}, {0, 0}};
  const FilmPlacement pl(ts, lens.filmZ_mm());
  const ScheimpflugData s = scheimpflug(fl.paraxial, pl);
  const double dof = 8.0 * 1.1 * 0.03;  // working f-number about 8.8 at 1.5 m
  const double zh = fl.paraxial.principal_plane_front_z_mm;
  const Vec3 n1{0, 0, fl.paraxial.nodal_point_front_z_mm},
      n2{0, 0, fl.paraxial.nodal_point_back_z_mm};
  for (double fy : {-9.0, -5.0, 0.0, 5.0, 9.0})
    for (double fx : {0.0, 7.0}) {
      // The object point seen at film point (fx, fy): along the ray through the nodal points
      // (leaving the front one parallel to the film side's line from the film point to the
      // rear one), where it meets the predicted plane.
      const Vec3 film = pl.lensFromFilm({fx, fy});
      const Vec3 d = normalize(n2 - film);
      const Vec3 n = s.focus_plane_normal, h = s.hinge_point_mm;
      const Vec3 obj = n1 + d * (dot(n, h - n1) / dot(n, d));
      const Focus on = bestFocus(lens, pl, obj);
      std::printf(
          "film (%g, %g): best focus %+.2f mm off the film, rms %.4f mm there, %.4f on it\n", fx,
          fy, on.best_offset_mm, on.best_rms_mm, on.film_rms_mm);
      EXPECT_LT(std::abs(on.best_offset_mm), dof) << fx << " " << fy;
      EXPECT_LT(on.film_rms_mm, 0.03) << fx << " " << fy;
      // The untilted plane's point on the same line (the axial depth): off by the film's tilt
      // times the image height, beyond the depth of focus at |fy| = 9.
      const Vec3 flat_obj = n1 + d * ((zh - s.object_distance_mm - n1.z) / d.z);
      const Focus flat = bestFocus(lens, pl, flat_obj);
      if (std::abs(fy) == 9.0) {
        EXPECT_GT(std::abs(flat.best_offset_mm), 2 * dof) << fx << " " << fy;
      }
    }
}

namespace {

double numberAfter(const std::string& out, const std::string& key) {
  const size_t at = out.find("\"" + key + "\": ");
  EXPECT_NE(at, std::string::npos) << key << "\n" << out;
  return at == std::string::npos ? 0 : std::stod(out.substr(at + key.size() + 4));
}

}  // namespace

// `lens info --tilt --shift`: J = EFL / sin(tilt) with the EFL it reports, the tilt angle from
// cos(tilt) = cos(tx) cos(ty), and located refusals (exit 1).
TEST(TiltShift, LensInfoReportsTheHingeAndRefusesBadValues) {
  const std::string lens = lensim::test::lensPath("dgauss.50mm.dat");
  const test::CliResult r =
      test::runLensim("lens info --json --focus-distance 2 --tilt=3,-4 --shift=1,2 " + lens);
  ASSERT_EQ(r.status, 0) << r.out;
  const double efl = numberAfter(r.out, "effective_focal_length_mm");
  const double theta = std::acos(std::cos(3 * kDeg) * std::cos(4 * kDeg));
  EXPECT_NEAR(numberAfter(r.out, "tilt_angle_deg"), theta / kDeg, 1e-9);
  EXPECT_NEAR(numberAfter(r.out, "hinge_distance_mm"), efl / std::sin(theta), 1e-6);
  EXPECT_NEAR(numberAfter(r.out, "film_reach_from_axis_mm"), 17.5 + std::hypot(1.0, 2.0), 1e-9);
  const test::CliResult text = test::runLensim("lens info --tilt=-8,0 " + lens);
  ASSERT_EQ(text.status, 0) << text.out;
  EXPECT_NE(text.out.find("hinge line"), std::string::npos) << text.out;
  for (const char* bad : {"--tilt=50,0", "--tilt=a,b", "--shift=3", "--shift=2000,0"}) {
    const test::CliResult b = test::runLensim(std::string("lens info ") + bad + " " + lens);
    EXPECT_EQ(b.status, 1) << bad << ": " << b.out;
    const std::string opt = std::string(bad).substr(0, std::string(bad).find('='));
    EXPECT_NE(b.out.find(opt + " '"), std::string::npos) << b.out;
  }
}
