// Decentred apertures (Zemax OBDC: an off-axis parabolic mirror) and a rectangular aperture on a
// cylinder (SQAP on a TOROIDAL surface flat in x), issue 28, checked against closed forms written
// here: a collimated beam along a parabola's axis meets at its focus R/2 from the vertex, whatever
// part of the parabola it strikes; a thick plano-convex cylindrical lens focuses a beam on the
// line f - t/n behind its flat face (f = R/(n-1)) and leaves x alone.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "lensim/camera/camera.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/off_axis_mirror.h"
#include "lensim/optics/placed_lens.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "cli_run.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string zmxPath(const std::string& name) {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/" + name;
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

int mirrorRow(const LensPrescription& p) {
  for (size_t i = 0; i < p.surfaces.size(); ++i)
    if (p.surfaces[i].mirror) return int(i);
  return -1;
}

// zmax_37992.zmx: the stop (surface 1) at the origin, 200 mm on a coordinate break decentres
// y by -190.6 mm, then the parabola (CONI -1, R -190.6 mm) whose CLAP 25.4 is decentred by
// OBDC 0 190.6, back onto the beam's axis.
constexpr double kR = -190.6, kBreakZ = 200, kBreakDy = -190.6, kClap = 25.4;


const char* const kSynthetic =
    "MODE SEQ\nENPD 20\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0\n  DISZ 100\n"
    "  DIAM 10\nSURF 2\n  CURV {}\n  CONI {}\n  DISZ -50\n  GLAS MIRROR\n  DIAM 10\n{}"
    "  OBDC 0 {}\nSURF 3\n  DISZ 0\n";

std::string synthetic(double curv, double conic, const std::string& aperture, double dy) {
  return fmt::format(fmt::runtime(kSynthetic), curv, conic, aperture, dy);
}

}  // namespace

TEST(OffAxisMirror, ReadsPlacedInSpaceAndTheCoaxialToolsRefuseIt) {
  const std::string path = zmxPath("zmax_37992.zmx");
  const LensPrescription p = parseZmx(slurp(path), path);
  ASSERT_TRUE(p.noncoaxial_loc.has_value());
  const int m = mirrorRow(p);
  ASSERT_GE(m, 0);
  const LensSurface& s = p.surfaces[size_t(m)];
  EXPECT_DOUBLE_EQ(s.aperture_decentre_mm[0], 0.0);
  EXPECT_DOUBLE_EQ(s.aperture_decentre_mm[1], 190.6);
  EXPECT_NEAR(s.semiAperture_mm(), kClap, 1e-9);
  EXPECT_EQ(s.shape.conic, -1.0);
  EXPECT_NEAR(s.radius_mm, kR, 1e-9);
  EXPECT_THROW(LensSystem{p}, Error);
}

TEST(OffAxisMirror, EveryRayOfTheFileMeetsTheParabolasFocus) {
  const std::string path = zmxPath("zmax_37992.zmx");
  const LensPrescription p = parseZmx(slurp(path), path);
  const PlacedLens lens(p, 587.6);
  // The focus, R/2 from the vertex along the parabola's axis (the front frame's z).
  const Vec3 focus{0, kBreakDy, kBreakZ + kR / 2};
  int passed = 0;
  double worst = 0;
  constexpr int kN = 41;
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j) {
      const double x = kClap * (2.0 * i / (kN - 1) - 1), y = kClap * (2.0 * j / (kN - 1) - 1);
      if (std::hypot(x, y) >= kClap * (1 - 1e-9)) continue;
      const TraceResult t = lens.trace({{x, y, -50}, {0, 0, 1}});
      ASSERT_TRUE(t.ok()) << x << " " << y;
      // On the image surface (which the file puts at the focus) and on a line through it.
      EXPECT_LT(length(t.ray.origin - focus), 1e-9) << x << " " << y;
      worst = std::max(worst, length(t.ray.origin - focus));
      const Vec3 to = focus - t.ray.origin;
      EXPECT_LT(length(to - t.ray.direction * dot(to, t.ray.direction)), 1e-9);
      ++passed;
    }
  EXPECT_EQ(passed, 1245);  // the grid's points inside the disc: i^2 + j^2 < 20^2
  std::printf("off-axis parabola: %d rays, farthest %.3g mm from the focus\n", passed, worst);
  // The image surface's SCBD (tilt about x by 90 degrees) turns it to face the reflected beam:
  // the central ray leaves the mirror along -y (the parabola's slope is 1 there) and meets it
  // at normal incidence.
  const TraceResult c = lens.trace({{0, 0, -50}, {0, 0, 1}});
  ASSERT_TRUE(c.ok());
  EXPECT_NEAR(c.ray.direction.y, -1, 1e-12);
  const auto& rot = p.image_frame.rotation;
  const Vec3 normal{rot[0][2], rot[1][2], rot[2][2]};
  EXPECT_NEAR(std::abs(dot(normal, c.ray.direction)), 1, 1e-12);
}

