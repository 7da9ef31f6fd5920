// Textbook case (issue 33): the Cooke triplet of tests/data/design/cooke-triplet.dat (ray-optics'
// sample after Kingslake; source in the file) re-optimised for EFL 50 mm, f/4 and a 20 degree
// half field reaches an RMS spot no worse than the published design's, both at their best
// focus. lensim's RMS spot is checked on axis by a meridional exact trace written here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <vector>

#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/tolerance.h"
#include "lensim/optics/prescription.h"
#include "meridional_trace.h"
#include "scene_test_util.h"
#include "test_paths.h"

namespace {

using namespace lensim::optics;
using namespace lensim::optics::design;

constexpr double kD = 587.5618;

// RMS radius (mm) on the film of an axial bundle from infinity filling the paraxial entrance
// pupil, at the d line, with the catalogue's n_d given per medium (n_after[i]: after row i).
// Exact meridional trace (meridional_trace.h); by symmetry the spot is a function of the pupil
// radius rho only, rms^2 = integral of r(rho)^2 2 rho d rho / a^2 (midpoint rule).
double axialRms(const LensPrescription& p, const std::vector<double>& n_after) {
  const size_t m = p.surfaces.size();
  // Paraxial entrance pupil: the stop's radius over the height there of a unit parallel ray.
  int stop = -1;
  double y = 1, nu = 0, n = 1, a = 0;
  for (size_t i = 0; i < m; ++i) {
    if (p.surfaces[i].radius_mm == 0 && n_after[i] == 0) {
      stop = static_cast<int>(i);
      a = 0.5 * p.surfaces[i].aperture_diameter_mm / y;
    }
    const double c = p.surfaces[i].radius_mm == 0 ? 0 : 1 / p.surfaces[i].radius_mm;
    const double n2 = n_after[i] == 0 ? n : n_after[i];
    nu -= y * c * (n2 - n);
    n = n2;
    y += p.surfaces[i].thickness_mm * nu / n;
  }
  EXPECT_GE(stop, 0);
  std::vector<lensim::test::MeridionalRow> rows;
  for (size_t i = 0; i < m; ++i)
    rows.push_back({p.surfaces[i].radius_mm, p.surfaces[i].thickness_mm, n_after[i]});
  auto filmHeight = [&](double h) { return lensim::test::meridionalFilmHeight(rows, h, 0); };
  const int N = 4000;
  double s = 0;
  for (int k = 0; k < N; ++k) {
    const double rho = (k + 0.5) / N;
    const double r = filmHeight(rho * a);
    s += r * r * 2 * rho / N;
  }
  return std::sqrt(s);
}

// Paraxial f-number f / (2 a) at the d line: EFL from a y-nu trace of a unit parallel ray, a
// the entrance-pupil radius (the stop's radius over that ray's height at the stop).
double paraxialFNumber(const LensPrescription& p, const std::vector<double>& n_after) {
  double y = 1, nu = 0, n = 1, a = 0;
  for (size_t i = 0; i < p.surfaces.size(); ++i) {
    if (p.surfaces[i].radius_mm == 0 && n_after[i] == 0)
      a = 0.5 * p.surfaces[i].aperture_diameter_mm / y;
    const double c = p.surfaces[i].radius_mm == 0 ? 0 : 1 / p.surfaces[i].radius_mm;
    const double n2 = n_after[i] == 0 ? n : n_after[i];
    nu -= y * c * (n2 - n);
    n = n2;
    y += p.surfaces[i].thickness_mm * nu / n;
  }
  return (-1 / nu) / (2 * a);
}

TEST(DesignTextbook, CookeTripletNoWorseThanThePublishedDesign) {
  lensim::testutil::TempDir dir("lensim-triplet");
  const std::string lens = lensim::test::dataPath("design/cooke-triplet.dat");
  std::ofstream(dir.path() / "job.json") << R"({
  "lens": ")" << lens << R"(",
  "wavelengths_nm": [587.5618, 486.1327, 656.2725],
  "fields_deg": [0, 14, 20],
  "max_iterations": 60,
  "variables": [
    {"type": "curvature", "surface": 0}, {"type": "curvature", "surface": 1},
    {"type": "curvature", "surface": 3}, {"type": "curvature", "surface": 4},
    {"type": "curvature", "surface": 5}, {"type": "curvature", "surface": 6},
    {"type": "thickness", "surface": 6, "min": 30, "max": 50}
  ],
  "operands": [
    {"type": "efl", "target": 50, "weight": 10000},
    {"type": "f_number", "target": 4, "weight": 10000},
    {"type": "image_height", "field_deg": 20, "min": 17, "max": 19, "weight": 100},
    {"type": "rms_spot", "weight": 1000}
  ]
}
)";
  const DesignJob job = readDesignJob((dir.path() / "job.json").string());
  const DesignResult r = optimiseDesign(job);
  // The stopping rule is met (the merit's fall over 10 iterations), not the iteration limit.
  EXPECT_EQ(r.stop_reason.rfind("merit fell by less than", 0), 0u) << r.stop_reason;
  EXPECT_LT(r.iterations, 40);
  // Stated first-order targets.
  EXPECT_NEAR(r.values[0], 50, 0.01);
  EXPECT_NEAR(r.values[1], 4, 0.01);

  // The criterion: RMS over the 3 fields x 3 wavelengths of the RMS spot, each lens at the film
  // that minimises it (the back-focus compensator), published against optimised.
  double dz_pub = 0, dz_opt = 0;
  const double pub = toleranceCriterion(job, job.start, &dz_pub);
  const double opt = toleranceCriterion(job, r.lens, &dz_opt);
  EXPECT_LE(opt, pub) << "optimised " << opt << " mm, published " << pub << " mm";

  // lensim's axial d-line spot against the independent trace, both lenses at their best focus.
  const std::vector<double> n_after{1.69100, 1, 0, 1.67271, 1, 1.69100, 1};
  // The f_number operand against the test's paraxial trace (the published lens: f/4.000); the
  // test's indices are the catalogue's 5-decimal n_d, lensim's from the Sellmeier fits (they
  // differ by up to 1e-5, 6e-5 in the f-number).
  EXPECT_NEAR(operandValues(job, job.start)[1], paraxialFNumber(job.start, n_after), 2e-4);
  EXPECT_NEAR(r.values[1], paraxialFNumber(r.lens, n_after), 2e-4);
  for (int k = 0; k < 2; ++k) {
    LensPrescription p = k == 0 ? job.start : r.lens;
    p.surfaces.back().thickness_mm += k == 0 ? dz_pub : dz_opt;
    const double mine = axialRms(p, n_after);
    const double lensim_rms = rmsSpot_mm(p, 0, kD, kD, 12);
    EXPECT_NEAR(lensim_rms, mine, 0.02 * mine + 1e-5) << (k == 0 ? "published" : "optimised");
  }
  std::printf("triplet: published %.6f mm, optimised %.6f mm, %d iterations, %d evaluations, %s, EFL %.6f f/%.6f\n", pub, opt,
              r.iterations, r.evaluations, r.stop_reason.c_str(), r.values[0], r.values[1]);
}

}  // namespace
