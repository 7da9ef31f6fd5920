// Mirrors and central obscurations (catadioptric lenses): reflection in the exact tracers, the
// n -> -n paraxial convention, the Zemax and JSON readers, and the .dat writer's refusal. Checked
// against closed forms (f = R/2 of a mirror, the two-mirror formula, a parabola's perfect axial
// focus) and against a y-nu trace written here, independently of paraxial.cpp's matrices.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "lensim/optics/focus.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/pupil.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;

namespace {

std::string sharedLens(const std::string& name) {
  return std::string(LENSIM_SHARED_DIR) + "/lenses/" + name;
}

LensSurface surf(double radius, double thickness, double semi, double ior = 1) {
  LensSurface s;
  s.radius_mm = radius;
  s.thickness_mm = thickness;
  s.aperture_diameter_mm = 2 * semi;
  s.ior = ior;
  s.stop_flag = false;
  return s;
}

// A single concave mirror facing the scene (centre of curvature toward -z): radius R < 0, focus
// |R|/2 in front of it (thickness -|R|/2 to the image, Zemax's convention).
LensPrescription singleMirror(double R, double conic, double semi) {
  LensPrescription p;
  p.path = "mirror";
  LensSurface m = surf(R, R / 2, semi);
  m.mirror = true;
  m.stop_flag = true;
  m.shape.conic = conic;
  p.surfaces.push_back(m);
  return p;
}

// An independent paraxial (y, u) trace with the n -> -n convention written out: per surface the
// refraction n'u' = n u - y (n' - n) c, then the transfer y += t u'. Returns EFL = -y0 / u' and
// BFL = -y / u' for a ray entering parallel at height y0 = 1.
struct YNu {
  double efl, bfl;
};
YNu ynuTrace(const std::vector<double>& curv, const std::vector<double>& thick,
             const std::vector<double>& index_after, const std::vector<bool>& mirror) {
  double y = 1, u = 0, n = 1, sign = 1;
  for (size_t i = 0; i < curv.size(); ++i) {
    if (mirror[i]) sign = -sign;
    const double n2 = sign * index_after[i];
    u = (n * u - y * (n2 - n) * curv[i]) / n2;
    n = n2;
    if (i + 1 < curv.size()) y += thick[i] * u;
  }
  // EFL in object-space terms (1 / power with n_object = 1): power = -n' u' / y0.
  return {1 / (-n * u), -y / u};
}

}  // namespace

// A spherical mirror focuses at R/2: EFL = |R|/2, the back focal length along the reflected
// light |R|/2, and the image lies in front of the mirror (image space reversed).
TEST(Mirror, SphericalMirrorFocalLengthIsHalfTheRadius) {
  for (double R : {-200.0, -57.3, -1000.0}) {
    const LensSystem lens(singleMirror(R, 0, std::abs(R) / 10));
    EXPECT_TRUE(lens.imageSpaceReversed());
    EXPECT_EQ(lens.mirrorCount(), 1);
    const ParaxialData p = computeParaxial(lens);
    EXPECT_NEAR(p.effective_focal_length_mm, std::abs(R) / 2, 1e-9 * std::abs(R)) << R;
    EXPECT_NEAR(p.back_focal_length_mm, std::abs(R) / 2, 1e-9 * std::abs(R)) << R;
    // The film (thickness R/2 < 0 in the file) is |R|/2 from the mirror, physically in front.
    EXPECT_NEAR(lens.filmDistance_mm(), std::abs(R) / 2, 1e-12);
    EXPECT_NEAR(lens.realFilmZ_mm(), R / 2, 1e-12);
    // f/N of the stop (the mirror): EFL / diameter.
    EXPECT_NEAR(p.f_number, std::abs(R) / 2 / (2 * std::abs(R) / 10), 1e-9);
  }
  // A convex mirror (R > 0) diverges: EFL -R/2.
  LensPrescription convex = singleMirror(100, 0, 10);
  convex.surfaces[0].thickness_mm = -30;
  EXPECT_NEAR(computeParaxial(LensSystem(convex)).effective_focal_length_mm, -50, 1e-9);
}

