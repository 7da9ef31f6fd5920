// Diffraction gratings (issue 28, Zemax TYPE DGRATING, optics/grating.h): traced by the non-coaxial
// tracer and checked against the grating equation in closed form, written here: sin theta = m
// lambda / d at normal incidence, n' sin theta' = n sin theta + m lambda / d in the plane of the
// grating vector, the component along the lines kept in conical incidence, a reflecting grating
// in Littrow returning the ray onto itself, the vector equation at a point of a curved grating
// (its normal from the sphere's centre), evanescent orders blocked; the optiland sample files
// read and their chief rays leave as the closed form says; the cameras refuse gratings at the
// scene's Camera line.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
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

constexpr double kDeg = std::numbers::pi / 180;

// A one-surface lens: a grating (lines per micrometre, order) of curvature `curv` at the stop,
// in air, followed by `after` (a GLAS line, or "" for air; "  GLAS MIRROR" reflects it back).
std::string gratingZmx(double lines_per_um, int order, const std::string& after = "",
                       double curv = 0) {
  const bool mirror = after.find("MIRROR") != std::string::npos;
  return fmt::format(
      "MODE SEQ\nENPD 10\nWAVM 1 0.55 1\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n"
      "  TYPE DGRATING\n  CURV {}\n  PARM 1 {}\n  PARM 2 {}\n  DISZ {}\n{}  DIAM 8\n"
      "SURF 2\n  DISZ 0\n",
      curv, lines_per_um, order, mirror ? -10 : 10, after.empty() ? "" : after + "\n");
}

PlacedLens gratingLens(double lines_per_um, int order, const std::string& after = "",
                       double curv = 0) {
  const LensPrescription p = parseZmx(gratingZmx(lines_per_um, order, after, curv), "g.zmx");
  return PlacedLens(p, 550);
}

// The direction leaving the grating of a ray aimed at its vertex region from z = -5.
TraceResult through(const PlacedLens& lens, Vec3 dir, Vec2 at = {0, 0}) {
  dir = normalize(dir);
  const Vec3 hit{at.x, at.y, 0};
  return lens.trace({hit - dir * (5 / dir.z), dir});
}

std::string optiland(const std::string& name) {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/optiland/" + name;
}

}  // namespace

// Normal incidence on a plane grating in air: sin theta = m lambda / d, per wavelength and order;
// an order with |m lambda / d| > 1 is evanescent and blocked.
TEST(Grating, NormalIncidenceSendsEachWavelengthToItsClosedFormAngle) {
  constexpr double lines = 0.6;  // per micrometre: d = 1.667 um
  int blocked = 0, passed = 0;
  for (int m = -3; m <= 3; ++m) {
    PlacedLens lens = gratingLens(lines, m);
    for (double nm = 400; nm <= 700; nm += 25) {
      SCOPED_TRACE(fmt::format("order {}, {} nm", m, nm));
      lens.setWavelength(nm);
      const double s = m * (nm / 1000) * lines;
      for (Vec2 at : {Vec2{0, 0}, Vec2{1.5, -2}}) {
        const TraceResult r = through(lens, {0, 0, 1}, at);
        if (std::abs(s) >= 1) {
          EXPECT_EQ(r.blocked_surface, 0);
          EXPECT_EQ(r.reason, BlockReason::Evanescent);
          ++blocked;
          continue;
        }
        ASSERT_TRUE(r.ok()) << blockReasonName(r.reason);
        EXPECT_NEAR(r.ray.direction.x, 0, 1e-12);
        EXPECT_NEAR(r.ray.direction.y, s, 1e-12);
        EXPECT_NEAR(r.ray.direction.z, std::sqrt(1 - s * s), 1e-12);
        ++passed;
      }
    }
  }
  EXPECT_GT(blocked, 0);  // order 3 beyond 555 nm
  EXPECT_GT(passed, 100);
}

