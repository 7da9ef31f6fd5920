// Lens design's wavefront and MTF operands (issue 33) on a lens that is perfect on axis: a
// plano-convex lens, plane side to the object, whose rear surface is a hyperboloid of conic
// -n^2 (glass to air): a parallel beam inside the glass meets it and converges without
// aberration to the hyperbola's far focus, R / (1 - n) behind the vertex. Checked against
// closed forms, with the numerical aperture from the hyperbola's sag written here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <thread>

#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/tolerance.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/util/error.h"

namespace fs = std::filesystem;
using namespace lensim;
using namespace lensim::optics;
using namespace lensim::optics::design;

namespace {

constexpr double kN = 1.5, kR = -50, kStopRadius = 10, kLambda_nm = 587.56;
constexpr double kFocus = kR / (1 - kN);  // 100 mm behind the rear vertex

struct TempDir {
  fs::path path;
  TempDir() {
    path =
        fs::temp_directory_path() / ("lensim_design_wf_" + std::to_string(std::random_device{}()));
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name) << text;
    return (path / name).string();
  }
};

// Stop (20 mm) at z = 0, a plane (a radius of 1e9 mm) 5 mm behind it, 4 mm of constant-index
// glass, the rear surface, the film at the focus.
const char* kLens =
    "# perfect on axis\n"
    "0      5    1     20\n"
    "1e9    4    1.5   40\n"
    "-50    100  1     40\n";

struct PerfectLens {
  TempDir dir;
  DesignJob job;
  LensPrescription lens;
  explicit PerfectLens(const std::string& operands) {
    dir.write("perfect.dat", kLens);
    job = readDesignJob(dir.write("job.json",
                                  "{\"lens\": \"perfect.dat\", \"wavelengths_nm\": [587.56],\n"
                                  " \"operands\": [" +
                                      operands + "]}"));
    lens = job.start;
    lens.surfaces[2].shape.conic = -kN * kN;
  }
};

// n' sin u' of the marginal ray: from the rim of the beam (height 10 on the hyperboloid, whose
// sag is c h^2 / (1 + sqrt(1 - (1 + k) c^2 h^2))) to the focus.
double marginalNa() {
  const double c = 1 / kR, k = -kN * kN, h = kStopRadius;
  const double sag = c * h * h / (1 + std::sqrt(1 - (1 + k) * c * c * h * h));
  return h / std::hypot(h, kFocus - sag);
}

// The MTF of an aberration-free circular pupil at nu / cutoff.
double circularPupilMtf(double v) {
  return v >= 1 ? 0 : 2 / std::numbers::pi * (std::acos(v) - v * std::sqrt(1 - v * v));
}

TEST(DesignWavefrontOperand, DefocusMatchesTheClosedForm) {
  // A film moved by dz sees W = n' dz (1 - gamma) (Hopkins; gamma the ray's direction cosine
  // along the axis), first order in dz, exact in angle. Over a pupil uniform in the direction
  // cosines out to NA, t = (alpha^2 + beta^2) / NA^2 is uniform on [0, 1], so
  //   <gamma> = 2 (1 - (1 - NA^2)^(3/2)) / (3 NA^2),  <gamma^2> = 1 - NA^2 / 2,
  // and RMS W = dz sqrt(<gamma^2> - <gamma>^2). Its leading term is W020 / sqrt(12) with
  // W020 = dz NA^2 / 2 (W = W020 rho^2: <rho^4> - <rho^2>^2 = 1/3 - 1/4 = 1/12).
  PerfectLens s("{\"type\": \"rms_wavefront\", \"field_deg\": 0}");
  const double na = marginalNa();
  const double g1 = 2 * (1 - std::pow(1 - na * na, 1.5)) / (3 * na * na), g2 = 1 - na * na / 2;
  for (double dz : {0.05, -0.1}) {
    LensPrescription p = s.lens;
    p.surfaces.back().thickness_mm = kFocus + dz;
    const double rms = operandValues(s.job, p)[0];
    const double exact = std::abs(dz) * std::sqrt(g2 - g1 * g1) / (kLambda_nm * 1e-6);
    EXPECT_NEAR(rms, exact, 0.01 * exact) << "dz " << dz;
    const double w020 = std::abs(dz) * na * na / 2 / (kLambda_nm * 1e-6);
    EXPECT_NEAR(rms, w020 / std::sqrt(12.0), 0.02 * exact) << "dz " << dz;
    std::printf("defocus %g mm: rms_wavefront %.6f waves, closed form %.6f, W020/sqrt(12) %.6f\n",
                dz, rms, exact, w020 / std::sqrt(12.0));
  }
  // In focus: no aberration (the hyperboloid is perfect).
  EXPECT_LT(operandValues(s.job, s.lens)[0], 1e-3);
}