// An on-axis paraboloid images a beam parallel to its axis to a point: the exact rays (double
// and float tracers) meet the focal plane at the axis. The reflected rays are checked in real
// coordinates (they travel toward -z, and the focus is at z = R/2 in front of the vertex), after
// undoing the unfolding of image space.
TEST(Mirror, ParabolaFocusesAnAxialBeamToAPoint) {
  const double R = -200, semi = 25;
  const LensSystem lens(singleMirror(R, -1, semi));
  double sum2 = 0, sum2_f = 0, sum2_sphere = 0;
  int n = 0;
  const LensSystem sphere(singleMirror(R, 0, semi));
  for (int k = 1; k <= 40; ++k) {
    const double h = semi * 0.98 * std::sqrt(k / 40.0);
    for (double phi : {0.0, 1.0, 2.5}) {
      const Ray in{{h * std::cos(phi), h * std::sin(phi), -50}, {0, 0, 1}};
      const TraceResult r = lens.tracer().traceFromScene(in);
      ASSERT_TRUE(r.ok()) << h;
      // Undo the unfolding: real z = 2 z_rear - z, real direction z = -d.z.
      const Vec3 o{r.ray.origin.x, r.ray.origin.y, 2 * lens.rearVertexZ_mm() - r.ray.origin.z};
      const Vec3 d{r.ray.direction.x, r.ray.direction.y, -r.ray.direction.z};
      ASSERT_LT(d.z, 0);  // reflected back toward the scene
      const double t = (R / 2 - o.z) / d.z;
      const Vec3 q = o + d * t;
      sum2 += q.x * q.x + q.y * q.y;
      // The same through the unfolded film plane the rest of lensim uses.
      const double tu = (lens.filmZ_mm() - r.ray.origin.z) / r.ray.direction.z;
      EXPECT_NEAR(r.ray.origin.x + tu * r.ray.direction.x, q.x, 1e-9);
      const TraceResultT<float> rf =
          lens.tracerFloat().traceFromScene({Vec3f(in.origin), Vec3f(in.direction)});
      ASSERT_TRUE(rf.ok());
      const double tf = (lens.filmZ_mm() - rf.ray.origin.z) / rf.ray.direction.z;
      const double xf = rf.ray.origin.x + tf * rf.ray.direction.x,
                   yf = rf.ray.origin.y + tf * rf.ray.direction.y;
      sum2_f += xf * xf + yf * yf;
      const TraceResult rs = sphere.tracer().traceFromScene(in);
      const double ts = (sphere.filmZ_mm() - rs.ray.origin.z) / rs.ray.direction.z;
      const double xs = rs.ray.origin.x + ts * rs.ray.direction.x,
                   ys = rs.ray.origin.y + ts * rs.ray.direction.y;
      sum2_sphere += xs * xs + ys * ys;
      ++n;
    }
  }
  const double rms = std::sqrt(sum2 / n), rms_f = std::sqrt(sum2_f / n),
               rms_sphere = std::sqrt(sum2_sphere / n);
  RecordProperty("rms_parabola_mm", fmt::format("{:.3g}", rms));
  RecordProperty("rms_sphere_mm", fmt::format("{:.3g}", rms_sphere));
  EXPECT_LT(rms, 1e-9);
  EXPECT_LT(rms_f, 2e-4);  // float precision
  // The sphere of the same radius has spherical aberration: the marginal ray at height h crosses
  // the paraxial focal plane at h^3 / R^2 (third order, -h^3/(2 R^2) longitudinal x 2h/R slope).
  EXPECT_GT(rms_sphere, 0.1 * std::pow(semi, 3) / (R * R));
}