// What a maker states: the file's NOTE names it "OAPM 90 DEG 50.8 X 190.6" (off-axis angle,
// diameter, reflected focal length); the traced central ray agrees, and a second mirror matches
// RFL = (R^2 + h^2) / 2|R| and cos(angle) = (R^2 - h^2) / (R^2 + h^2) for its decentre h.
TEST(OffAxisMirror, TheMakersFiguresFromTheFile) {
  const std::string path = zmxPath("zmax_37992.zmx");
  const std::string text = slurp(path);
  EXPECT_NE(text.find("OAPM 90 DEG 50.8 X 190.6"), std::string::npos);
  const LensPrescription p = parseZmx(text, path);
  const int m = mirrorRow(p);
  const auto oap = offAxisParabola(p.surfaces[size_t(m)]);
  ASSERT_TRUE(oap.has_value());
  EXPECT_NEAR(oap->parent_focal_length_mm, -kR / 2, 1e-9);
  EXPECT_NEAR(oap->reflected_focal_length_mm, 190.6, 1e-9);
  EXPECT_NEAR(oap->off_axis_angle_deg, 90, 1e-9);
  EXPECT_NEAR(2 * p.surfaces[size_t(m)].semiAperture_mm(), 50.8, 1e-9);
  // The central ray: from its hit on the mirror to the focus, and its turn.
  const PlacedLens lens(p, 587.6);
  std::vector<Vec3> hits;
  const TraceResult c = lens.trace({{0, 0, -50}, {0, 0, 1}}, {}, &hits);
  ASSERT_TRUE(c.ok());
  ASSERT_GE(hits.size(), 3u);
  const Vec3 on_mirror = hits[hits.size() - 2];
  EXPECT_NEAR(length(c.ray.origin - on_mirror), 190.6, 1e-9);
  EXPECT_NEAR(std::acos(c.ray.direction.z * -1) * 180 / std::numbers::pi, 90, 1e-9);

  const LensPrescription q = parseZmx(synthetic(-0.01, -1, "  CLAP 0 10 0\n", 50), "q.zmx");
  const auto o2 = offAxisParabola(q.surfaces[size_t(mirrorRow(q))]);
  ASSERT_TRUE(o2.has_value());
  const double R = 100, h = 50;
  EXPECT_NEAR(o2->parent_focal_length_mm, 50, 1e-12);
  EXPECT_NEAR(o2->reflected_focal_length_mm, (R * R + h * h) / (2 * R), 1e-12);
  EXPECT_NEAR(std::cos(o2->off_axis_angle_deg * std::numbers::pi / 180),
              (R * R - h * h) / (R * R + h * h), 1e-12);
  // Not an off-axis paraboloid: the centred one, and a decentred sphere.
  const LensPrescription centred = parseZmx(synthetic(-0.01, -1, "  CLAP 0 10 0\n", 0), "c.zmx");
  EXPECT_FALSE(offAxisParabola(centred.surfaces[size_t(mirrorRow(centred))]));
  const LensPrescription sph = parseZmx(synthetic(-0.01, 0, "  CLAP 0 10 0\n", 50), "s.zmx");
  EXPECT_FALSE(offAxisParabola(sph.surfaces[size_t(mirrorRow(sph))]));
}

TEST(OffAxisMirror, WrittenToZmxItReadsBackTheSame) {
  const std::string path = zmxPath("zmax_37992.zmx");
  const LensPrescription p = parseZmx(slurp(path), path);
  const LensPrescription q = parseZmx(writeLensZmx(p), "written.zmx");
  ASSERT_TRUE(q.noncoaxial_loc.has_value());
  const int m = mirrorRow(q);
  ASSERT_GE(m, 0);
  EXPECT_NEAR(q.surfaces[size_t(m)].aperture_decentre_mm[1], 190.6, 1e-12);
  EXPECT_NEAR(q.surfaces[size_t(m)].semiAperture_mm(), kClap, 1e-12);
  const PlacedLens a(p, 587.6), b(q, 587.6);
  for (double y : {-20.0, 0.0, 13.0}) {
    const TraceResult ta = a.trace({{3, y, -50}, {0, 0, 1}}), tb = b.trace({{3, y, -50}, {0, 0, 1}});
    ASSERT_TRUE(ta.ok() && tb.ok());
    EXPECT_LT(length(ta.ray.origin - tb.ray.origin), 1e-9);
  }
  EXPECT_THROW(writeLensJson(p), Error);
}