TEST(DesignTolerance, IrregularityWavefrontMatchesTheClosedForm) {
  // W fringes of irregularity on the plane front surface (h = its semi-aperture, 10 mm here,
  // the beam's radius): the sag departs by A ((r/h)^4 + (y/h)^2), A = W lambda_t / 4 (on a plane
  // base the astigmatic half is a sphere of curvature 2A/h^2 along y: A (y/h)^2 up to 1e-8 of
  // it). In collimated light the wavefront follows (n - 1) times the sag departure (first order
  // in A). Over the unit disc, f = alpha rho^4 + beta rho^2 sin^2(phi) has variance
  //   alpha^2 (1/5 - 1/9) + alpha beta (1/4 - 1/6) + beta^2 (1/8 - 1/16),
  // so with alpha = beta = 1, RMS f = sqrt(0.2347222...) = 0.48448 (no tilt to remove).
  PerfectLens s("{\"type\": \"rms_wavefront\", \"field_deg\": 0}");
  s.lens.surfaces[1].aperture_diameter_mm = 2 * kStopRadius;
  for (double w : {1.0, -2.5}) {
    Tolerance t;
    t.kind = Tolerance::Kind::Irregularity;
    t.surface = t.last_surface = 1;
    t.delta = std::abs(w);
    t.test_wavelength_nm = 632.8;
    const LensPrescription p = applyTolerance(s.lens, t, w);
    const double a = std::abs(w) * 632.8e-6 / 4;
    const double exact =
        (kN - 1) * a * std::sqrt(4.0 / 45 + 1.0 / 12 + 1.0 / 16) / (kLambda_nm * 1e-6);
    const double rms = operandValues(s.job, p)[0];
    EXPECT_NEAR(rms, exact, 0.03 * exact) << w << " fringes";
    std::printf("irregularity %g fringes: rms_wavefront %.6f waves, closed form %.6f\n", w, rms,
                exact);
  }
}

TEST(DesignMtfOperand, InFocusMatchesTheCircularPupilMtf) {
  const double cutoff = 2 * marginalNa() / (kLambda_nm * 1e-6);  // cycles/mm
  std::string ops;
  for (double v : {0.2, 0.5, 0.8})
    for (const char* az : {"tangential", "sagittal"})
      ops += std::string(ops.empty() ? "" : ",\n") +
             "{\"type\": \"mtf\", \"frequency\": " + std::to_string(v * cutoff) +
             ", \"azimuth\": \"" + az + "\", \"target\": 1}";
  PerfectLens s(ops);
  const std::vector<double> mtf = operandValues(s.job, s.lens);
  ASSERT_EQ(mtf.size(), 6u);
  int k = 0;
  for (double v : {0.2, 0.5, 0.8})
    for (int az = 0; az < 2; ++az, ++k) {
      EXPECT_NEAR(mtf[k], circularPupilMtf(v), 0.005) << v << " " << az;
      std::printf("mtf at %.2f of the cutoff, %s: %.5f, closed form %.5f\n", v, az ? "sag" : "tan",
                  mtf[k], circularPupilMtf(v));
    }
  // Defocus lowers it: a quarter wave of W020 takes the mid frequency well below the limit.
  LensPrescription p = s.lens;
  p.surfaces.back().thickness_mm += 0.5 * kLambda_nm * 1e-6 / std::pow(marginalNa(), 2);
  EXPECT_LT(operandValues(s.job, p)[2], circularPupilMtf(0.5) - 0.05);
}