// A classical Cassegrain: EFL from the two-mirror formula 1/f = 1/f1 + 1/f2 - d/(f1 f2) (f1 =
// -R1/2 for the concave primary, f2 = R2/2 with the secondary's sign as seen by the reflected
// light), and the back focal distance from the secondary by the mirror equation.
TEST(Mirror, CassegrainMatchesTheTwoMirrorFormula) {
  const LensPrescription p = readLensFile("lenses:cassegrain.500mm");
  const LensSystem lens(p);
  ASSERT_EQ(lens.mirrorCount(), 2);
  EXPECT_FALSE(lens.imageSpaceReversed());
  const double R1 = p.surfaces[1].radius_mm, R2 = p.surfaces[2].radius_mm;
  const double d = std::abs(p.surfaces[1].thickness_mm);
  const double f1 = -R1 / 2, f2 = R2 / 2;  // 200 and -119.05 mm
  const double f = 1 / (1 / f1 + 1 / f2 - d / (f1 * f2));
  const ParaxialData para = computeParaxial(lens);
  EXPECT_NEAR(para.effective_focal_length_mm, f, 1e-6);
  EXPECT_NEAR(para.effective_focal_length_mm, 500, 1e-4);  // the design's focal length
  // The primary's image is a virtual object for the secondary; the mirror equation gives the
  // image behind the secondary (the back focal length).
  // Distances along the light, real positive: the object is virtual, f1 - d beyond the mirror.
  const double s_obj = -(f1 - d);
  const double s_img = 1 / (1 / f2 - 1 / s_obj);  // 1/s + 1/s' = 1/f; f2 < 0: a convex mirror
  EXPECT_NEAR(para.back_focal_length_mm, s_img, 1e-6);
  EXPECT_NEAR(para.f_number, 8.0, 1e-9);
  // The stop is the primary and it is the entrance pupil (nothing in front of it has power).
  EXPECT_EQ(para.aperture_stop_surface, 1);
  EXPECT_NEAR(para.entrance_pupil_z_mm, lens.interfaces()[1].z_mm, 1e-9);
}

// The Zemax samples with mirrors: the Cassegrain HoO-V2C18Ex03 (conic mirrors) and the Mangin
// reflex design US 5,331,467 (glass behind both mirrors, an OBSC central obscuration) against the
// independent y-nu trace above, fed with the file's curvatures and thicknesses (read here from
// the prescription, indices at the analysis wavelength from the system).
TEST(Mirror, ZmxSamplesAgreeWithAnIndependentParaxialTrace) {
  for (const char* f : {"zmx/HoO-V2C18Ex03.zmx", "zmx/US05331467-1.zmx"}) {
    SCOPED_TRACE(f);
    const LensPrescription p = readLensFile(sharedLens(f));
    const LensSystem lens(p);
    std::vector<double> c, t, n;
    std::vector<bool> m;
    for (size_t i = 0; i < p.surfaces.size(); ++i) {
      c.push_back(p.surfaces[i].radius_mm != 0 ? 1 / p.surfaces[i].radius_mm : 0.0);
      t.push_back(p.surfaces[i].thickness_mm);
      n.push_back(lens.interfaces()[i].ior_after);
      m.push_back(p.surfaces[i].mirror);
    }
    const YNu y = ynuTrace(c, t, n, m);
    const ParaxialData para = computeParaxial(lens);
    EXPECT_NEAR(para.effective_focal_length_mm, y.efl, 1e-9 * std::abs(y.efl));
    EXPECT_NEAR(para.back_focal_length_mm, y.bfl, 1e-9 * std::abs(y.bfl) + 1e-9);
  }
  // HoO-V2C18Ex03: two mirrors 16 mm apart (R -45.72 and -19.2 mm): the two-mirror formula, the
  // image where the file puts it (its last DISZ, 24.035 mm), f/4 from FNUM 4.
  const LensSystem cass(readLensFile(sharedLens("zmx/HoO-V2C18Ex03.zmx")));
  const double f1 = 1 / (2 * 2.187226596675415774E-02), f2 = -1 / (2 * 5.208333333333333565E-02);
  const double f = 1 / (1 / f1 + 1 / f2 - 16 / (f1 * f2));
  const ParaxialData pc = computeParaxial(cass);
  EXPECT_NEAR(pc.effective_focal_length_mm, f, 1e-9 * f);
  EXPECT_NEAR(pc.back_focal_length_mm, 24.035, 2e-3);
  EXPECT_NEAR(pc.f_number, 4.0, 1e-9);
  // US 5,331,467: the obscuration (OBSC 0 25) on surface 2, mirrors at surfaces 4 and 7.
  const LensPrescription us = readLensFile(sharedLens("zmx/US05331467-1.zmx"));
  EXPECT_DOUBLE_EQ(us.surfaces[1].obscuration_radius_mm, 25);
  EXPECT_TRUE(us.surfaces[3].mirror);
  EXPECT_TRUE(us.surfaces[3].isStop());  // the Mangin primary is the stop (STOP on it)
  EXPECT_TRUE(us.surfaces[6].mirror);
  EXPECT_EQ(us.surfaces[3].glass.name, us.surfaces[2].glass.name);  // back through its glass
  EXPECT_EQ(us.surfaces[3].ior, us.surfaces[2].ior);
}