TEST(OffAxisMirror, TheDecentredDiscClipsAtItsEdge) {
  // The stop widened (ENPD 80) so that the mirror's decentred CLAP is what clips.
  const std::string path = zmxPath("zmax_37992.zmx");
  const std::string text = replaced(slurp(path), "ENPD 50.799999999999997", "ENPD 80");
  const LensPrescription p = parseZmx(text, path);
  const int m = mirrorRow(p);
  const PlacedLens lens(p, 587.6);
  // A ray along z at (x, y) meets the mirror at its own (x, y - kBreakDy): the disc about
  // (0, 190.6) there is the disc of radius 25.4 about the beam's axis.
  for (double a : {0.0, 0.7, 1.9, 3.3, 4.8}) {
    for (double eps : {-1e-7, 1e-7}) {
      const double r = kClap * (1 + eps);
      const TraceResult t = lens.trace({{r * std::cos(a), r * std::sin(a), -50}, {0, 0, 1}});
      SCOPED_TRACE(fmt::format("angle {} radius {}", a, r));
      if (eps < 0) {
        EXPECT_TRUE(t.ok());
      } else {
        EXPECT_EQ(t.blocked_surface, m);
        EXPECT_EQ(t.reason, BlockReason::Aperture);
      }
    }
  }
  // Beyond the disc but inside the stop: blocked at the mirror.
  const TraceResult far = lens.trace({{0, 35, -50}, {0, 0, 1}});
  EXPECT_EQ(far.blocked_surface, m);
}


TEST(OffAxisMirror, ADecentredApertureAloneMakesTheLensNonCoaxial) {
  // No coordinate break: the OBDC line is where the axis of symmetry is lost.
  const LensPrescription p = parseZmx(synthetic(-0.01, -1, "  CLAP 0 10 0\n", 30), "oap.zmx");
  ASSERT_TRUE(p.noncoaxial_loc.has_value());
  EXPECT_EQ(p.noncoaxial_loc->line, 17);
  EXPECT_NE(p.noncoaxial_reason.find("decentred"), std::string::npos) << p.noncoaxial_reason;
  EXPECT_THROW(LensSystem{p}, Error);
  // A centred one (OBDC 0 0) stays coaxial.
  EXPECT_FALSE(parseZmx(synthetic(-0.01, -1, "  CLAP 0 10 0\n", 0), "c.zmx").noncoaxial_loc);
}

TEST(OffAxisMirror, RefusedWhereItCannotBeModelled) {
  auto errorAt = [](const std::string& text) -> FileLoc {
    try {
      parseZmx(text, "bad.zmx");
    } catch (const Error& e) {
      return e.loc();
    }
    ADD_FAILURE() << "no error";
    return {};
  };
  // OBDC with no aperture line to decentre.
  EXPECT_EQ(errorAt(synthetic(-0.01, -1, "", 30)).line, 16);
  // A sphere of radius 60 ends 60 mm from its axis; the decentred disc reaches 65.
  const FileLoc l = errorAt(synthetic(-1.0 / 60, 0, "  CLAP 0 10 0\n", 55));
  EXPECT_EQ(l.line, 17);
  EXPECT_EQ(l.column, 10);
  // SCBD on a surface other than the image, and with two motions on one line.
  std::string text = synthetic(-0.01, -1, "  CLAP 0 10 0\n", 30);
  EXPECT_EQ(errorAt(replaced(text, "  DIAM 10\nSURF 2", "  DIAM 10\n  SCBD 1 0 0 0 0 5 0 0\nSURF 2"))
                .line,
            10);
  EXPECT_EQ(errorAt(text + "  SCBD 1 0 0 0 1 5 0 0\n").line, 20);
}

