// Rectangular and elliptical surface apertures (Zemax SQAP, ELAP): rays just inside pass and
// rays just outside stop, in the double, float and batched tracers. Rays parallel to the axis
// meet the first surface from the scene, and the last from the film, at their own (x, y) whatever
// the surface's shape, so the closed forms are |x| <= hx, |y| <= hy and
// (x / hx)^2 + (y / hy)^2 <= 1. The reader's refusals are located at the bad value.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/util/error.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

// A plano-convex singlet behind a stop: surface 2 (plane, N-BK7 after it) carries `front`,
// surface 3 (R = -20 mm, `back_type`) carries `back`.
std::string writeLens(const std::string& name, const std::string& front, const std::string& back,
                      const std::string& back_type = "STANDARD") {
  const auto path = std::filesystem::temp_directory_path() / ("lensim_aperture_" + name + ".zmx");
  std::ofstream f(path);
  f << "MODE SEQ\nUNIT MM X W X CM MR CPMM\nENPD 12\nWAVM 1 0.5876 1\nPWAV 1\n"
       "SURF 0\n  TYPE STANDARD\n  CURV 0\n  DISZ INFINITY\n"
       "SURF 1\n  STOP\n  TYPE STANDARD\n  CURV 0\n  DISZ 2\n  DIAM 6\n"
       "SURF 2\n  TYPE STANDARD\n  CURV 0\n  DISZ 4\n  GLAS N-BK7 0 0 1.5168 64.17\n"
    << "  " << front << "\n"
    << "SURF 3\n  TYPE " << back_type << "\n  CURV -0.05\n"
    << (back_type == "EVENASPH" ? "  PARM 2 1e-5\n" : "") << "  DISZ 35\n  " << back << "\n"
    << "SURF 4\n  TYPE STANDARD\n  CURV 0\n  DISZ 0\n  DIAM 10\n";
  return path.string();
}

bool passesFromScene(const LensSystem& lens, double x, double y, int* surface = nullptr) {
  const TraceResult r = lens.tracer().traceFromScene({{x, y, -5}, {0, 0, 1}});
  if (surface) *surface = r.blocked_surface;
  if (!r.ok()) {
    EXPECT_EQ(r.reason, BlockReason::Aperture) << x << " " << y;
  }
  return r.ok();
}

// From the film, parallel to the axis: the double tracer, the float tracer and the float batch
// agree, and the result is returned.
bool passesFromFilm(const LensSystem& lens, double x, double y) {
  const double z = lens.filmZ_mm();
  const TraceResult d = lens.tracer().traceFromFilm({{x, y, z}, {0, 0, -1}});
  const RayT<float> rf{{float(x), float(y), float(z)}, {0, 0, -1}};
  const TraceResultT<float> f = lens.tracerFloat().traceFromFilm(rf);
  RayT<float> rays[3] = {rf, rf, rf};
  TraceResultT<float> batch[3];
  lens.tracerFloat().traceFromFilmBatch(rays, 3, batch);
  EXPECT_EQ(d.reason, f.reason) << x << " " << y;
  for (const auto& b : batch) {
    EXPECT_EQ(b.reason, f.reason) << x << " " << y;
    EXPECT_EQ(b.blocked_surface, f.blocked_surface) << x << " " << y;
  }
  if (!d.ok()) {
    EXPECT_EQ(d.reason, BlockReason::Aperture) << x << " " << y;
    EXPECT_EQ(d.blocked_surface, 2) << x << " " << y;  // the back surface
  }
  return d.ok();
}

}  // namespace

TEST(SurfaceAperture, RectangleFromTheScene) {
  const LensSystem lens(readLensFile(writeLens("rect_front", "SQAP 4 2 0", "DIAM 10")));
  const auto& in = lens.interfaces()[1];
  EXPECT_EQ(in.aperture_shape, ApertureShape::Rectangle);
  EXPECT_DOUBLE_EQ(in.semi_aperture_mm, std::hypot(4.0, 2.0));  // the circle around it
  int surface = -1;
  EXPECT_TRUE(passesFromScene(lens, 3.99, 0));
  EXPECT_FALSE(passesFromScene(lens, 4.01, 0, &surface));
  EXPECT_EQ(surface, 1);
  EXPECT_TRUE(passesFromScene(lens, 0, -1.99));
  EXPECT_FALSE(passesFromScene(lens, 0, -2.01));
  // A corner: 4.35 mm from the axis, beyond a 4 mm circle, inside the rectangle.
  EXPECT_TRUE(passesFromScene(lens, -3.95, 1.95));
  EXPECT_FALSE(passesFromScene(lens, -3.95, 2.02));
  EXPECT_FALSE(passesFromScene(lens, 3.0, 3.0));  // inside the circle around it, outside
}

TEST(SurfaceAperture, RectangleFromTheFilmAllTracers) {
  const LensSystem lens(readLensFile(writeLens("rect_back", "DIAM 10", "SQAP 4 2 0")));
  EXPECT_TRUE(passesFromFilm(lens, 3.99, 0));
  EXPECT_FALSE(passesFromFilm(lens, 4.01, 0));
  EXPECT_TRUE(passesFromFilm(lens, 0, 1.99));
  EXPECT_FALSE(passesFromFilm(lens, 0, 2.01));
  EXPECT_TRUE(passesFromFilm(lens, 3.95, -1.95));
  EXPECT_FALSE(passesFromFilm(lens, 3.0, -3.0));
}

TEST(SurfaceAperture, EllipseOnAnAsphereFromTheFilmAllTracers) {
  const LensSystem lens(
      readLensFile(writeLens("ellipse_back", "DIAM 10", "ELAP 4 2 0", "EVENASPH")));
  EXPECT_EQ(lens.interfaces()[2].aperture_shape, ApertureShape::Ellipse);
  EXPECT_DOUBLE_EQ(lens.interfaces()[2].semi_aperture_mm, 4.0);
  EXPECT_TRUE(passesFromFilm(lens, 3.99, 0));
  EXPECT_FALSE(passesFromFilm(lens, 4.01, 0));
  EXPECT_TRUE(passesFromFilm(lens, 0, -1.99));
  EXPECT_FALSE(passesFromFilm(lens, 0, -2.01));
  // (x/4)^2 + (y/2)^2 = 0.9481 and 1.0525: inside and outside, both inside the rectangle.
  EXPECT_TRUE(passesFromFilm(lens, 2.9, 1.3));
  EXPECT_FALSE(passesFromFilm(lens, 3.0, -1.4));
}

TEST(SurfaceAperture, BadApertureLinesAreRefusedAtTheValue) {
  struct Case {
    std::string line, expect;
  };
  for (const Case& c : {Case{"SQAP 0 2 0", ":21:8: error: surface 2: SQAP half-widths 0 2"},
                        Case{"ELAP 3 -1 0", ":21:10: error: surface 2: ELAP half-widths 3 -1"},
                        Case{"SQAP 3 2 1", ":21:12: error: surface 2: SQAP: value 3 is 1"},
                        Case{"SQOB 3 2 0", "SQOB"}}) {
    try {
      readLensFile(writeLens("bad", c.line, "DIAM 10"));
      ADD_FAILURE() << c.line << " was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
    }
  }
}