// Central obscurations block rays inside their radius; the double, float and batched tracers
// agree on every ray through a mirror lens (reflections, obscurations, conics).
TEST(Mirror, ObscurationsBlockAndTheTracersAgree) {
  const LensSystem lens(readLensFile("lenses:cassegrain.500mm"));
  // From the scene on the axis: blocked by the front obscuration (the secondary's shadow).
  TraceResult r = lens.tracer().traceFromScene({{5, 0, -10}, {0, 0, 1}});
  EXPECT_EQ(r.reason, BlockReason::Obscured);
  EXPECT_EQ(r.blocked_surface, 0);
  EXPECT_STREQ(blockReasonName(r.reason), "obscured");
  r = lens.tracer().traceFromScene({{5, 0, -10}, {0, 0, 1}}, kOuterBoundary);
  EXPECT_TRUE(r.ok());  // with obscurations ignored, it reaches the film
  r = lens.tracer().traceFromScene({{25, 0, -10}, {0, 0, 1}});
  ASSERT_TRUE(r.ok());
  EXPECT_GT(r.ray.direction.z, 0);  // two reflections: on toward the film
  // Film to scene, over the exit-pupil region: batch == single (float) == double within 1e-3.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int ok = 0, obscured = 0, total = 0;
  for (int b = 0; b < 40; ++b) {
    RayT<float> rays[LensTracer<float>::kBatch];
    TraceResultT<float> out[LensTracer<float>::kBatch];
    const int nb = LensTracer<float>::kBatch;
    for (int j = 0; j < nb; ++j) {
      const Vec3 from{u(rng) * 10, u(rng) * 10, lens.filmZ_mm()};
      const Vec3 to{u(rng) * 14, u(rng) * 14, lens.rearVertexZ_mm()};
      rays[j] = {Vec3f(from), Vec3f(normalize(to - from))};
    }
    lens.tracerFloat().traceFromFilmBatch(rays, nb, out);
    for (int j = 0; j < nb; ++j) {
      const TraceResultT<float> one = lens.tracerFloat().traceFromFilm(rays[j]);
      const TraceResult dbl =
          lens.tracer().traceFromFilm({Vec3(rays[j].origin), normalize(Vec3(rays[j].direction))});
      EXPECT_EQ(out[j].reason, one.reason);
      EXPECT_EQ(out[j].blocked_surface, one.blocked_surface);
      EXPECT_EQ(out[j].ray.origin.x, one.ray.origin.x);
      EXPECT_EQ(out[j].ray.direction.z, one.ray.direction.z);
      ++total;
      if (dbl.reason != one.reason) continue;  // a ray on an edge, within float precision
      ok += one.ok();
      obscured += one.reason == BlockReason::Obscured;
      if (one.ok()) {
        EXPECT_NEAR(one.ray.origin.x, dbl.ray.origin.x, 1e-3);
        EXPECT_NEAR(one.ray.direction.x, dbl.ray.direction.x, 1e-5);
        EXPECT_LT(dbl.ray.direction.z, 0);  // leaves toward the scene
      }
    }
  }
  EXPECT_GT(ok, total / 10);
  EXPECT_GT(obscured, total / 20);
}

