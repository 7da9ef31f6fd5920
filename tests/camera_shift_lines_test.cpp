// Shift keeps straight lines straight and moves the image by exactly the shift (docs/zoom.md,
// "Tilt and shift"), with real rays (the exact double tracer) and the film placement.
//
// A distortion-free lens: a system symmetric about its stop, used at unit magnification (object
// and film planes at mirrored distances), has no distortion to any order (the symmetry
// principle): the chief ray from an object point at height h, point-reflected through the stop's
// centre, is itself, so it lands at -h exactly. Through it, with the lens shifted and the scene
// held in the camera body's frame (an architectural shot), every straight line of an object
// plane parallel to the film images to a straight line (fit residual of the chief rays' film
// points < 1e-9 mm, against a pixel of 0.01-0.04 mm), at film-frame position 2 s - h. Through the
// double Gauss, which distorts, the same lines bow by tens of micrometres (the fit sees it).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/prescription.h"
#include "lensim/optics/tilt_shift.h"
#include "test_paths.h"

using namespace lensim;

namespace {

// Symmetric about the stop (surface 2): radii 40, -150 | 150, -40, the same glass, thicknesses
// 5, 6 | 6, 5.
const char* const kSymmetricLens = R"({"format": "lensim-lens", "units": "mm", "surfaces": [
  {"radius_mm": 40, "thickness_mm": 5, "semi_aperture_mm": 12, "ior": 1.6},
  {"radius_mm": -150, "thickness_mm": 6, "semi_aperture_mm": 12},
  {"radius_mm": 0, "thickness_mm": 6, "semi_aperture_mm": 3, "stop": true},
  {"radius_mm": 150, "thickness_mm": 5, "semi_aperture_mm": 12, "ior": 1.6},
  {"radius_mm": -40, "thickness_mm": 0, "semi_aperture_mm": 12}]})";

struct Bench {
  optics::FocusedLens fl;
  double z_object = 0;  ///< lens space z of the object plane
};

// The lens with its film `film_mm` behind the rear vertex and the object plane `object_mm` in
// front of the front vertex.
Bench bench(const optics::LensPrescription& p, double film_mm, double object_mm) {
  optics::LensSetup setup;
  setup.film_distance_mm = film_mm;
  Bench b{optics::focusLens(p, setup), 0};
  b.z_object = b.fl.lens->interfaces().front().z_mm - object_mm;
  return b;
}

// The chief ray from the lens-space point o (through the stop's centre; Newton's method on the
// direction, derivatives by differences), traced out: nullopt if it does not get through.
std::optional<optics::Ray> chiefRay(const optics::LensSystem& lens, const Vec3& o) {
  const Vec3 stop{0, 0, lens.interfaces()[size_t(*lens.stopIndex())].z_mm};
  Vec2 a{(stop.x - o.x) / (stop.z - o.z), (stop.y - o.y) / (stop.z - o.z)};  // slopes
  auto at = [&](Vec2 s, Vec2* hit) {
    const optics::TraceResult r =
        lens.tracer().traceFromScene(optics::Ray{o, normalize(Vec3{s.x, s.y, 1})}, {});
    *hit = r.stop_point;
    return r;
  };
  for (int it = 0; it < 30; ++it) {
    Vec2 h, hx, hy;
    at(a, &h);
    if (std::hypot(h.x, h.y) < 1e-13) break;
    const double e = 1e-7;
    at({a.x + e, a.y}, &hx);
    at({a.x, a.y + e}, &hy);
    const double j11 = (hx.x - h.x) / e, j21 = (hx.y - h.y) / e;
    const double j12 = (hy.x - h.x) / e, j22 = (hy.y - h.y) / e;
    const double det = j11 * j22 - j12 * j21;
    a = {a.x - (j22 * h.x - j12 * h.y) / det, a.y - (-j21 * h.x + j11 * h.y) / det};
  }
  Vec2 h;
  const optics::TraceResult r = at(a, &h);
  if (!r.ok() || std::hypot(h.x, h.y) > 1e-10) return std::nullopt;
  return r.ray;
}