// Oblique incidence in the plane of the grating vector (y-z), from air into a glass: n' sin
// theta' = n sin theta + m lambda / d.
TEST(Grating, ObliqueIncidenceFollowsTheGratingEquation) {
  for (int m : {-2, -1, 0, 1, 2}) {
    PlacedLens lens = gratingLens(0.3, m, "  GLAS ___BLANK 1 0 1.6 40");
    for (double nm : {450.0, 550.0, 650.0}) {
      lens.setWavelength(nm);
      const double n2 = lens.glasses()[0].index(nm);
      ASSERT_GT(n2, 1.55);
      for (double deg : {-40.0, -12.0, 0.0, 25.0, 60.0}) {
        SCOPED_TRACE(fmt::format("order {}, {} nm, {} deg", m, nm, deg));
        const double sin_in = std::sin(deg * kDeg);
        const double sin_out = (sin_in + m * (nm / 1000) * 0.3) / n2;
        const TraceResult r = through(lens, {0, sin_in, std::cos(deg * kDeg)}, {0.5, 1});
        ASSERT_TRUE(r.ok());
        EXPECT_NEAR(r.ray.direction.y, sin_out, 1e-12);
        EXPECT_NEAR(r.ray.direction.x, 0, 1e-12);
        EXPECT_NEAR(r.ray.direction.z, std::sqrt(1 - sin_out * sin_out), 1e-12);
      }
    }
  }
}

// Conical incidence (a component along the lines, x): n' times the x direction cosine is kept,
// the y one gains m lambda / d, and the ray stays a unit vector going on.
TEST(Grating, ConicalIncidenceKeepsTheComponentAlongTheLines) {
  PlacedLens lens = gratingLens(0.5, 1, "  GLAS ___BLANK 1 0 1.5 60");
  for (double nm : {480.0, 620.0}) {
    lens.setWavelength(nm);
    const double n2 = lens.glasses()[0].index(nm);
    for (const Vec3 d0 : {Vec3{0.3, 0.2, 1}, Vec3{-0.5, -0.4, 1}, Vec3{0.7, 0, 1}}) {
      const Vec3 d = normalize(d0);
      const TraceResult r = through(lens, d, {-1, 2});
      ASSERT_TRUE(r.ok());
      const Vec3 o = r.ray.direction;
      EXPECT_NEAR(n2 * o.x, d.x, 1e-12);
      EXPECT_NEAR(n2 * o.y, d.y + 1 * (nm / 1000) * 0.5, 1e-12);
      EXPECT_NEAR(dot(o, o), 1, 1e-14);
      EXPECT_GT(o.z, 0);
    }
  }
}

// A reflecting grating in Littrow (2 d sin theta = m lambda) sends the ray back onto itself, for
// either sign of the order; order 0 is a plane mirror.
TEST(Grating, ReflectingGratingInLittrowReturnsTheRayOntoItself) {
  constexpr double lines = 1.2, nm = 550;
  for (int m : {-2, -1, 1, 2}) {
    SCOPED_TRACE(m);
    const PlacedLens lens = gratingLens(lines, m, "  GLAS MIRROR");
    const double s = m * (nm / 1000) * lines / 2;  // sin theta = m lambda / (2 d)
    const Vec3 d{0, -s, std::sqrt(1 - s * s)};
    const TraceResult r = through(lens, d, {0.3, -0.2});
    ASSERT_TRUE(r.ok()) << blockReasonName(r.reason);
    EXPECT_NEAR(r.ray.direction.x, -d.x, 1e-12);
    EXPECT_NEAR(r.ray.direction.y, -d.y, 1e-12);
    EXPECT_NEAR(r.ray.direction.z, -d.z, 1e-12);
  }
  const PlacedLens mirror = gratingLens(lines, 0, "  GLAS MIRROR");
  const Vec3 d = normalize(Vec3{0.1, 0.3, 1});
  const TraceResult r = through(mirror, d);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r.ray.direction.x, d.x, 1e-12);
  EXPECT_NEAR(r.ray.direction.y, d.y, 1e-12);
  EXPECT_NEAR(r.ray.direction.z, -d.z, 1e-12);
}

