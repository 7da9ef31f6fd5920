// Zemax coordinate breaks (issue 28, optics/coordinate_break.h): a system folded by plane mirrors
// has the first-order data of its coaxial twin, whatever the fold's angle, axis and order flag;
// tilted or decentred lenses are placed in space (optics/placed_lens.h) and the coaxial tools
// refuse them at the break; extreme angles never crash.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string fold() { return slurp(test::dataPath("lenses/fold45.zmx")); }
std::string twin() { return slurp(test::dataPath("lenses/fold45_twin.zmx")); }

// Replaces the n-th (0-based) occurrence of `from` in s.
std::string replaceNth(std::string s, const std::string& from, const std::string& to, int n) {
  size_t at = s.find(from);
  for (int i = 0; i < n && at != std::string::npos; ++i) at = s.find(from, at + 1);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

ParaxialData firstOrder(const std::string& text, const std::string& name) {
  return computeParaxial(LensSystem(parseZmx(text, name)).atWavelength(587.5618));
}

void expectSameFirstOrder(const ParaxialData& a, const ParaxialData& b) {
  EXPECT_NEAR(a.effective_focal_length_mm, b.effective_focal_length_mm, 1e-9);
  EXPECT_NEAR(a.back_focal_length_mm, b.back_focal_length_mm, 1e-9);
  EXPECT_NEAR(a.front_focal_length_mm, b.front_focal_length_mm, 1e-9);
  EXPECT_NEAR(a.principal_plane_front_z_mm, b.principal_plane_front_z_mm, 1e-9);
  EXPECT_NEAR(a.principal_plane_back_z_mm, b.principal_plane_back_z_mm, 1e-9);
  EXPECT_NEAR(a.entrance_pupil_z_mm, b.entrance_pupil_z_mm, 1e-9);
  EXPECT_NEAR(a.entrance_pupil_diameter_mm, b.entrance_pupil_diameter_mm, 1e-9);
  EXPECT_NEAR(a.exit_pupil_z_mm, b.exit_pupil_z_mm, 1e-9);
  EXPECT_NEAR(a.exit_pupil_diameter_mm, b.exit_pupil_diameter_mm, 1e-9);
  EXPECT_NEAR(a.real_f_number, b.real_f_number, 1e-9);
}

// Independent y-nu trace of fold45_twin.zmx's data (Zemax convention: a mirror turns the index
// negative, thicknesses negative after it): EFL = -y1 / (n' u') of a ray parallel to the axis.
double yNuEfl() {
  struct S { double c, t, n; };  // curvature, thickness after, index after (signed)
  const double n = 1.5168;
  const std::vector<S> s = {{0.02, 6, n}, {-0.005, 40, 1}, {0, -20, -1}, {-0.01, -4, -n},
                            {0, -30, -1}};
  double y = 1, w = 0, n_before = 1;  // w = n u
  for (size_t i = 0; i < s.size(); ++i) {
    w = w - y * s[i].c * (s[i].n - n_before);
    if (i + 1 < s.size()) y += s[i].t * w / s[i].n;
    n_before = s[i].n;
  }
  return -1 / w;
}


// An independent 3-D trace of fold45.zmx as built in space (not through the reader): a thin ray
// parallel to the axis at height h; returns the EFL h / sin(u') and the back focal distance
// (last vertex to the axis crossing, along the folded axis).
struct V { double x, y, z; };
V operator+(V a, V b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V operator*(double s, V a) { return {s * a.x, s * a.y, s * a.z}; }
double dotV(V a, V b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

void foldTrace3d(double h, double& efl, double& bfl) {
  const double n = 1.5168;
  V p{h, 0, -10}, d{0, 0, 1};
  // A sphere (vertex v, axis a toward the light's travel, curvature c) or plane (c = 0).
  auto refract = [&](V v, V a, double c, double n1, double n2) {
    V q;
    if (c == 0) {
      q = p + (dotV(v + (-1.0) * p, a) / dotV(d, a)) * d;
    } else {
      const V centre = v + (1 / c) * a;
      const V oc = p + (-1.0) * centre;
      const double b = dotV(oc, d), cc = dotV(oc, oc) - 1 / (c * c);
      const double disc = std::sqrt(b * b - cc);
      const double t1 = -b - disc, t2 = -b + disc;
      // The intersection nearer the vertex.
      const V q1 = p + t1 * d, q2 = p + t2 * d;
      q = dotV(q1 + (-1.0) * v, q1 + (-1.0) * v) < dotV(q2 + (-1.0) * v, q2 + (-1.0) * v) ? q1 : q2;
    }
    V nrm = c == 0 ? a : (q + (-1.0) * (v + (1 / c) * a));
    nrm = (1 / std::sqrt(dotV(nrm, nrm))) * nrm;
    if (dotV(nrm, d) < 0) nrm = (-1.0) * nrm;
    const double mu = n1 / n2, ci = dotV(nrm, d);
    const double ct = std::sqrt(1 - mu * mu * (1 - ci * ci));
    d = mu * d + (ct - mu * ci) * nrm;
    p = q;
  };
  const V z{0, 0, 1}, y{0, 1, 0};
  refract({0, 0, 0}, z, 0.02, 1, n);
  refract({0, 0, 6}, z, -0.005, n, 1);
  // The plane mirror at (0, 0, 46), normal (0, -1, 1)/sqrt 2: the light leaves along +y.
  {
    const V m{0, -std::sqrt(0.5), std::sqrt(0.5)};
    p = p + (dotV(V{0, 0, 46} + (-1.0) * p, m) / dotV(d, m)) * d;
    d = d + (-2 * dotV(d, m)) * m;
  }
  // Singlet 2 along +y: its front's centre of curvature 100 mm downstream (R = -100 in the
  // twin, whose light travels toward -z), 4 mm of glass, a plane back.
  refract({0, 20, 46}, y, 0.01, 1, n);
  refract({0, 24, 46}, y, 0, n, 1);
  // u' in the plane of the ray (x, the folded axis y); the crossing of x = 0.
  efl = h / std::sqrt(d.x * d.x + d.z * d.z);
  bfl = p.y + (-p.x / d.x) * d.y - 24;
}

}  // namespace

TEST(ZmxCoordinateBreak, FoldMirrorHasItsTwinsFirstOrderData) {
  const ParaxialData t = firstOrder(twin(), "fold45_twin.zmx");
  expectSameFirstOrder(firstOrder(fold(), "fold45.zmx"), t);
  // The twin itself against a y-nu trace written here.
  EXPECT_NEAR(std::abs(t.effective_focal_length_mm), std::abs(yNuEfl()), 1e-9);
  // The breaks are gone: the coaxial twin's rows, and the fold is marked for the renderer.
  const LensPrescription p = parseZmx(fold(), "fold45.zmx");
  EXPECT_EQ(p.surfaces.size(), parseZmx(twin(), "t.zmx").surfaces.size());
  ASSERT_TRUE(p.fold_loc.has_value());
  EXPECT_EQ(p.fold_loc->line, 26);
  EXPECT_FALSE(parseZmx(twin(), "t.zmx").fold_loc.has_value());
  // The 45-degree mirror's circle (semi-diameter 15) seen along the axis: 15 by 15 cos 45 (its
  // tilt about x foreshortens y).
  const LensSurface& m = p.surfaces[3];
  ASSERT_TRUE(m.mirror);
  EXPECT_EQ(m.aperture_shape, ApertureShape::Ellipse);
  EXPECT_NEAR(m.aperture_half_x_mm, 15, 1e-12);
  EXPECT_NEAR(m.aperture_half_y_mm, 15 * std::cos(M_PI / 4), 1e-12);
}

TEST(ZmxCoordinateBreak, FoldAgreesWithAnIndependent3dTrace) {
  double efl = 0, bfl = 0;
  foldTrace3d(1e-4, efl, bfl);
  const ParaxialData f = firstOrder(fold(), "fold45.zmx");
  EXPECT_NEAR(std::abs(f.effective_focal_length_mm), efl, 1e-6);
  EXPECT_NEAR(std::abs(f.back_focal_length_mm), bfl, 1e-6);
}

TEST(ZmxCoordinateBreak, AnyFoldAngleAxisAndOrderIsTheSameTwin) {
  const ParaxialData t = firstOrder(twin(), "fold45_twin.zmx");
  const std::string f = fold();
  auto both = [&](const std::string& from, const std::string& to) {
    return replaceNth(replaceNth(f, from, to, 0), from, to, 0);
  };
  struct Variant {
    const char* what;
    std::string text;
  };
  const Variant variants[] = {
      {"tilt 30 about x", both("PARM 3 45", "PARM 3 30")},
      {"tilt -60 about x", both("PARM 3 45", "PARM 3 -60")},
      {"tilt 405 about x", both("PARM 3 45", "PARM 3 405")},
      {"order flag 1", both("PARM 6 0", "PARM 6 1")},
  };
  std::vector<Variant> all(std::begin(variants), std::end(variants));
  {
    std::string y = both("PARM 3 45", "PARM 3 0");
    y = replaceNth(replaceNth(y, "PARM 4 0", "PARM 4 45", 0), "PARM 4 0", "PARM 4 45", 0);
    all.push_back({"tilt 45 about y", y});
  }
  for (const Variant& v : all) {
    SCOPED_TRACE(v.what);
    const std::string& text = v.text;
    try {
      expectSameFirstOrder(firstOrder(text, "v.zmx"), t);
    } catch (const Error& e) {
      ADD_FAILURE() << e.what();
    }
  }
}

TEST(ZmxCoordinateBreak, TiltedOrDecentredLensIsNotCoaxialFromTheBreak) {
  const std::string f = fold();
  struct Case {
    std::string text;
    int line;
    const char* word;
  };
  const Case cases[] = {
      // The second break turns by 40, not 45: the singlet after it leaves the folded axis.
      {replaceNth(f, "PARM 3 45", "PARM 3 40", 1), 47, "off the axis"},
      // A decentre on the first break: the mirror's vertex and all after it leave the axis.
      {replaceNth(f, "PARM 1 0", "PARM 1 2", 0), 29, "off the axis"},
  };
  for (const Case& c : cases) {
    const LensPrescription p = parseZmx(c.text, "bad.zmx");
    ASSERT_TRUE(p.noncoaxial_loc.has_value());
    EXPECT_EQ(p.noncoaxial_loc->line, c.line);
    EXPECT_NE(p.noncoaxial_reason.find(c.word), std::string::npos) << p.noncoaxial_reason;
    EXPECT_FALSE(p.fold_loc.has_value());
    for (const LensSurface& s : p.surfaces) EXPECT_TRUE(s.frame.has_value());
    try {
      LensSystem sys(p);
      ADD_FAILURE() << "the coaxial system accepted line " << c.line;
    } catch (const Error& e) {
      EXPECT_EQ(e.loc().line, c.line) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.word), std::string::npos) << e.what();
    }
  }
}

// Extreme angles and decentres in either break: an answer or an error at a line, never a crash.
TEST(ZmxCoordinateBreak, ExtremeValuesNeverCrash) {
  const std::string f = fold();
  const char* values[] = {"1e300", "-1e308", "90", "180", "-270", "1e-300", "1.7976931348623157e308",
                          "0.5", "89.99999999"};
  int read = 0, refused = 0;
  for (int parm = 1; parm <= 6; ++parm)
    for (int which = 0; which < 2; ++which)
      for (const char* v : values) {
        const std::string from = "PARM " + std::to_string(parm) + " " + (parm == 3 ? "45" : "0");
        const std::string text = replaceNth(f, from, "PARM " + std::to_string(parm) + " " + v, which);
        try {
          const LensPrescription p = parseZmx(text, "x.zmx");
          (void)computeParaxial(LensSystem(p).atWavelength(587.5618));
          ++read;
        } catch (const Error& e) {
          EXPECT_GT(e.loc().line, 0) << e.what();
          ++refused;
        }
      }
  EXPECT_GT(refused, 0);
  EXPECT_GT(read, 0);
}
