// Real image height fields (FTYP 3, docs/lens-files.md): the field angle whose real chief ray
// lands at the given image height, against a meridional ray trace and bisection written here
// (spheres, Snell's law, the model glass's n_d at the d line), its paraxial limit, the
// automatic semi-diameters it gives, and the refusal of a height no chief ray reaches.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/auto_semi_diameter.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/util/error.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A surface of the independent trace: vertex z, curvature, index after it.
struct Surf {
  double z, c, n_after;
};

// Traces the meridional ray from (x, z) with direction (sin th, cos th) through the surfaces
// (index 1 before the first); returns its x where it meets the plane z = z_stop (when asked)
// or the image plane z_image. nullopt when it misses a sphere or is totally reflected.
std::optional<double> traceX(const std::vector<Surf>& s, double x, double z, double th,
                             double z_plane, bool stop_plane_first_after = false,
                             size_t stop_after = 0) {
  double dx = std::sin(th), dz = std::cos(th), n = 1;
  for (size_t i = 0; i <= s.size(); ++i) {
    if (stop_plane_first_after && i == stop_after) return x + (z_plane - z) / dz * dx;
    if (i == s.size()) break;
    const double w = z - s[i].z, c = s[i].c;
    const double b = 2 * c * (x * dx + w * dz) - 2 * dz, cc = c * (x * x + w * w) - 2 * w;
    const double disc = b * b - 4 * c * cc;
    if (disc < 0) return std::nullopt;
    const double t = 2 * cc / (-b + std::sqrt(disc));
    x += t * dx, z += t * dz;
    // Unit normal against the ray: gradient of c (x^2 + w^2) - 2 w.
    double nx = c * x, nz = c * (z - s[i].z) - 1;
    const double len = std::hypot(nx, nz);
    nx /= len, nz /= len;
    if (nx * dx + nz * dz > 0) nx = -nx, nz = -nz;
    const double mu = n / s[i].n_after, cosi = -(nx * dx + nz * dz);
    const double k = 1 - mu * mu * (1 - cosi * cosi);
    if (k < 0) return std::nullopt;
    const double a = mu * cosi - std::sqrt(k);
    dx = mu * dx + a * nx, dz = mu * dz + a * nz;
    n = s[i].n_after;
  }
  return x + (z_plane - z) / dz * dx;
}

// Bisection on the angle until the interval stops shrinking.
template <class F>
double bisect(F f, double lo, double hi, double target) {
  for (int i = 0; i < 200; ++i) {
    const double mid = (lo + hi) / 2;
    if (mid <= lo || mid >= hi) break;
    (f(mid) >= target ? hi : lo) = mid;
  }
  return (lo + hi) / 2;
}

// Lens A: the stop at z = 0 (ENPD 10), a biconvex singlet (R 50, -100; 6 mm of n 1.6) from
// z = 5, the image plane at z = 81. Lens B: a meniscus in front of the stop, the singlet after.
std::string lensA(const std::string& ftyp, const std::string& yfln) {
  return fmt::format(
      "MODE SEQ\nUNIT MM\nENPD 10\n{}\nXFLN 0 0\n{}\nWAVM 1 0.5875618 1\nPWAV 1\n"
      "SURF 0\n  CURV 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0\n  DISZ 5\n"
      "SURF 2\n  CURV 0.02\n  DISZ 6\n  GLAS ___BLANK 1 0 1.6 50 0 0 0 0 0 0\n  DIAM 0\n"
      "SURF 3\n  CURV -0.01\n  DISZ 70\n  DIAM 0\nSURF 4\n  CURV 0\n  DISZ 0\n",
      ftyp, yfln);
}
const std::vector<Surf> kLensA = {{5, 0.02, 1.6}, {11, -0.01, 1.0}};

std::string lensB() {
  return "MODE SEQ\nUNIT MM\nENPD 8\nRAIM 0 1 1 1 0 0 0 0 0\nFTYP 3 0 2 1 0 0 0\nXFLN 0 0\n"
         "YFLN 0 5\nWAVM 1 0.5875618 1\nPWAV 1\nSURF 0\n  CURV 0\n  DISZ INFINITY\n"
         "SURF 1\n  CURV 0.03\n  DISZ 4\n  GLAS ___BLANK 1 0 1.7 40 0 0 0 0 0 0\n  DIAM 12\n"
         "SURF 2\n  CURV 0.04\n  DISZ 6\n  DIAM 12\nSURF 3\n  STOP\n  CURV 0\n  DISZ 4\n"
         "  DIAM 5\nSURF 4\n  CURV 0.02\n  DISZ 6\n  GLAS ___BLANK 1 0 1.6 50 0 0 0 0 0 0\n"
         "  DIAM 14\nSURF 5\n  CURV -0.01\n  DISZ 60\n  DIAM 14\nSURF 6\n  CURV 0\n  DISZ 0\n";
}
const std::vector<Surf> kLensB = {{0, 0.03, 1.7}, {4, 0.04, 1.0}, {14, 0.02, 1.6},
                                  {20, -0.01, 1.0}};

}  // namespace

