// Tilted and decentred surfaces (issue 28, optics/placed_lens.h): a Zemax lens whose coordinate
// breaks leave no single axis is placed in space and traced exactly, surface by surface in each
// surface's own frame. Checked against closed forms (the paraxial image of a decentred lens, the
// lateral shift of a tilted plate) and an independent 3-D trace written here.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/placed_lens.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

constexpr double kD = 587.5618;  // the files' wavelength (the d line): n = n_d = 1.5168
constexpr double kN = 1.5168;
constexpr double kDeg = std::numbers::pi / 180;

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string replaceFirst(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

// An independent 3-D trace: a point and a unit direction, refracted at spheres and planes given
// by their vertex, their axis (unit) and curvature.
struct P3 {
  double x, y, z;
};
P3 operator+(P3 a, P3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
P3 operator-(P3 a, P3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
P3 operator*(double s, P3 a) { return {s * a.x, s * a.y, s * a.z}; }
double dot3(P3 a, P3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
P3 unit(P3 a) { return (1 / std::sqrt(dot3(a, a))) * a; }

struct Ray3 {
  P3 p, d;
};

void refractAt(Ray3& r, P3 vertex, P3 axis, double c, double n1, double n2) {
  P3 q, nrm;
  if (c == 0) {
    q = r.p + (dot3(vertex - r.p, axis) / dot3(r.d, axis)) * r.d;
    nrm = axis;
  } else {
    const P3 centre = vertex + (1 / c) * axis;
    const P3 oc = r.p - centre;
    const double b = dot3(oc, r.d), cc = dot3(oc, oc) - 1 / (c * c);
    const double disc = std::sqrt(b * b - cc);
    const P3 q1 = r.p + (-b - disc) * r.d, q2 = r.p + (-b + disc) * r.d;
    q = dot3(q1 - vertex, q1 - vertex) < dot3(q2 - vertex, q2 - vertex) ? q1 : q2;
    nrm = unit(q - centre);
  }
  if (dot3(nrm, r.d) < 0) nrm = -1.0 * nrm;
  const double mu = n1 / n2, ci = dot3(nrm, r.d);
  const double ct = std::sqrt(1 - mu * mu * (1 - ci * ci));
  r.d = mu * r.d + (ct - mu * ci) * nrm;
  r.p = q;
}

// Where the ray crosses the plane z = z0.
P3 toPlaneZ(const Ray3& r, double z0) { return r.p + ((z0 - r.p.z) / r.d.z) * r.d; }

const std::string kSinglet = "lenses/decentred_singlet.zmx";
constexpr double kDecentre = 0.5, kRadius = 50, kThick = 5, kStopGap = 10, kImage = 93.4528125;

// The decentred singlet's image of a ray through the stop's centre at angle theta (y-z plane):
// independently in 3-D.
double singletImageY3d(double theta) {
  Ray3 r{{0, 0, 0}, {0, std::sin(theta), std::cos(theta)}};
  const P3 z{0, 0, 1};
  refractAt(r, {0, kDecentre, kStopGap}, z, 1 / kRadius, 1, kN);
  refractAt(r, {0, kDecentre, kStopGap + kThick}, z, 0, kN, 1);
  return toPlaneZ(r, kStopGap + kThick + kImage).y;
}

// The same for a finite object point (0, h, -distance) and the ray through the stop's centre.
double singletImageY3dFinite(double h, double distance) {
  Ray3 r{{0, h, -distance}, unit(P3{0, -h, distance})};
  const P3 z{0, 0, 1};
  refractAt(r, {0, kDecentre, kStopGap}, z, 1 / kRadius, 1, kN);
  refractAt(r, {0, kDecentre, kStopGap + kThick}, z, 0, kN, 1);
  return toPlaneZ(r, kStopGap + kThick + kImage).y;
}

// The same paraxially (y-nu trace about the lens's own axis, then the decentre added back).
double singletImageYParaxial(double theta) {
  const double u = std::tan(theta);
  double h = kStopGap * u - kDecentre;  // height on the lens, from its axis
  double nu = u - h * (kN - 1) / kRadius;
  h += kThick * nu / kN;
  return h + kImage * nu + kDecentre;
}

}  // namespace

TEST(PlacedLens, DecentredSingletChiefRayLandsWhereTheClosedFormSays) {
  const LensPrescription p = readLensFile(test::dataPath(kSinglet));
  ASSERT_TRUE(p.noncoaxial_loc.has_value());
  EXPECT_EQ(p.noncoaxial_loc->line, 24);  // the first break's decentre (PARM 2)
  const PlacedLens lens(p, kD);
  for (double deg : {0.0, 0.5, -1.0, 2.0}) {
    SCOPED_TRACE(deg);
    PlacedLens::Field f;
    f.angle_y_deg = deg;
    const auto e = lens.aim(f, {0, 0});  // the chief ray: through the stop's centre
    ASSERT_TRUE(e.has_value());
    const TraceResult t = lens.trace(lens.fieldRay(f, *e));
    ASSERT_TRUE(t.ok());
    const Vec3 img = lens.toImageFrame(t.ray.origin);
    EXPECT_NEAR(img.z, 0, 1e-9);
    EXPECT_NEAR(img.x, 0, 1e-12);
    EXPECT_NEAR(img.y, singletImageY3d(deg * kDeg), 1e-9);
    // The paraxial decentre formula, up to the lens's aberrations at these small heights.
    EXPECT_NEAR(img.y, singletImageYParaxial(deg * kDeg), 2e-3 * (1 + std::abs(deg)));
  }
  // On axis the chief ray meets the lens 0.5 mm below its axis and lands near its focus, on the
  // lens's axis: 0.5 mm above the object axis.
  PlacedLens::Field on_axis;
  const auto e = lens.aim(on_axis, {0, 0});
  ASSERT_TRUE(e.has_value());
  const Vec3 img = lens.toImageFrame(lens.trace(lens.fieldRay(on_axis, *e)).ray.origin);
  EXPECT_NEAR(img.y, kDecentre, 1e-4);
  EXPECT_NEAR(singletImageYParaxial(0), kDecentre, 1e-6);
}

TEST(PlacedLens, FiniteObjectPointsAreTracedFromThePoint) {
  const std::string text = slurp(test::dataPath(kSinglet));
  const LensPrescription p =
      parseZmx(replaceFirst(text, "DISZ INFINITY", "DISZ 500"), "decentred_singlet.zmx");
  ASSERT_TRUE(p.object_distance_mm.has_value());
  const PlacedLens lens(p, kD);
  for (double h : {0.0, 3.0, -7.5}) {
    PlacedLens::Field f;
    f.at_infinity = false;
    f.object_point = {0, h, -500};
    const auto e = lens.aim(f, {0, 0});
    ASSERT_TRUE(e.has_value());
    const TraceResult t = lens.trace(lens.fieldRay(f, *e));
    ASSERT_TRUE(t.ok());
    EXPECT_NEAR(lens.toImageFrame(t.ray.origin).y, singletImageY3dFinite(h, 500), 1e-9) << h;
  }
}

TEST(PlacedLens, DecentredSingletSpotIsAboutTheDecentredAxis) {
  const PlacedLens lens(readLensFile(test::dataPath(kSinglet)), kD);
  const auto s = lens.spot({});
  ASSERT_TRUE(s.has_value());
  EXPECT_GT(s->rays, 100);
  // A 2 mm beam radius at f/24: the spot is the spherical aberration's, centred on the
  // lens's axis to the spot's own size.
  EXPECT_NEAR(s->centroid.y, kDecentre, 2 * s->rms_mm + 1e-6);
  EXPECT_NEAR(s->centroid.x, 0, 1e-9);
  EXPECT_LT(s->rms_mm, 0.01);
  EXPECT_GT(s->rms_mm, 0);
}

TEST(PlacedLens, TiltedPlateShiftsTheRayByTheClosedForm) {
  const std::string text = slurp(test::dataPath("lenses/tilted_plate.zmx"));
  const double t = 10;
  for (double deg : {30.0, 5.0, 60.0, -45.0}) {
    SCOPED_TRACE(deg);
    std::string s = replaceFirst(text, "PARM 3 30", fmt::format("PARM 3 {}", deg));
    s = replaceFirst(s, "PARM 3 -30", fmt::format("PARM 3 {}", -deg));
    const LensPrescription p = parseZmx(s, "tilted_plate.zmx");
    ASSERT_TRUE(p.noncoaxial_loc.has_value());
    const PlacedLens lens(p, kD);
    const TraceResult r = lens.trace({{0, 0, -1}, {0, 0, 1}});
    ASSERT_TRUE(r.ok());
    const double th = deg * kDeg;
    const double shift = t * std::sin(th) *
                         (1 - std::cos(th) / std::sqrt(kN * kN - std::sin(th) * std::sin(th)));
    // The ray leaves parallel to itself, moved toward -y for a plate whose normal tips to -y.
    EXPECT_NEAR(r.ray.origin.y, -shift, 1e-12);
    EXPECT_NEAR(r.ray.origin.x, 0, 1e-12);
    EXPECT_NEAR(r.ray.direction.y, 0, 1e-14);
    EXPECT_NEAR(r.ray.direction.z, 1, 1e-14);
  }
}

TEST(PlacedLens, CoaxialToolsRefuseANonCoaxialLensAtItsBreak) {
  const LensPrescription p = readLensFile(test::dataPath(kSinglet));
  try {
    LensSystem sys(p);
    ADD_FAILURE() << "LensSystem accepted a decentred lens";
  } catch (const Error& e) {
    EXPECT_EQ(e.loc().line, 24) << e.what();
    EXPECT_NE(std::string(e.what()).find("tilted or decentred"), std::string::npos) << e.what();
  }
  EXPECT_THROW(writeLensJson(p), Error);
  // And the non-coaxial tracer refuses a coaxial lens.
  EXPECT_THROW(PlacedLens(readLensFile(test::dataPath("lenses/fold45_twin.zmx")), kD), Error);
}

// Extreme decentres, tilts and thicknesses on either break: a trace, or an error at a line.
TEST(PlacedLens, ExtremeValuesNeverCrash) {
  const std::string f = slurp(test::dataPath(kSinglet));
  const char* values[] = {"1e300",  "-1e308", "90",    "180", "-270", "1e-300",
                          "1.7976931348623157e308", "0.5", "89.99999999"};
  int read = 0, refused = 0;
  for (int parm = 1; parm <= 6; ++parm)
    for (const char* v : values) {
      const std::string from = "PARM " + std::to_string(parm) + " " + (parm == 2 ? "0.5" : "0");
      const std::string text = replaceFirst(f, from, "PARM " + std::to_string(parm) + " " + v);
      try {
        const LensPrescription p = parseZmx(text, "x.zmx");
        if (!p.noncoaxial_loc) {
          ++read;
          continue;
        }
        const PlacedLens lens(p, kD);
        PlacedLens::Field field;
        field.angle_y_deg = 1;
        (void)lens.aim(field, {0, 0});
        (void)lens.spot(field, 9);
        ++read;
      } catch (const Error& e) {
        EXPECT_GT(e.loc().line, 0) << e.what();
        ++refused;
      }
    }
  EXPECT_GT(read, 0);
}

// `lens info` on the decentred singlet: the real chief ray per --field and the spot, no
// first-order data; the options that need a coaxial lens, and --field on one, refused.
TEST(PlacedLens, LensInfoReportsRealRaysAndNoFirstOrderData) {
  const std::string lens = test::dataPath(kSinglet);
  const auto r = test::runLensim("lens info " + lens + " --json --field 0,1 --field 0,-0.5");
  ASSERT_EQ(r.status, 0) << r.out;
  const size_t at = r.out.find("{\n");
  ASSERT_NE(at, std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out.substr(at));
  EXPECT_EQ(j["noncoaxial"]["line"].get<int>(), 24);
  EXPECT_FALSE(j.contains("paraxial"));
  EXPECT_FALSE(j.contains("effective_focal_length_mm"));
  ASSERT_EQ(j["fields"].size(), 2u);
  EXPECT_NEAR(j["fields"][0]["chief_ray_image_mm"][1].get<double>(), singletImageY3d(1 * kDeg),
              1e-9);
  EXPECT_NEAR(j["fields"][1]["chief_ray_image_mm"][1].get<double>(),
              singletImageY3d(-0.5 * kDeg), 1e-9);
  for (const char* m : {"+x", "-x", "+y", "-y"})
    EXPECT_TRUE(j["fields"][0]["marginal_rays_image_mm"][m].is_array()) << m;
  EXPECT_GT(j["fields"][0]["spot"]["rms_radius_mm"].get<double>(), 0);
  EXPECT_EQ(test::runLensim("lens info " + lens + " --tilt 1,0").status, 1);
  const auto configs = test::runLensim("lens info --configs " + lens);
  EXPECT_EQ(configs.status, 1);
  EXPECT_EQ(configs.out.find("EFL"), std::string::npos) << configs.out;  // nothing half-printed
  EXPECT_NE(configs.out.find(":24:10: error:"), std::string::npos) << configs.out;
  EXPECT_EQ(
      test::runLensim("lens info " + test::dataPath("lenses/fold45_twin.zmx") + " --field 0,1")
          .status,
      1);
}

// Mirrors: the 45-degree fold of optics_coordbrk_test with its image decentred 0.3 mm in x is not
// coaxial; traced in space it lands where the coaxial tracer puts the unfolded twin's ray (the
// fold keeps x), less the decentre.
TEST(PlacedLens, FoldWithADecentredImageMatchesItsCoaxialTwin) {
  std::string text = slurp(test::dataPath("lenses/fold45.zmx"));
  text = replaceFirst(text, "SURF 8\n", "SURF 8\n  TYPE COORDBRK\n  PARM 1 0.3\n  DISZ 0\nSURF 9\n");
  const LensPrescription p = parseZmx(text, "fold45_decentred_image.zmx");
  ASSERT_TRUE(p.noncoaxial_loc.has_value());
  const PlacedLens lens(p, kD);
  const LensSystem twin(parseZmx(slurp(test::dataPath("lenses/fold45_twin.zmx")), "twin.zmx"));
  for (double h : {0.5, 2.0, -3.0}) {
    SCOPED_TRACE(h);
    const TraceResult placed = lens.trace({{h, 0, -10}, {0, 0, 1}});
    ASSERT_TRUE(placed.ok());
    const TraceResult tw = twin.tracer().traceFromScene({{h, 0, -10}, {0, 0, 1}});
    ASSERT_TRUE(tw.ok());
    const double zf = twin.filmZ_mm();
    const double x_twin =
        tw.ray.origin.x + tw.ray.direction.x * (zf - tw.ray.origin.z) / tw.ray.direction.z;
    const Vec3 img = lens.toImageFrame(placed.ray.origin);
    EXPECT_NEAR(img.x, x_twin - 0.3, 1e-9);
    EXPECT_NEAR(img.z, 0, 1e-9);
  }
}

// The system aperture: applied where the surfaces up to the stop sit on the object axis (the
// singlet's stop comes first: its semi-diameter is ENPD / 2), kept from DIAM with a note where
// a break comes before the stop.
TEST(PlacedLens, EntrancePupilDiameterSizesAStopInFrontOfTheBreaks) {
  const std::string text = slurp(test::dataPath(kSinglet));
  const LensPrescription p = parseZmx(replaceFirst(text, "ENPD 4", "ENPD 3"), "s.zmx");
  ASSERT_TRUE(p.noncoaxial_loc.has_value());
  EXPECT_NEAR(PlacedLens(p, kD).stopSemiAperture_mm(), 1.5, 1e-12);
  // The stop moved behind the decentred lens: DIAM kept (2 mm), with a note at ENPD.
  std::string behind = replaceFirst(text, "  STOP\n", "");
  behind = replaceFirst(behind, "  CURV 0.0\n  DISZ 0\n  DIAM 10", "  STOP\n  CURV 0.0\n  DISZ 0\n  DIAM 2");
  const LensPrescription q = parseZmx(replaceFirst(behind, "ENPD 4", "ENPD 3"), "s.zmx");
  EXPECT_NEAR(PlacedLens(q, kD).stopSemiAperture_mm(), 2, 1e-12);
  bool noted = false;
  for (const Diagnostic& d : q.diagnostics)
    noted = noted || (d.loc.line == 7 && d.message.find("not applied") != std::string::npos);
  EXPECT_TRUE(noted);
}