// On a curved grating the vector equation holds at the hit point with the sphere's own normal
// (from its centre, computed here) and the ruling axis y projected into the tangent plane:
// n' (s' - (s'.N) N) = n (s - (s.N) N) + (m lambda / d) (y - (y.N) N).
TEST(Grating, CurvedGratingObeysTheVectorEquationAtEachPoint) {
  constexpr double curv = 1.0 / 40, lines = 0.4;
  for (const char* after : {"  GLAS ___BLANK 1 0 1.5 60", "  GLAS MIRROR"}) {
    SCOPED_TRACE(after);
    const bool mirror = std::string(after).find("MIRROR") != std::string::npos;
    for (int m : {-1, 2}) {
      const PlacedLens lens = gratingLens(lines, m, after, curv);
      const double n2 = mirror ? 1.0 : lens.glasses().back().index(550);
      const double k = m * 0.55 * lines;
      for (const Vec2 at : {Vec2{0, 0}, Vec2{3, -2}, Vec2{-4, 5}, Vec2{2, 6}}) {
        const Vec3 d = normalize(Vec3{0.05, -0.1, 1});
        std::vector<Vec3> path;
        const Vec3 start = Vec3{at.x, at.y, 0} - d * 5;
        // Unclipped: the stop (ENPD 10) is narrower than some of these points.
        const TraceResult r = lens.trace({start, d}, TraceOptions{false, false}, &path);
        ASSERT_TRUE(r.ok());
        ASSERT_GE(path.size(), 3u);
        const Vec3 p = path[path.size() - 2];  // the grating's hit (a plane stop may precede it)
        const Vec3 centre{0, 0, 1 / curv};
        EXPECT_NEAR(length(p - centre), 1 / curv, 1e-9);  // on the sphere
        const Vec3 nrm = normalize(p - centre);
        const Vec3 y{0, 1, 0};
        const Vec3 q = y - nrm * dot(y, nrm);
        const Vec3 o = r.ray.direction;
        const Vec3 lhs = (o - nrm * dot(o, nrm)) * n2;
        const Vec3 rhs = (d - nrm * dot(d, nrm)) + q * k;
        EXPECT_NEAR(lhs.x, rhs.x, 1e-12);
        EXPECT_NEAR(lhs.y, rhs.y, 1e-12);
        EXPECT_NEAR(lhs.z, rhs.z, 1e-12);
        EXPECT_NEAR(dot(o, o), 1, 1e-14);
        // Transmitted: on the far side of the surface; reflected: back on the near side.
        EXPECT_EQ(dot(o, nrm) * dot(d, nrm) > 0, !mirror);
      }
    }
  }
}

// Traced backward (as a camera traces), a ray retraces the forward one through the grating.
TEST(Grating, BackwardTraceRetracesTheForwardOne) {
  for (const char* after : {"  GLAS ___BLANK 1 0 1.5 60", "  GLAS MIRROR"}) {
    const PlacedLens lens = gratingLens(0.4, 1, after, 1.0 / 50);
    const Vec3 d = normalize(Vec3{0.02, 0.15, 1});
    const TraceResult f = lens.trace({Vec3{1, -2, -5}, d}, TraceOptions{false, false});
    ASSERT_TRUE(f.ok());
    const TraceResult b =
        lens.traceBackward({f.ray.origin, -f.ray.direction}, TraceOptions{false, false});
    ASSERT_TRUE(b.ok());
    EXPECT_NEAR(b.ray.direction.x, -d.x, 1e-12);
    EXPECT_NEAR(b.ray.direction.y, -d.y, 1e-12);
    EXPECT_NEAR(b.ray.direction.z, -d.z, 1e-12);
  }
}

// What a grating's parameters may be: an integer order, parameters 1 and 2 only; and it is not
// the object or image surface.
TEST(Grating, BadParametersAreRefusedAtTheirLine) {
  std::string text = gratingZmx(0.5, 1);
  const auto errorOf = [](const std::string& t) -> Error {
    try {
      parseZmx(t, "g.zmx");
    } catch (const Error& e) {
      return e;
    }
    return Error("no error");
  };
  std::string half = text;
  half.replace(half.find("PARM 2 1"), 8, "PARM 2 1.5");
  const Error e1 = errorOf(half);
  EXPECT_EQ(e1.loc().line, 11) << e1.what();
  EXPECT_NE(std::string(e1.what()).find("must be an integer"), std::string::npos) << e1.what();
  std::string extra = text;
  extra.replace(extra.find("  DISZ 10"), 0, "  PARM 3 2\n");
  const Error e2 = errorOf(extra);
  EXPECT_EQ(e2.loc().line, 12) << e2.what();
  EXPECT_NE(std::string(e2.what()).find("PARM 3"), std::string::npos) << e2.what();
  std::string image = text;
  image.replace(image.find("SURF 2\n"), 7, "SURF 2\n  TYPE DGRATING\n");
  const Error e3 = errorOf(image);
  EXPECT_EQ(e3.loc().line, 15) << e3.what();
  EXPECT_NE(std::string(e3.what()).find("as the image surface"), std::string::npos) << e3.what();
}