// The exit-pupil bound of an obscured lens: the outer boundary (obscurations ignored) minus a
// hole in the obscured middle. No ray that gets through falls outside it or in the hole, the
// passing area it implies (bound area x share of its samples that pass) equals the passing area
// measured by uniform points on a disc of the rear plane, and the samples lost are far fewer
// than the obscured share of the pupil, (15 / 31.25)^2 = 23% on the axis.
TEST(Mirror, ExitPupilBoundCutsOutTheObscuredMiddle) {
  LensSetup setup;
  setup.focus_distance_m = 12;
  const FocusedLens fl = focusLens(readLensFile("lenses:cassegrain.500mm"), setup);
  const LensSystem& lens = *fl.lens;
  const double film_r = 17.5, disc = 16;
  const ExitPupilSampler sampler(lens, fl.paraxial, film_r);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  int samples = 0, wasted = 0;
  for (double h : {0.0, 6.0, 12.0, 17.0}) {
    const Vec2 film{h * 0.8, h * 0.6};
    constexpr int kN = 20000;
    int passing = 0, outside = 0;
    for (int k = 0; k < kN; ++k) {
      const double rr = disc * std::sqrt(u(rng)), pa = 6.283185307179586 * u(rng);
      const Vec2 rear{rr * std::cos(pa), rr * std::sin(pa)};
      if (lens.traceFromFilmPoint(film, rear).ok()) {
        ++passing;
        outside += !sampler.contains(film, rear);
      }
    }
    EXPECT_EQ(outside, 0) << h;
    int pass2 = 0;
    for (int k = 0; k < kN; ++k) {
      const auto s = sampler.sample(film, {u(rng), u(rng)});
      ASSERT_TRUE(s);
      pass2 += lens.traceFromFilmPoint(film, {s->rear_point_mm.x, s->rear_point_mm.y}).ok();
    }
    samples += kN;
    wasted += kN - pass2;
    const double p1 = double(passing) / kN, p2 = double(pass2) / kN;
    const double a_disc = 3.141592653589793 * disc * disc, a_bound = sampler.areaMm2(film);
    const double a1 = a_disc * p1, a2 = a_bound * p2;
    const double se =
        std::hypot(a_disc * std::sqrt(p1 * (1 - p1) / kN), a_bound * std::sqrt(p2 * (1 - p2) / kN));
    EXPECT_NEAR(a2, a1, 4.5 * se) << "film height " << h;
    EXPECT_GT(passing, 1000) << h;
  }
  const double share = double(wasted) / samples;
  RecordProperty("wasted", fmt::format("{:.4f}", share));
  // Without the hole: 0.256; with a scaled copy of the outer polygon as the hole: 0.116; with the
  // hole's own vertex distances per direction: 0.037.
  EXPECT_LT(share, 0.05);
}

