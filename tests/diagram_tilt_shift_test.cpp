// The lens diagram of a tilted and shifted lens (optics/diagram.h): the film drawn where it
// crosses the section through the lens axis, and the bundles starting on it, against the
// placement written out here (rotations by hand, as optics_tilt_shift_test does).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include "cli_run.h"
#include "lensim/optics/diagram.h"
#include "lensim/util/error.h"
#include "test_paths.h"

namespace lensim {
namespace {

using namespace optics;
constexpr double kRad = std::numbers::pi / 180;

FocusedLens dgauss() {
  LensSetup setup;
  setup.focus_distance_m = 2;
  return focusLens(readLensFile(test::lensPath("dgauss.50mm.dat")), setup);
}

// Lens space from the film frame: p_lens = R^T (p - s) + (0, 0, z_film), R = Ry(ty) Rx(tx).
Vec3 lensFromFilm(Vec3 p, double tx_deg, double ty_deg, Vec2 s, double z_film) {
  const double a = tx_deg * kRad, b = ty_deg * kRad;
  p = {p.x - s.x, p.y - s.y, p.z};
  // R^T = Rx^T Ry^T.
  const Vec3 q{std::cos(b) * p.x - std::sin(b) * p.z, p.y, std::sin(b) * p.x + std::cos(b) * p.z};
  return {q.x, std::cos(a) * q.y + std::sin(a) * q.z,
          -std::sin(a) * q.y + std::cos(a) * q.z + z_film};
}
// The film frame from lens space (the inverse of the above).
Vec3 filmFromLens(Vec3 p, double tx_deg, double ty_deg, Vec2 s, double z_film) {
  const double a = tx_deg * kRad, b = ty_deg * kRad;
  p.z -= z_film;
  const Vec3 q{p.x, std::cos(a) * p.y - std::sin(a) * p.z, std::sin(a) * p.y + std::cos(a) * p.z};
  return {std::cos(b) * q.x + std::sin(b) * q.z + s.x, q.y + s.y,
          -std::sin(b) * q.x + std::cos(b) * q.z};
}

struct Case {
  double tx, ty;
  Vec2 shift;
};

TEST(DiagramTiltShift, FilmAndBundlesLieOnThePlacedFilm) {
  const FocusedLens fl = dgauss();
  const double z_film = fl.lens->filmZ_mm(), h = 20;
  for (const Case& c : {Case{0, 8, {0, 0}}, Case{-6, 0, {0, 4}}, Case{5, 0, {3, 0}},
                        Case{3, 4, {0, 0}}, Case{0, 0, {0, 6}}, Case{0, 0, {-2, 5}}}) {
    DiagramOptions opts;
    opts.film_diagonal_mm = 2 * h;
    opts.fields = {-1, 0, 1};
    opts.tilt_shift.tilt_deg = {c.tx, c.ty};
    opts.tilt_shift.shift_mm = c.shift;
    const LensDiagram d = buildLensDiagram(fl, opts);
    ASSERT_TRUE(d.film_segment);
    const Vec2 a = (*d.film_segment)[0], b = (*d.film_segment)[1];
    // The film's angle to the lens's normal plane: cos = cos tx cos ty.
    const double drawn = std::atan2(std::abs(b.x - a.x), std::abs(b.y - a.y));
    EXPECT_NEAR(std::cos(drawn), std::cos(c.tx * kRad) * std::cos(c.ty * kRad), 1e-12);
    // The section is the plane through the lens axis turned by phi about it; the film meets it
    // along a chord of the film's circle of radius h about the film's centre.
    const Vec3 n = lensFromFilm({0, 0, 1}, c.tx, c.ty, {0, 0}, 0);
    const Vec3 centre = lensFromFilm({0, 0, 0}, c.tx, c.ty, c.shift, z_film);
    const double phi =
        std::hypot(n.x, n.y) > 1e-12 ? std::atan2(n.y, n.x) : std::atan2(centre.y, centre.x);
    auto unturn = [&](Vec2 zx) {  // a section point (z, x) in lens space
      return Vec3{zx.y * std::cos(phi), zx.y * std::sin(phi), zx.x};
    };
    const Vec3 fa = filmFromLens(unturn(a), c.tx, c.ty, c.shift, z_film);
    const Vec3 fb = filmFromLens(unturn(b), c.tx, c.ty, c.shift, z_film);
    EXPECT_NEAR(fa.z, 0, 1e-9);
    EXPECT_NEAR(fb.z, 0, 1e-9);
    // Both ends on the film's circle (radius h about its centre, the film frame's origin).
    EXPECT_NEAR(std::hypot(fa.x, fa.y), h, 1e-9);
    EXPECT_NEAR(std::hypot(fb.x, fb.y), h, 1e-9);
    // Every bundle starts on the film: at the chord's ends and middle.
    ASSERT_EQ(d.rays.size(), 3u * 11);
    for (const DiagramRay& r : d.rays) {
      EXPECT_NEAR(r.start.origin.y, 0, 1e-12);
      const Vec3 q =
          filmFromLens(unturn({r.start.origin.z, r.start.origin.x}), c.tx, c.ty, c.shift, z_film);
      EXPECT_NEAR(q.z, 0, 1e-9);
      const double from_centre = std::hypot(q.x, q.y);
      EXPECT_NEAR(from_centre, r.field == 1 ? std::hypot(fa.x + fb.x, fa.y + fb.y) / 2 : h, 1e-9);
    }
  }
}

TEST(DiagramTiltShift, RefusedWhereTheSectionCannotShowIt) {
  // An anamorphic lens is drawn in its x-z section only: a tilt about x is refused.
  LensPrescription p = readLensFile(test::lensPath("toroidal-anamorphic.50mm.zmx"));
  const FocusedLens fl = focusLens(p, {});
  DiagramOptions opts;
  opts.tilt_shift.tilt_deg = {5, 0};
  EXPECT_THROW(buildLensDiagram(fl, opts), Error);
  opts.tilt_shift.tilt_deg = {0, 5};  // about y: the x-z section
  EXPECT_NO_THROW(buildLensDiagram(fl, opts));
}

TEST(DiagramTiltShift, CliDrawTakesTiltAndShift) {
  const std::string out = ::testing::TempDir() + "/tilt_draw.svg";
  const test::CliResult r = test::runLensim("lens draw " + test::lensPath("dgauss.50mm.dat") +
                                            " --tilt=0,8 --shift=3,0 --focus-distance 2 -o " + out);
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream f(out);
  std::stringstream svg;
  svg << f.rdbuf();
  EXPECT_NE(svg.str().find("film (tilted/shifted)"), std::string::npos);
  EXPECT_NE(svg.str().find("tilt (0, 8)°, shift (3, 0) mm"), std::string::npos);
  const test::CliResult ana = test::runLensim(
      "lens draw " + test::lensPath("toroidal-anamorphic.50mm.zmx") + " --tilt=3,0 -o " + out);
  EXPECT_EQ(ana.status, 1) << ana.out;
  EXPECT_NE(ana.out.find("rotationally symmetric"), std::string::npos) << ana.out;
  const test::CliResult bad = test::runLensim("lens draw " + test::lensPath("dgauss.50mm.dat") +
                                              " --tilt=0,8 --fields=-2,0 -o " + out);
  EXPECT_EQ(bad.status, 1) << bad.out;
  EXPECT_NE(bad.out.find("--fields -2,0"), std::string::npos) << bad.out;
}

}  // namespace
}  // namespace lensim