// The optiland sample files read (their TYPE DGRATING line is where the symmetry is lost), the
// coaxial tracer refuses them there, and the flat grating's chief rays leave as the grating
// equation says: through the plane N-BK7 window n sin theta is kept, so into air behind the
// grating sin theta' = sin theta + m lambda / d (m = -1, 0.2 lines/um, 0.587 um).
TEST(Grating, OptilandSampleFilesReadAndTheFlatOnesChiefRaysAreExact) {
  struct File {
    const char* name;
    int line, order;
  };
  for (const File& f : {File{"curved_reflective_grating.zmx", 77, 1},
                        File{"curved_transmission_grating.zmx", 102, -1},
                        File{"flat_transmission_grating.zmx", 102, -1}}) {
    SCOPED_TRACE(f.name);
    const LensPrescription p = readLensFile(optiland(f.name));
    ASSERT_TRUE(p.noncoaxial_loc.has_value());
    EXPECT_EQ(p.noncoaxial_loc->line, f.line);
    const LensSurface* g = firstGrating(p);
    ASSERT_NE(g, nullptr);
    EXPECT_EQ(g->grating->lines_per_um, 0.2);
    EXPECT_EQ(g->grating->order, f.order);
    try {
      const LensSystem sys(p);
      ADD_FAILURE() << "the coaxial tracer accepted a grating";
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, f.line);
      EXPECT_NE(std::string(e.what()).find("diffraction grating"), std::string::npos) << e.what();
    }
    // Its rows taken as a coaxial lens (as a placed build's twin is) are refused too.
    LensPrescription twin = p;
    twin.noncoaxial_loc.reset();
    for (LensSurface& s : twin.surfaces) s.frame.reset();
    EXPECT_THROW(LensSystem{twin}, Error);
  }
  const LensPrescription p =
      readLensFile(optiland("flat_transmission_grating.zmx"));
  const PlacedLens lens(p, 587);
  for (double field : {0.0, 5.0, 10.0}) {
    PlacedLens::Field fld;
    fld.angle_y_deg = field;
    const auto e = lens.aim(fld, {0, 0});
    ASSERT_TRUE(e.has_value());
    const TraceResult r = lens.trace(lens.fieldRay(fld, *e));
    ASSERT_TRUE(r.ok());
    const double sin_in = std::sin(field * kDeg);
    const double sin_out = sin_in - 0.587 * 0.2;
    EXPECT_NEAR(r.ray.direction.y, sin_out, 1e-12) << field;
    EXPECT_NEAR(r.ray.direction.x, 0, 1e-12);
  }
}

// The program that wrote the reflective sample computed its image surface's semi-diameter (DIAM
// 24.799609695789151, the largest ray height there) from the rays of the fields (0, 0), (0, 10)
// and (10, 0) degrees through the edge of the entrance pupil (ENPD 15 mm at the mirror's vertex
// plane, no ray aiming); they reproduce it. The highest ray meets the curved grating 7.5 mm off
// its vertex, so this checks the order's sign and the projected grating vector together. (The
// transmitting samples' image DIAMs are not reproduced: docs/lens-files.md "Gratings".)
TEST(Grating, ReflectiveSampleImageSemiDiameterIsReproduced) {
  constexpr double kImageDiam = 24.799609695789151;  // the file's image surface DIAM
  const LensPrescription p = readLensFile(optiland("curved_reflective_grating.zmx"));
  const PlacedLens lens(p, 587);
  double highest = 0;
  for (const auto& [fx, fy] : {std::pair{0.0, 0.0}, std::pair{0.0, 10.0}, std::pair{10.0, 0.0}}) {
    const Vec3 d = normalize(Vec3{std::tan(fx * kDeg), std::tan(fy * kDeg), 1});
    for (int k = 0; k < 3600; ++k) {
      const double phi = 2 * std::numbers::pi * k / 3600;
      const Vec3 at{7.5 * std::cos(phi), 7.5 * std::sin(phi), 0};  // the pupil at z = 0
      const TraceResult r = lens.trace({at - d * (20 / d.z), d}, TraceOptions{false, false});
      ASSERT_TRUE(r.ok());
      const Vec3 q = lens.toImageFrame(r.ray.origin);
      highest = std::max(highest, std::hypot(q.x, q.y));
    }
  }
  EXPECT_NEAR(highest, kImageDiam, 1e-9 * kImageDiam);
}