// The readers: a positive thickness after one mirror (or negative after none) is refused at its
// DISZ line; obscuring rings and a decentre (OBDC) of no aperture line are refused at their
// line; a mirror's medium repeats the one before it; JSON round-trips mirrors and obscurations;
// .dat refuses them naming the surface.
TEST(Mirror, ReadersLocateErrorsAndRoundTrip) {
  const std::string head =
      "MODE SEQ\nUNIT MM X W X CM MR CPMM\nENPD 20\nSURF 0\n  CURV 0\n  DISZ INFINITY\n"
      "SURF 1\n  STOP\n  CURV -0.005\n  DISZ {}\n  GLAS MIRROR 0 0 1.5 40\n  CONI -1\n"
      "  DIAM 12\n{}SURF 2\n  CURV 0\n  DISZ 0\n  DIAM 1\n";
  const LensPrescription ok =
      parseZmx(fmt::format(fmt::runtime(head), "-100", "  OBSC 0 3 0\n"), "m.zmx");
  ASSERT_EQ(ok.surfaces.size(), 1u);
  EXPECT_TRUE(ok.surfaces[0].mirror);
  EXPECT_TRUE(ok.surfaces[0].isStop());
  EXPECT_EQ(ok.surfaces[0].ior, 1.0);
  EXPECT_DOUBLE_EQ(ok.surfaces[0].obscuration_radius_mm, 3);
  EXPECT_NEAR(computeParaxial(LensSystem(ok)).effective_focal_length_mm, 100, 1e-9);
  auto errorOf = [](const std::string& text) {
    try {
      parseZmx(text, "m.zmx");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string pos = errorOf(fmt::format(fmt::runtime(head), "100", ""));
  EXPECT_NE(pos.find("m.zmx:10:8: error: surface 1: thickness 100 is positive after 1 mirror"),
            std::string::npos)
      << pos;
  const std::string ring = errorOf(fmt::format(fmt::runtime(head), "-100", "  OBSC 2 3 0\n"));
  EXPECT_NE(ring.find("m.zmx:14:8: error: surface 1: OBSC 2 3: an obscuring ring"),
            std::string::npos)
      << ring;
  const std::string big = errorOf(fmt::format(fmt::runtime(head), "-100", "  OBSC 0 30 0\n"));
  EXPECT_NE(big.find("m.zmx:14:10: error: surface 1: obscuration radius 30"), std::string::npos)
      << big;
  const std::string dec = errorOf(fmt::format(fmt::runtime(head), "-100", "  OBDC 0.0 190.6\n"));
  EXPECT_NE(dec.find("m.zmx:14:12: error: surface 1: OBDC"), std::string::npos) << dec;
  // CLAP rmin rmax: an annular clear aperture is a central obscuration.
  const LensPrescription clap =
      parseZmx(fmt::format(fmt::runtime(head), "-100", "  CLAP 2 11 0\n"), "m.zmx");
  EXPECT_DOUBLE_EQ(clap.surfaces[0].obscuration_radius_mm, 2);
  EXPECT_DOUBLE_EQ(clap.surfaces[0].semiAperture_mm(), 10);  // ENPD 20 sets the stop

  // JSON: round trip of the Mangin reflex lens; the .dat writer names the first mirror.
  const LensPrescription us = readLensFile(sharedLens("zmx/US05331467-1.zmx"));
  const auto tmp = std::filesystem::temp_directory_path() / "lensim_mirror_roundtrip.json";
  { std::ofstream(tmp) << writeLensJson(us); }
  const LensPrescription back = readLensFile(tmp.string());
  std::filesystem::remove(tmp);
  ASSERT_EQ(back.surfaces.size(), us.surfaces.size());
  for (size_t i = 0; i < us.surfaces.size(); ++i) {
    EXPECT_EQ(back.surfaces[i].mirror, us.surfaces[i].mirror) << i;
    EXPECT_EQ(back.surfaces[i].obscuration_radius_mm, us.surfaces[i].obscuration_radius_mm) << i;
    EXPECT_EQ(back.surfaces[i].thickness_mm, us.surfaces[i].thickness_mm) << i;
  }
  EXPECT_DOUBLE_EQ(computeParaxial(LensSystem(back)).effective_focal_length_mm,
                   computeParaxial(LensSystem(us)).effective_focal_length_mm);
  try {
    writeLensDat(us);
    FAIL() << "a mirror lens written to .dat";
  } catch (const Error& e) {
    const std::string msg = e.what();
    // The first surface .dat cannot hold: the obscured corrector (surface 1, line 79).
    EXPECT_NE(msg.find("US05331467-1.zmx:79:1: error: surface 1 cannot be written to .dat: it "
                       "has a central obscuration"),
              std::string::npos)
        << msg;
  }
  LensPrescription no_obsc = us;
  no_obsc.surfaces[1].obscuration_radius_mm = 0;
  try {
    writeLensDat(no_obsc);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("surface 3 cannot be written to .dat: it is a mirror"),
              std::string::npos)
        << e.what();
  }
  // JSON errors: a mirror's index must be the medium's before it; thickness signs.
  const std::string bad_json =
      R"({"format": "lensim-lens", "version": 1, "surfaces": [
  {"radius_mm": 0, "thickness_mm": 10, "semi_aperture_mm": 20, "ior": 1.5},
  {"radius_mm": -200, "thickness_mm": -10, "semi_aperture_mm": 20, "mirror": true, "ior": 1.6},
  {"radius_mm": 0, "thickness_mm": -50, "semi_aperture_mm": 20}]})";
  const auto bj = std::filesystem::temp_directory_path() / "lensim_mirror_bad.json";
  { std::ofstream(bj) << bad_json; }
  try {
    readLensFile(bj.string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(":3:3: error: surface 1 is a mirror: its \"ior\" 1.6"),
              std::string::npos)
        << e.what();
  }
  std::string sign_json = bad_json;
  sign_json.replace(sign_json.find(", \"ior\": 1.6"), 12, "");
  sign_json.replace(sign_json.find("\"thickness_mm\": -10"), 19, "\"thickness_mm\": 10");
  { std::ofstream(bj) << sign_json; }
  try {
    readLensFile(bj.string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(":3:3: error: surface 1: thickness 10 mm is positive "
                                         "after 1 mirror"),
              std::string::npos)
        << e.what();
  }
  std::filesystem::remove(bj);
}