// Optimised through the operands: the film distance from 0.03 mm (a quarter wave of W020) out of
// focus back to the focus. (From farther out, an MTF at a high frequency passes through zeros and
// side lobes as the film moves: its merit has local minima there.)
TEST(DesignTolerance, MtfCriterionMatchesTheCircularPupilAndFallsWithDefocus) {
  // The criterion "mtf": on the lens perfect on axis, the nominal is the aberration-free MTF at
  // the frequency (both azimuths); an error of the film distance defocuses it, and the back-focus
  // compensator (the best RMS-spot plane) restores it.
  PerfectLens s("{\"type\": \"efl\", \"target\": 100}");
  const double cutoff = 2 * marginalNa() / (kLambda_nm * 1e-6);
  DesignJob job = s.job;
  job.start = s.lens;
  job.fields_deg = {0};
  job.tolerance.criterion = "mtf";
  job.tolerance.mtf_frequency = 0.5 * cutoff;
  job.tolerance.monte_carlo = 6;
  Tolerance t;
  t.kind = Tolerance::Kind::Thickness;
  t.surface = t.last_surface = 2;
  t.delta = 0.02;
  t.distribution = Tolerance::Distribution::EndPoint;
  job.tolerance.tolerances = {t};
  for (bool compensate : {false, true}) {
    job.tolerance.back_focus_compensator = compensate;
    const ToleranceResult r = runTolerancing(job);
    EXPECT_NEAR(r.nominal, circularPupilMtf(0.5), 0.005) << compensate;
    if (!compensate) {
      // 0.02 mm of defocus: W020 = dz NA^2 / 2 of 0.17 waves.
      EXPECT_LT(r.sensitivity[0].plus, -0.02);
      EXPECT_LT(r.sensitivity[0].minus, -0.02);
      EXPECT_EQ(r.worst, *std::min_element(r.builds.begin(), r.builds.end()));
      EXPECT_LT(r.worst, r.nominal - 0.02);
    } else {
      EXPECT_NEAR(r.sensitivity[0].plus, 0, 0.005);
      EXPECT_NEAR(r.sensitivity[0].minus, 0, 0.005);
    }
    std::printf("mtf criterion (compensator %d): nominal %.5f (closed form %.5f), +%.4f / %.4f\n",
                compensate, r.nominal, circularPupilMtf(0.5), r.sensitivity[0].plus,
                r.sensitivity[0].minus);
  }
}

TEST(DesignWavefrontOperand, OptimisationFindsTheFocus) {
  for (const char* op : {"{\"type\": \"rms_wavefront\"}",
                         "{\"type\": \"mtf\", \"frequency\": 100, \"target\": 1}"}) {
    TempDir dir;
    dir.write("perfect.dat", kLens);
    DesignJob job = readDesignJob(dir.write(
        "job.json", std::string("{\"lens\": \"perfect.dat\", \"wavelengths_nm\": [587.56],\n"
                                " \"variables\": [{\"type\": \"thickness\", \"surface\": 2, "
                                "\"min\": 99, \"max\": 101}],\n"
                                " \"operands\": [") +
                        op + "]}"));
    job.start.surfaces[2].shape.conic = -kN * kN;
    job.start.surfaces[2].thickness_mm = kFocus + 0.03;
    const DesignResult r = optimiseDesign(job);
    EXPECT_NEAR(r.lens.surfaces[2].thickness_mm, kFocus, 1e-4) << op << ": " << r.stop_reason;
    std::printf("%s: film %.6f mm (focus %.1f), %d iterations, %s\n", op,
                r.lens.surfaces[2].thickness_mm, kFocus, r.iterations, r.stop_reason.c_str());
  }
}

// The Jacobian evaluates operands from several threads at once: the MTF's FFTs (whose planner is
// not thread-safe) must give the serial values.
TEST(DesignMtfOperand, ConcurrentEvaluationsMatchTheSerialOne) {
  PerfectLens s("{\"type\": \"mtf\", \"frequency\": 120, \"target\": 1}");
  const double serial = operandValues(s.job, s.lens)[0];
  std::vector<double> got(8, -1);
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&, t] { got[t] = operandValues(s.job, s.lens)[0]; });
  for (std::thread& t : threads) t.join();
  for (double v : got) EXPECT_EQ(v, serial);
}

TEST(DesignMtfOperand, JobErrorsNameTheValue) {
  TempDir dir;
  dir.write("perfect.dat", kLens);
  auto err = [&](const std::string& op) {
    try {
      readDesignJob(
          dir.write("bad.json", "{\"lens\": \"perfect.dat\",\n \"operands\": [\n  " + op + "]}"));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(err("{\"type\": \"mtf\", \"target\": 0.5}")
                .find("bad.json:3:3: error: missing \"frequency\""),
            std::string::npos)
      << err("{\"type\": \"mtf\", \"target\": 0.5}");
  EXPECT_NE(err("{\"type\": \"mtf\", \"frequency\": 50, \"azimuth\": \"radial\", \"target\": 1}")
                .find("\"azimuth\" \"radial\": expected tangential or sagittal"),
            std::string::npos);
  EXPECT_NE(err("{\"type\": \"rms_wavefront\", \"frequency\": 50}").find("belong to mtf operands"),
            std::string::npos);
}

}  // namespace