// The film-frame image (chief ray) of a scene point q given in the camera body's frame (the
// film frame of the unshifted camera: the scene does not move when the lens shifts).
std::optional<Vec2> imageOf(const Bench& b, const optics::FilmPlacement& placed, Vec3 q_body) {
  const double z_film = b.fl.lens->filmZ_mm();
  const Vec3 o = placed.lensFromFilmPoint(q_body);
  EXPECT_NEAR(o.z, q_body.z + z_film, 1e-12);
  const std::optional<optics::Ray> r = chiefRay(*b.fl.lens, o);
  if (!r) return std::nullopt;
  Vec2 f;
  double t = 0;
  if (!placed.intersectFilm(r->origin, r->direction, &f, &t) || !(t > 0)) return std::nullopt;
  return f;
}

// The largest distance of the points from their total-least-squares line.
double lineResidual(const std::vector<Vec2>& pts) {
  Vec2 m{0, 0};
  for (const Vec2& p : pts) m = m + p * (1.0 / double(pts.size()));
  double sxx = 0, sxy = 0, syy = 0;
  for (const Vec2& p : pts) {
    const Vec2 d = p - m;
    sxx += d.x * d.x, sxy += d.x * d.y, syy += d.y * d.y;
  }
  const double angle = 0.5 * std::atan2(2 * sxy, sxx - syy);  // the line's direction
  const Vec2 n{-std::sin(angle), std::cos(angle)};
  double worst = 0;
  for (const Vec2& p : pts)
    worst = std::max(worst, std::abs((p.x - m.x) * n.x + (p.y - m.y) * n.y));
  return worst;
}

// Lines of the object plane (camera body frame, mm): vertical, horizontal and diagonal ones
// across the shifted field.
struct Line {
  Vec2 a, b;
};
const std::array<Line, 4> kLines = {
    {{{-12, -14}, {-12, 18}}, {{9, -14}, {9, 18}}, {{-14, 15}, {14, 15}}, {{-13, -12}, {11, 16}}}};

double worstLineResidual(const Bench& b, const optics::TiltShift& ts, double max_err_to = -1,
                         int* points = nullptr) {
  const optics::FilmPlacement placed(ts, b.fl.lens->filmZ_mm());
  const double zq = b.z_object - b.fl.lens->filmZ_mm();
  double worst = 0;
  for (const Line& l : kLines) {
    std::vector<Vec2> img;
    for (int i = 0; i <= 20; ++i) {
      const Vec2 q = l.a + (l.b - l.a) * (i / 20.0);
      const std::optional<Vec2> f = imageOf(b, placed, {q.x, q.y, zq});
      if (!f) continue;
      img.push_back(*f);
      if (max_err_to >= 0) {  // unit magnification about the lens axis: 2 s - q
        EXPECT_NEAR(f->x, 2 * ts.shift_mm.x - q.x, max_err_to) << q.x << " " << q.y;
        EXPECT_NEAR(f->y, 2 * ts.shift_mm.y - q.y, max_err_to) << q.x << " " << q.y;
      }
    }
    EXPECT_GE(img.size(), 19u) << "chief rays through the lens";
    if (points) *points += int(img.size());
    worst = std::max(worst, lineResidual(img));
  }
  return worst;
}

}  // namespace

TEST(ShiftLines, DistortionFreeLensImagesLinesStraightWhenShifted) {
  const optics::LensPrescription p = optics::parseLensJson(kSymmetricLens, "symmetric.json");
  // Unit magnification: object and film 2f from the principal planes, at mirrored distances
  // from the vertices (the paraxial data of a first placement give f and the principal plane).
  const optics::FocusedLens probe = bench(p, 80, 80).fl;
  const double f = probe.paraxial.effective_focal_length_mm;
  const double d =
      2 * f - (probe.paraxial.principal_plane_front_z_mm - probe.lens->interfaces().front().z_mm);
  const Bench b = bench(p, d, d);
  const double z_stop = b.fl.lens->interfaces()[2].z_mm;
  ASSERT_NEAR(z_stop - b.fl.lens->interfaces().front().z_mm, 11, 1e-12);
  ASSERT_NEAR(b.fl.lens->filmZ_mm() - z_stop, z_stop - b.z_object, 1e-9);
  std::printf("symmetric lens f = %.4f mm, object and film %.4f mm from the vertices\n", f, d);
  for (const Vec2 s : {Vec2{0, 0}, Vec2{0, 6}, Vec2{4, -3}, Vec2{-7, 2}}) {
    optics::TiltShift ts;
    ts.shift_mm = s;
    int points = 0;
    const double r = worstLineResidual(b, ts, 1e-9, &points);
    std::printf("shift (%g, %g) mm: %d chief rays, worst line-fit residual %.3g mm\n", s.x, s.y,
                points, r);
    EXPECT_LT(r, 1e-9);
  }
}