// US 5,331,467 (a 1000 mm f/7.5 Mangin reflex telephoto): its glass E-LAFH3 is an obsolete
// glass that Hikari's AGF catalogue still lists (n_d 1.795041, V_d 28.69, as its successor
// J-LAFH3), and its GLAS lines carry placeholders (n_d 1.5, V_d 40 on every line). The
// first-order data are ray-optics' (../shared/lenses/SOURCES.md: EFL 999.6388 mm, BFL
// 75.3805 mm, at the primary wavelength; independent of lensim), which substitutes J-LAFH3's
// spreadsheet formula: to 2 ppm, the difference between the two formulas; a real axial beam through
// both Mangin mirrors comes to a focus: RMS spot at the paraxial focus far below the blur of the
// placeholder glass, whose EFL was -9224 mm.
TEST(Mirror, ManginTelephotoFocusesWithTheSuccessorGlass) {
  const LensPrescription p = readLensFile(sharedLens("zmx/US05331467-1.zmx"));
  const LensSystem lens(p);
  const ParaxialData para = computeParaxial(lens);
  EXPECT_NEAR(para.effective_focal_length_mm, 999.6388, 2e-3);
  EXPECT_NEAR(para.back_focal_length_mm, 75.3805, 3e-4);
  EXPECT_NEAR(para.f_number, 7.5, 1e-9);  // FNUM 7.5 sets the stop
  std::vector<Diagnostic> diags;
  resolveGlasses(p, &diags);
  bool warned = false;
  for (const Diagnostic& d : diags)
    warned = warned || (d.message.find("'E-LAFH3'") != std::string::npos &&
                        d.message.find("replaces it") != std::string::npos);
  EXPECT_FALSE(warned);  // a catalogue glass: no substitution
  bool found = false;
  for (const Glass& g : resolveGlasses(p)) found = found || g.describe() == "hikari:E-LAFH3";
  EXPECT_TRUE(found);
  // Axial rays between the central obscuration (25 mm) and the rim, at the paraxial focus.
  const double z_focus = para.back_focal_point_z_mm;
  double s2 = 0;
  int n = 0;
  for (int k = 0; k <= 40; ++k) {
    const double h = 27 + (64 - 27) * k / 40.0;
    const TraceResult t = lens.tracer().traceFromScene({{0, h, -10}, {0, 0, 1}});
    if (!t.ok()) continue;
    const double s = (z_focus - t.ray.origin.z) / t.ray.direction.z;
    const double y = t.ray.origin.y + s * t.ray.direction.y;
    s2 += y * y;
    ++n;
  }
  ASSERT_GT(n, 30);
  const double rms = std::sqrt(s2 / n);
  RecordProperty("rms_spot_mm", fmt::format("{:.6g}", rms));
  EXPECT_LT(rms, 0.03) << rms;  // measured 0.0164 mm
}