// A grating lens written to .zmx reads back the same grating and traces the same rays.
TEST(Grating, WrittenAndReadBack) {
  for (const char* name : {"curved_reflective_grating.zmx", "flat_transmission_grating.zmx"}) {
    SCOPED_TRACE(name);
    const LensPrescription p = readLensFile(optiland(name));
    const LensPrescription q = parseZmx(writeLensZmx(p), "back.zmx");
    ASSERT_NE(firstGrating(q), nullptr);
    EXPECT_EQ(firstGrating(q)->grating->order, firstGrating(p)->grating->order);
    EXPECT_EQ(firstGrating(q)->grating->lines_per_um, 0.2);
    const PlacedLens a(p, 550), b(q, 550);
    const Vec3 d = normalize(Vec3{0.05, 0.1, 1});
    const TraceResult ra = a.trace({Vec3{1, 2, -5}, d}), rb = b.trace({Vec3{1, 2, -5}, d});
    ASSERT_TRUE(ra.ok() && rb.ok());
    EXPECT_NEAR(length(ra.ray.origin - rb.ray.origin), 0, 1e-9);
    EXPECT_NEAR(length(ra.ray.direction - rb.ray.direction), 0, 1e-12);
  }
}

// `lens info` reads every grating file (exit 0) and lists the grating; a scene whose realistic
// camera names one is refused at its Camera line.
TEST(Grating, LensInfoReadsThemAndTheCameraRefusesThem) {
  for (const char* name : {"curved_reflective_grating.zmx", "curved_transmission_grating.zmx",
                           "flat_transmission_grating.zmx"}) {
    SCOPED_TRACE(name);
    const std::string path = optiland(name);
    const test::CliResult r = test::runLensim("lens info " + path + " --field 0,10");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("grating 0.2 lines/um"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("chief ray at 587.0000 nm"), std::string::npos) << r.out;
    const test::CliResult j = test::runLensim("lens info --json " + path);
    EXPECT_EQ(j.status, 0) << j.out;
    EXPECT_NE(j.out.find("\"chief_ray_by_wavelength\""), std::string::npos) << j.out;
  }
  // The flat grating's chief ray at 10 degrees, per wavelength (the file lists 0.587 um): its
  // direction's y component sin 10 - 0.587 x 0.2 behind the window, as the closed form says.
  const test::CliResult j = test::runLensim(
      "lens info --json --field 0,10 " + optiland("flat_transmission_grating.zmx"));
  ASSERT_EQ(j.status, 0) << j.out;
  // The notes (stderr) come first; the JSON document is the rest.
  const size_t doc = j.out.find("{\n");
  ASSERT_NE(doc, std::string::npos) << j.out;
  const nlohmann::json info = nlohmann::json::parse(j.out.substr(doc));
  const auto& per = info.at("fields").at(0).at("chief_ray_by_wavelength");
  ASSERT_EQ(per.size(), 1u);
  EXPECT_EQ(per.at(0).at("wavelength_nm").get<double>(), 587);
  EXPECT_NEAR(per.at(0).at("direction").at(1).get<double>(), std::sin(10 * kDeg) - 0.587 * 0.2,
              1e-12);
  EXPECT_EQ(info.at("surfaces").at(2).at("grating").at("order").get<int>(), -1);
  const std::string dir = (std::filesystem::temp_directory_path() / "lensim_grating_test").string();
  std::filesystem::create_directories(dir);
  const std::string scene = dir + "/grating.pbrt";
  std::ofstream(scene) << fmt::format(
      "Camera \"realistic\" \"string lensfile\" \"{}\" \"float aperturediameter\" 5\n"
      "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n"
      "LightSource \"infinite\" \"rgb L\" [1 1 1]\n",
      optiland("flat_transmission_grating.zmx"));
  const test::CliResult r = test::runLensim("render " + scene + " -o " + dir + "/out.exr");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("grating.pbrt:1:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("diffraction grating"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out.exr"));
}