// The fit has teeth: through the double Gauss (focused at 1.5 m; its distortion is about -1% at
// the field's edge) the same lines, shifted by 6 mm, bow measurably.
TEST(ShiftLines, DistortingLensBowsTheLines) {
  const optics::LensPrescription p = optics::readLensFile(test::lensPath("dgauss.50mm.dat"));
  optics::LensSetup setup;
  setup.focus_distance_m = 1.5;
  Bench b{optics::focusLens(p, setup), 0};
  b.z_object = b.fl.lens->filmZ_mm() - 1500;
  optics::TiltShift ts;
  ts.shift_mm = {0, 6};
  // The object plane 1.5 m away: lines scaled up by the magnification's inverse (about 29).
  const double scale = 1500.0 / b.fl.paraxial.effective_focal_length_mm;
  const optics::FilmPlacement placed(ts, b.fl.lens->filmZ_mm());
  double worst = 0;
  for (const Line& l : kLines) {
    std::vector<Vec2> img;
    for (int i = 0; i <= 20; ++i) {
      const Vec2 q = (l.a + (l.b - l.a) * (i / 20.0)) * (scale * 0.8);
      if (std::optional<Vec2> f =
              imageOf(b, placed, {q.x, q.y, b.z_object - b.fl.lens->filmZ_mm()}))
        img.push_back(*f);
    }
    ASSERT_GE(img.size(), 15u);
    worst = std::max(worst, lineResidual(img));
  }
  std::printf("double Gauss shifted 6 mm: worst line-fit residual %.4f mm\n", worst);
  EXPECT_GT(worst, 1e-3);
}

// A scene point held in the lens's frame (it moves with the lens): its image on the film moves
// by exactly the shift, through the double Gauss's real chief ray (1e-9 mm).
TEST(ShiftLines, ShiftMovesTheImageByExactlyTheShift) {
  const optics::LensPrescription p = optics::readLensFile(test::lensPath("dgauss.50mm.dat"));
  optics::LensSetup setup;
  setup.focus_distance_m = 2;
  const optics::FocusedLens fl = optics::focusLens(p, setup);
  const double z_film = fl.lens->filmZ_mm(), z_obj = z_film - 2000;
  const optics::FilmPlacement centred(optics::TiltShift{}, z_film);
  int checked = 0;
  for (const Vec3 o : {Vec3{0, 0, z_obj}, Vec3{150, -90, z_obj}, Vec3{-300, 240, z_obj}}) {
    const std::optional<optics::Ray> r = chiefRay(*fl.lens, o);
    ASSERT_TRUE(r);
    Vec2 f0;
    double t = 0;
    ASSERT_TRUE(centred.intersectFilm(r->origin, r->direction, &f0, &t));
    for (const Vec2 s : {Vec2{0, 5}, Vec2{-3, 4}, Vec2{11.5, -0.25}}) {
      optics::TiltShift ts;
      ts.shift_mm = s;
      const optics::FilmPlacement placed(ts, z_film);
      Vec2 f;
      ASSERT_TRUE(placed.intersectFilm(r->origin, r->direction, &f, &t));
      EXPECT_NEAR(f.x - f0.x, s.x, 1e-9);
      EXPECT_NEAR(f.y - f0.y, s.y, 1e-9);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 9);
}