// Lens A: the chief ray passes the stop's centre, the origin, whether aimed or not.
TEST(RealImageHeight, AgainstAnIndependentTraceAndBisection) {
  const LensPrescription p = parseZmx(lensA("FTYP 0 0 2 1 0 0 0", "YFLN 0 5"), "a.zmx");
  auto h = [](double th) { return *traceX(kLensA, 0, 0, th, 81); };
  for (const double target : {0.5, 5.0, 12.0, 20.0}) {
    SCOPED_TRACE(target);
    const double expected = bisect(h, 0, 40 * kPi / 180, target) * 180 / kPi;
    for (const bool aim : {false, true}) {
      const std::optional<double> deg = realImageHeightFieldAngle(p, target, aim);
      ASSERT_TRUE(deg.has_value());
      EXPECT_NEAR(*deg, expected, 1e-9);
    }
    EXPECT_NEAR(*realImageHeightFieldAngle(p, -target, false), -expected, 1e-9);
  }
  // Paraxial limit: the chief ray's (y, u) traced paraxially from the stop's centre at unit
  // slope gives the image height per radian; a small height's angle is h over it (the real
  // ray departs from it by terms of order angle^2, here 1e-11 relative).
  double y = 0, u = 1, n = 1, z = 0;
  for (const Surf& s : kLensA) {
    y += (s.z - z) * u, z = s.z;
    u = (n * u - y * s.c * (s.n_after - n)) / s.n_after, n = s.n_after;
  }
  y += (81 - z) * u;
  const double small = 1e-4, paraxial_deg = small / y * 180 / kPi;
  EXPECT_NEAR(*realImageHeightFieldAngle(p, small, false), paraxial_deg, 1e-9 * paraxial_deg);
}

// Lens B, ray aiming (RAIM): the chief ray crosses the stop plane (z = 10) at the axis; the
// test aims it there itself (bisection on the ray's height at the launch plane z = -20).
TEST(RealImageHeight, AimedAtTheStopAgainstAnIndependentTrace) {
  const LensPrescription p = parseZmx(lensB(), "b.zmx");
  auto aimed = [](double th) {
    // x at z = -20 such that the ray meets the stop plane at x = 0 (monotone near the chief).
    auto at_stop = [&](double x0) { return *traceX(kLensB, x0, -20, th, 10, true, 2); };
    return bisect(at_stop, -20, 20, 0.0);
  };
  auto h = [&](double th) { return *traceX(kLensB, aimed(th), -20, th, 80); };
  const double expected = bisect(h, 0, 30 * kPi / 180, 5.0) * 180 / kPi;
  const std::optional<double> deg = realImageHeightFieldAngle(p, 5.0, true);
  ASSERT_TRUE(deg.has_value());
  EXPECT_NEAR(*deg, expected, 1e-9);
  // Through the paraxial entrance pupil's centre instead (no aiming) the angle differs: the
  // meniscus's pupil aberration (3e-5 degree).
  EXPECT_GT(std::abs(*realImageHeightFieldAngle(p, 5.0, false) - expected), 1e-5);
}

// FTYP 3 with automatic semi-diameters: the same semi-diameters as FTYP 0 with the angle the
// independent solve gives; a height no chief ray reaches is refused at the FTYP line.
TEST(RealImageHeight, AutomaticSemiDiametersAndRefusal) {
  auto h = [](double th) { return *traceX(kLensA, 0, 0, th, 81); };
  const double deg = bisect(h, 0, 40 * kPi / 180, 12.0) * 180 / kPi;
  const LensPrescription heights = parseZmx(lensA("FTYP 3 0 2 1 0 0 0", "YFLN 0 12"), "a.zmx");
  const LensPrescription angles =
      parseZmx(lensA("FTYP 0 0 2 1 0 0 0", fmt::format("YFLN 0 {:.17g}", deg)), "a.zmx");
  ASSERT_EQ(heights.surfaces.size(), angles.surfaces.size());
  for (size_t i = 0; i < heights.surfaces.size(); ++i)
    EXPECT_NEAR(heights.surfaces[i].semiAperture_mm(), angles.surfaces[i].semiAperture_mm(),
                1e-9);
  // A finite object: refused at the FTYP line (real image heights are solved for infinity).
  std::string finite = lensA("FTYP 3 0 2 1 0 0 0", "YFLN 0 12");
  finite.replace(finite.find("DISZ INFINITY"), 13, "DISZ 500");
  try {
    parseZmx(finite, "finite.zmx");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.loc().line, 4) << e.what();
    EXPECT_NE(e.message().find("real (3) image heights"), std::string::npos) << e.what();
  }
  try {
    parseZmx(lensA("FTYP 3 0 2 1 0 0 0", "YFLN 0 1000"), "far.zmx");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.loc().line, 4) << e.what();
    EXPECT_NE(e.message().find("no real chief ray reaches the image height 1000 mm"),
              std::string::npos)
        << e.what();
  }
}