// Thorlabs LJ1598L1: N-BK7, R 2.02 mm curved in y, flat in x, 3.8 mm thick, SQAP 3 x 2 mm.
TEST(CylinderSqap, TheThickCylinderFocusesOnTheClosedFormLine) {
  const std::string path = zmxPath("optiland/thorlabs_lj1598l1.zmx");
  // ENPD 8: a stop wider than the rectangle, which then clips.
  const LensPrescription p = parseZmx(replaced(slurp(path), "ENPD 3.2", "ENPD 8"), path);
  EXPECT_FALSE(p.noncoaxial_loc.has_value());
  const LensSystem lens(p);
  // N-BK7's Sellmeier formula (Schott's data sheet) at the d line.
  const double l2 = 0.5875618 * 0.5875618;
  const double n_sellmeier = std::sqrt(1 + 1.03961212 * l2 / (l2 - 0.00600069867) +
                             0.231792344 * l2 / (l2 - 0.0200179144) +
                             1.01046945 * l2 / (l2 - 103.560653));
  // The index the lens traces with (the catalogue's n_d) is that one, to its 6 decimals; the
  // closed form below uses it, so that only the geometry is compared.
  int glass_rows = 0;
  double n_lens = 0;
  for (const Interface& in : lens.interfaces())
    if (in.ior_after > 1) {
      EXPECT_NEAR(in.ior_after, n_sellmeier, 2e-6);
      n_lens = in.ior_after;
      ++glass_rows;
    }
  EXPECT_EQ(glass_rows, 1);
  const double n = n_lens;
  const double R = 1 / 4.950495049504951000E-001, t = 3.8;
  const double f = R / (n - 1), line_z = lens.rearVertexZ_mm() + f - t / n;
  double worst = 0;
  for (double x : {0.0, 1.5, 2.5, 2.95, -2.95}) {
    SCOPED_TRACE(x);
    // A paraxial ray in the curved meridian, 1e-4 mm high (its aberration ~1e-8 mm).
    const TraceResult r = lens.tracer().traceFromScene({{x, 1e-4, -5}, {0, 0, 1}});
    ASSERT_TRUE(r.ok());
    const Ray& o = r.ray;
    const double z = o.origin.z - o.origin.y * o.direction.z / o.direction.y;
    EXPECT_NEAR(z, line_z, 1e-7);
    worst = std::max(worst, std::abs(z - line_z));
    EXPECT_NEAR(o.direction.x, 0, 1e-12);  // no power in x
    EXPECT_NEAR(o.origin.x, x, 1e-12);
  }
  std::printf("cylinder: focal line %.6f mm behind the flat face (f %.6f mm), traced within %.3g mm\n",
              f - t / n, f, worst);
  // The rectangle's edges (3 mm in x, 2 mm in y): its corners pass, beyond them is blocked.
  EXPECT_TRUE(lens.tracer().traceFromScene({{2.99, 1.99, -5}, {0, 0, 1}}).ok());
  EXPECT_TRUE(lens.tracer().traceFromScene({{-2.99, -1.99, -5}, {0, 0, 1}}).ok());
  EXPECT_FALSE(lens.tracer().traceFromScene({{3.01, 0.5, -5}, {0, 0, 1}}).ok());
  EXPECT_FALSE(lens.tracer().traceFromScene({{0.5, 2.01, -5}, {0, 0, 1}}).ok());
}

TEST(CylinderSqap, ARectangleBeyondTheCurvedDirectionIsRefused) {
  // Half-height 2.1 mm on a cylinder of radius 2.02 mm: outside the surface in y.
  const std::string path = zmxPath("optiland/thorlabs_lj1598l1.zmx");
  std::string text = slurp(path);
  const size_t at = text.find("SQAP 3.0 2 0");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 12, "SQAP 3.0 2.1 0");
  try {
    parseZmx(text, path);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.loc().line, 89) << e.what();
    EXPECT_NE(std::string(e.what()).find("not defined"), std::string::npos) << e.what();
  }
}

// `lens draw` of the cylinder: its x-z section has no power, so only the y-z section is drawn,
// with a note (it used to fail with "the lens is afocal").
TEST(CylinderSqap, DrawnInItsCurvedSection) {
  const std::string out =
      (std::filesystem::temp_directory_path() / "lensim_cylinder_draw.svg").string();
  std::filesystem::remove(out);
  const test::CliResult r =
      test::runLensim("lens draw " + zmxPath("optiland/thorlabs_lj1598l1.zmx") + " -o " + out);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("the x-z section has no optical power"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(1 lens)"), std::string::npos) << r.out;
  EXPECT_NE(slurp(out).find("y-z section"), std::string::npos);
  std::filesystem::remove(out);
}

// The realistic camera through the off-axis mirror: its image lies beside the mirror, inside the
// mirror's z range, and the placed camera samples the last surface from a film wholly on one side
// of it, so it refuses the lens at the scene's Camera line, naming the lens file (no crash).
TEST(OffAxisMirror, TheRealisticCameraRefusesItAtTheCameraLine) {
  const std::string lens = zmxPath("zmax_37992.zmx");
  const auto dir = std::filesystem::temp_directory_path() / "lensim_offaxis_test";
  std::filesystem::create_directories(dir);
  const std::string scene_path = (dir / "oap.pbrt").string();
  std::ofstream(scene_path) << fmt::format(
      "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16 \"float diagonal\" 2\n"
      "Camera \"realistic\" \"string lensfile\" \"{}\"\n"
      "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n",
      lens);
  try {
    camera::makeCamera(scene::loadScene(scene_path));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.loc().file, scene_path) << e.what();
    EXPECT_EQ(e.loc().line, 2) << e.what();
    const std::string what = e.what();
    EXPECT_NE(what.find("off-axis mirror"), std::string::npos) << what;
    EXPECT_NE(what.find(lens), std::string::npos) << what;
  }
}
