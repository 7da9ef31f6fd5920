// Lens design (issue 33): damped least squares on closed-form problems, a singlet optimised to a
// target focal length checked by an independent trace written here, tolerancing against a
// linear prediction, seeds, and the job file's errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>

#include "cli_run.h"
#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/levenberg_marquardt.h"
#include "lensim/optics/design/tolerance.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/surface_shape.h"

namespace fs = std::filesystem;
using namespace lensim;
using namespace lensim::optics;
using namespace lensim::optics::design;

namespace {

// --- Closed-form problems --------------------------------------------------------------------

bool rosenbrock(const std::vector<double>& x, std::vector<double>& r) {
  r = {10 * (x[1] - x[0] * x[0]), 1 - x[0]};
  return true;
}

TEST(LevenbergMarquardt, RosenbrockReachesTheMinimum) {
  const LmResult r = levenbergMarquardt(rosenbrock, {-1.2, 1.0}, {}, {});
  EXPECT_NEAR(r.x[0], 1, 1e-6);
  EXPECT_NEAR(r.x[1], 1, 1e-6);
  EXPECT_LT(r.merit, 1e-12);
  EXPECT_GT(r.initial_merit, 1);
}

TEST(LevenbergMarquardt, ExponentialFitRecoversTheParameters) {
  // y = a exp(b t) sampled without noise: least squares recovers a = 2.5, b = -0.7 exactly.
  std::vector<double> t, y;
  for (int i = 0; i < 20; ++i) t.push_back(0.25 * i), y.push_back(2.5 * std::exp(-0.7 * 0.25 * i));
  auto f = [&](const std::vector<double>& x, std::vector<double>& r) {
    r.resize(t.size());
    for (size_t i = 0; i < t.size(); ++i) r[i] = x[0] * std::exp(x[1] * t[i]) - y[i];
    return true;
  };
  const LmResult r = levenbergMarquardt(f, {1.0, 0.0}, {}, {});
  EXPECT_NEAR(r.x[0], 2.5, 1e-7);
  EXPECT_NEAR(r.x[1], -0.7, 1e-7);
}

TEST(LevenbergMarquardt, BoundsHoldAndTheBoundedMinimumIsFound) {
  // (x - 3)^2 + (y + 1)^2 with x <= 2, y >= 0: the minimum is the corner (2, 0).
  auto f = [](const std::vector<double>& x, std::vector<double>& r) {
    r = {x[0] - 3, x[1] + 1};
    return true;
  };
  const LmResult r = levenbergMarquardt(f, {0.0, 5.0}, {-10, 0}, {2, 10});
  EXPECT_NEAR(r.x[0], 2, 1e-9);
  EXPECT_NEAR(r.x[1], 0, 1e-9);
  EXPECT_NEAR(r.merit, 2, 1e-9);
}

TEST(LevenbergMarquardt, FiniteDifferenceJacobianMatchesAnalytic) {
  const std::vector<double> x{-0.8, 0.3};
  std::vector<double> r0, jac;
  rosenbrock(x, r0);
  ASSERT_TRUE(finiteDifferenceJacobian(rosenbrock, x, r0, {}, {}, {}, jac));
  const double analytic[4] = {-20 * x[0], 10, -1, 0};
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(jac[k], analytic[k], 1e-6 * std::max(1.0, std::abs(analytic[k])));
}

TEST(LevenbergMarquardt, CholeskySolvesAndRefusesIndefinite) {
  std::vector<double> x;
  ASSERT_TRUE(solveCholesky({4, 2, 2, 3}, {2, 1}, 2, x));
  EXPECT_NEAR(4 * x[0] + 2 * x[1], 2, 1e-12);
  EXPECT_NEAR(2 * x[0] + 3 * x[1], 1, 1e-12);
  EXPECT_FALSE(solveCholesky({1, 2, 2, 1}, {1, 1}, 2, x));
}

// --- An independent sequential tracer for spherical lenses (stop first, objects at infinity) ---

struct Row {
  double radius, thickness, n_after;
};

// Paraxial y-nu trace of a ray parallel to the axis at height 1: EFL = -1 / (n u') at the end.
double independentEfl(const std::vector<Row>& rows) {
  double y = 1, nu = 0, n = 1;
  for (size_t i = 0; i < rows.size(); ++i) {
    const double c = rows[i].radius == 0 ? 0 : 1 / rows[i].radius;
    nu -= y * (rows[i].n_after - n) * c;
    n = rows[i].n_after;
    if (i + 1 < rows.size()) y += rows[i].thickness * nu / n;
  }
  return -1 / nu;
}

// Paraxial back focal length: rear vertex to where the ray above crosses the axis.
double independentBfl(const std::vector<Row>& rows) {
  double y = 1, nu = 0, n = 1;
  for (size_t i = 0; i < rows.size(); ++i) {
    const double c = rows[i].radius == 0 ? 0 : 1 / rows[i].radius;
    nu -= y * (rows[i].n_after - n) * c;
    n = rows[i].n_after;
    if (i + 1 < rows.size()) y += rows[i].thickness * nu / n;
  }
  return -y / nu;
}

// Exact trace of one ray (origin at z = 0, the first row's vertex) through spherical rows by
// vector refraction, to the plane at the last thickness: the (x, y) it meets there.
std::pair<double, double> independentTrace(const std::vector<Row>& rows, double ox, double oy,
                                           const double dir[3]) {
  double o[3] = {ox, oy, 0}, d[3] = {dir[0], dir[1], dir[2]};
  double z = 0, n = 1;
  for (size_t i = 0; i < rows.size(); ++i) {
    if (rows[i].radius != 0) {
      const double R = rows[i].radius, cz = z + R;
      const double oc[3] = {o[0], o[1], o[2] - cz};
      const double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
      const double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - R * R;
      const double disc = std::sqrt(b * b - c);
      // The root on the vertex side: for R > 0 the nearer hit, for R < 0 the farther one.
      const double t = R > 0 ? -b - disc : -b + disc;
      for (int k = 0; k < 3; ++k) o[k] += t * d[k];
      // The unit normal facing the incoming ray (toward -z at the vertex).
      const double nrm[3] = {o[0] / R, o[1] / R, (o[2] - cz) / R};
      const double mu = n / rows[i].n_after;
      const double cosi = -(nrm[0] * d[0] + nrm[1] * d[1] + nrm[2] * d[2]);
      const double k2 = 1 - mu * mu * (1 - cosi * cosi);
      for (int k = 0; k < 3; ++k) d[k] = mu * d[k] + (mu * cosi - std::sqrt(k2)) * nrm[k];
    }
    n = rows[i].n_after;
    z += rows[i].thickness;
  }
  const double t = (z - o[2]) / d[2];
  return {o[0] + t * d[0], o[1] + t * d[1]};
}

// RMS spot (mm) of the on-axis beam filling a stop of radius `stop_r` at the first row (z = 0),
// on the plane at the last thickness: a dense square grid of rays.
double independentAxialRms(const std::vector<Row>& rows, double stop_r) {
  const int grid = 160;
  const double axis[3] = {0, 0, 1};
  double sx = 0, sy = 0, sxx = 0;
  int count = 0;
  for (int iy = 0; iy < grid; ++iy)
    for (int ix = 0; ix < grid; ++ix) {
      const double px = stop_r * (2.0 * (ix + 0.5) / grid - 1), py = stop_r * (2.0 * (iy + 0.5) / grid - 1);
      if (px * px + py * py > stop_r * stop_r) continue;
      const auto [x, y] = independentTrace(rows, px, py, axis);
      sx += x, sy += y, sxx += x * x + y * y;
      ++count;
    }
  const double mx = sx / count, my = sy / count;
  return std::sqrt(sxx / count - mx * mx - my * my);
}

std::vector<Row> rowsOf(const LensPrescription& p) {
  std::vector<Row> rows;
  for (const LensSurface& s : p.surfaces) rows.push_back({s.radius_mm, s.thickness_mm, s.ior == 0 ? 1 : s.ior});
  return rows;
}

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("lensim_design_" + std::to_string(std::random_device{}()));
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name) << text;
    return (path / name).string();
  }
};

// A biconvex N-BK7 singlet behind a 20 mm stop, with a constant index (no dispersion) so the
// independent tracer needs no dispersion formula.
const char* kSinglet =
    "# singlet\n"
    "0      5    1       20\n"
    "80     4    1.5168  30\n"
    "-120   90   1       30\n";

std::string singletJob(const std::string& lens, const std::string& extra = "",
                      const std::string& extra_variables = "") {
  return std::string("{\n  \"lens\": \"") + lens + "\",\n"
         "  \"fields_deg\": [0],\n"
         "  \"variables\": [\n" + extra_variables +
         "    {\"type\": \"curvature\", \"surface\": 1},\n"
         "    {\"type\": \"curvature\", \"surface\": 2},\n"
         "    {\"type\": \"thickness\", \"surface\": 2, \"min\": 50, \"max\": 150}\n"
         "  ],\n"
         "  \"operands\": [\n"
         "    {\"type\": \"efl\", \"target\": 100, \"weight\": 1000},\n"
         "    {\"type\": \"rms_spot\", \"weight\": 100}\n"
         "  ]" + extra + "\n}\n";
}

TEST(LensDesign, SingletReachesTargetEflWithSmallerSpotByIndependentTrace) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  const std::string job_path = dir.write("job.json", singletJob("singlet.dat"));
  const DesignJob job = readDesignJob(job_path);
  const DesignResult r = optimiseDesign(job);
  const std::vector<Row> before = rowsOf(job.start), after = rowsOf(r.lens);
  // The target focal length, by the independent paraxial trace.
  EXPECT_NEAR(independentEfl(after), 100, 1e-3);
  EXPECT_GT(std::abs(independentEfl(before) - 100), 5);
  // The spot: smaller than the start's (focused at its own paraxial focus for fairness), and the
  // design's own RMS agrees with the independent dense-grid trace within 2%.
  std::vector<Row> before_focused = before;
  before_focused.back().thickness = independentBfl(before);
  const double rms_before = independentAxialRms(before_focused, 10);
  const double rms_after = independentAxialRms(after, 10);
  EXPECT_LT(rms_after, 0.8 * rms_before) << rms_before << " -> " << rms_after;
  EXPECT_NEAR(rmsSpot_mm(r.lens, 0, kLineD_nm, kLineD_nm, job.rings), rms_after, 0.02 * rms_after);
  // Reproducible: the same job gives the same lens.
  const DesignResult again = optimiseDesign(job);
  for (size_t i = 0; i < after.size(); ++i) {
    EXPECT_EQ(again.lens.surfaces[i].radius_mm, r.lens.surfaces[i].radius_mm);
    EXPECT_EQ(again.lens.surfaces[i].thickness_mm, r.lens.surfaces[i].thickness_mm);
  }
}

TEST(LensDesign, SpotQuadraticMatchesSpotsOnShiftedFilms) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  const DesignJob job = readDesignJob(dir.write("job.json", singletJob("singlet.dat")));
  const SpotQuadratic q = spotQuadratic(job.start, 3, kLineD_nm, kLineD_nm, 6);
  for (double dz : {-2.0, 0.5, 3.0}) {
    LensPrescription p = job.start;
    p.surfaces.back().thickness_mm += dz;
    const double rms = rmsSpot_mm(p, 3, kLineD_nm, kLineD_nm, 6);
    EXPECT_NEAR(rms * rms, q.a + 2 * q.b * dz + q.c * dz * dz, 1e-9 * (1 + rms * rms));
  }
}

// The independent tracer's rays that are lost: a sphere missed or total internal reflection.
std::optional<std::pair<double, double>> independentTraceLost(const std::vector<Row>& rows,
                                                              double ox, double oy,
                                                              const double dir[3]) {
  double o[3] = {ox, oy, 0}, d[3] = {dir[0], dir[1], dir[2]};
  double z = 0, n = 1;
  for (const Row& row : rows) {
    if (row.radius != 0) {
      const double R = row.radius, cz = z + R;
      const double oc[3] = {o[0], o[1], o[2] - cz};
      const double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
      const double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - R * R;
      if (b * b - c < 0) return std::nullopt;
      const double t = R > 0 ? -b - std::sqrt(b * b - c) : -b + std::sqrt(b * b - c);
      for (int k = 0; k < 3; ++k) o[k] += t * d[k];
      const double nrm[3] = {o[0] / R, o[1] / R, (o[2] - cz) / R};
      const double mu = n / row.n_after;
      const double cosi = -(nrm[0] * d[0] + nrm[1] * d[1] + nrm[2] * d[2]);
      const double k2 = 1 - mu * mu * (1 - cosi * cosi);
      if (k2 < 0) return std::nullopt;
      for (int k = 0; k < 3; ++k) d[k] = mu * d[k] + (mu * cosi - std::sqrt(k2)) * nrm[k];
    }
    n = row.n_after;
    z += row.thickness;
  }
  if (!(d[2] > 0)) return std::nullopt;
  const double t = (z - o[2]) / d[2];
  return std::pair{o[0] + t * d[0], o[1] + t * d[1]};
}

// A stop-first lens whose steep rear surface (R -7 mm) the wide beams partly miss or reflect
// totally: the beam that reaches the film is the part of the stop whose rays pass.
const char* kSteepSinglet =
    "# steep singlet\n"
    "0      2    1       8\n"
    "14     7    1.5168  20\n"
    "-7     14   1       13.9\n";

TEST(LensDesign, RmsSpotOfABeamPartlyLostIsThatOfThePassingRays) {
  TempDir dir;
  dir.write("steep.dat", kSteepSinglet);
  const DesignJob job = readDesignJob(dir.write("job.json", singletJob("steep.dat")));
  const std::vector<Row> rows = rowsOf(job.start);
  // Independently: a dense grid over the stop (radius 4 at z = 0, the entrance pupil and its
  // chief ray's crossing), the rays that pass, their RMS about the centroid on the film.
  auto dense = [&](double deg, double* lost_share) {
    const double th = deg * M_PI / 180, dir[3] = {0, std::sin(th), std::cos(th)};
    const int grid = 400;
    double sx = 0, sy = 0, sxx = 0;
    int count = 0, lost = 0;
    for (int iy = 0; iy < grid; ++iy)
      for (int ix = 0; ix < grid; ++ix) {
        const double px = 4 * (2.0 * (ix + 0.5) / grid - 1), py = 4 * (2.0 * (iy + 0.5) / grid - 1);
        if (px * px + py * py > 16) continue;
        const auto hit = independentTraceLost(rows, px, py, dir);
        if (!hit) {
          ++lost;
          continue;
        }
        sx += hit->first, sy += hit->second, sxx += hit->first * hit->first + hit->second * hit->second;
        ++count;
      }
    *lost_share = double(lost) / (lost + count);
    const double mx = sx / count, my = sy / count;
    return std::sqrt(sxx / count - mx * mx - my * my);
  };
  double lost_small = 0, lost_wide = 0;
  const double rms_small = dense(5, &lost_small), rms_wide = dense(30, &lost_wide);
  EXPECT_EQ(lost_small, 0);
  EXPECT_GT(lost_wide, 0.05);
  EXPECT_LT(lost_wide, 0.5);
  EXPECT_NEAR(rmsSpot_mm(job.start, 5, kLineD_nm, kLineD_nm, 8), rms_small, 0.01 * rms_small);
  EXPECT_NEAR(rmsSpot_mm(job.start, 30, kLineD_nm, kLineD_nm, 8), rms_wide, 0.02 * rms_wide)
      << "lost share " << lost_wide;
  // Continuous as rays start to be lost: the onset angle by bisection on the rim's rays
  // (independently), and the RMS just below and above it.
  auto rimLost = [&](double deg) {
    const double th = deg * M_PI / 180, dir[3] = {0, std::sin(th), std::cos(th)};
    for (int k = 0; k < 720; ++k) {
      const double a = 2 * M_PI * k / 720;
      if (!independentTraceLost(rows, 4 * std::cos(a), 4 * std::sin(a), dir)) return true;
    }
    return false;
  };
  double lo = 5, hi = 30;
  for (int it = 0; it < 40; ++it) (rimLost(0.5 * (lo + hi)) ? hi : lo) = 0.5 * (lo + hi);
  const double below = rmsSpot_mm(job.start, lo - 1e-4, kLineD_nm, kLineD_nm, 8);
  const double above = rmsSpot_mm(job.start, hi + 1e-4, kLineD_nm, kLineD_nm, 8);
  EXPECT_NEAR(above, below, 2e-3 * below) << "onset " << hi << " deg";
}

TEST(LensDesign, WideFieldsOfAPatentLensAreEvaluated) {
  // US 583,336 (f/4.5): part of the 14 and 19 deg beams misses a surface; they are evaluated on
  // the rays that pass, the spot growing with the field.
  TempDir dir;
  const DesignJob job = readDesignJob(dir.write(
      "job.json", std::string("{\"lens\": \"") + LENSIM_SHARED_DIR +
                      "/lenses/zmx/US00583336-2-scaled.zmx\", \"fields_deg\": [0, 14, 19],\n"
                      "\"variables\": [{\"type\": \"curvature\", \"surface\": 1}],\n"
                      "\"operands\": [{\"type\": \"rms_spot\", \"weight\": 1}]}\n"));
  const std::vector<double> v = operandValues(job, job.start);
  ASSERT_EQ(v.size(), 3u);
  for (double x : v) EXPECT_TRUE(std::isfinite(x) && x > 0) << x;
  EXPECT_LT(v[0], v[1]);
}

TEST(LensDesign, GlassVariablesSnapToTheCatalogue) {
  TempDir dir;
  dir.write("singlet.dat",
            "0      5    1       20\n"
            "80     4    1.5168  30  64.17 N-BK7\n"
            "-120   90   1       30\n");
  const std::string job = dir.write(
      "job.json",
      singletJob("singlet.dat", ",\n  \"max_iterations\": 5",
                 "    {\"type\": \"glass_nd\", \"surface\": 1, \"min\": 1.6, \"max\": 1.7},\n"));
  const DesignResult r = optimiseDesign(readDesignJob(job));
  ASSERT_EQ(r.snapped.size(), 1u);
  const LensSurface& s = r.lens.surfaces[1];
  ASSERT_NE(GlassCatalog::builtin().find(s.glass.name), nullptr) << s.glass.name;
  EXPECT_GE(*s.glass.n_d, 1.59);
  EXPECT_LE(*s.glass.n_d, 1.71);
}

TEST(LensDesign, OperandValuesAgreeWithTheIndependentTrace) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  std::string text = singletJob("singlet.dat");
  const std::string from = "    {\"type\": \"rms_spot\", \"weight\": 100}\n";
  text.replace(text.find(from), from.size(),
               "    {\"type\": \"bfl\", \"target\": 0},\n"
               "    {\"type\": \"total_track\", \"target\": 0},\n"
               "    {\"type\": \"image_height\", \"field_deg\": 6, \"target\": 0},\n"
               "    {\"type\": \"distortion\", \"field_deg\": 6, \"target\": 0},\n"
               "    {\"type\": \"thickness\", \"surface\": 1, \"min\": 5}\n");
  const DesignJob job = readDesignJob(dir.write("job.json", text));
  const std::vector<double> v = operandValues(job, job.start);
  const std::vector<Row> rows = rowsOf(job.start);
  const double efl = independentEfl(rows);
  EXPECT_NEAR(v[0], efl, 1e-9 * efl);
  EXPECT_NEAR(v[1], independentBfl(rows), 1e-9 * efl);
  EXPECT_NEAR(v[2], 99.0, 1e-12);
  // The chief ray of a stop-first lens goes through the front vertex (the stop's centre).
  const double th = 6 * M_PI / 180, dir6[3] = {std::sin(th), 0, std::cos(th)};
  const double h = independentTrace(rows, 0, 0, dir6).first;
  EXPECT_NEAR(v[3], h, 1e-9);
  EXPECT_NEAR(v[4], 100 * (h - efl * std::tan(th)) / (efl * std::tan(th)), 1e-7);
  EXPECT_NEAR(v[5], 4, 1e-12);
  // The limit operand's residual: the weighted shortfall below the minimum.
  EXPECT_NEAR(operandResidual(job.operands[5], v[5]), 1.0, 1e-12);
}

TEST(LensDesign, EdgeThicknessAndClearApertureAgreeWithTheIndependentGeometry) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  std::string text = singletJob("singlet.dat");
  text.replace(text.find("\"fields_deg\": [0]"), 17, "\"fields_deg\": [0, 6]");
  const std::string from = "    {\"type\": \"rms_spot\", \"weight\": 100}\n";
  text.replace(text.find(from), from.size(),
               "    {\"type\": \"edge_thickness\", \"surface\": 1, \"min\": 1.5},\n"
               "    {\"type\": \"clear_aperture\", \"surface\": 1},\n"
               "    {\"type\": \"clear_aperture\", \"surface\": 2, \"max\": 10.5}\n");
  const DesignJob job = readDesignJob(dir.write("job.json", text));
  const std::vector<double> v = operandValues(job, job.start);
  ASSERT_EQ(v.size(), 4u);
  // Edge: both rows' semi-apertures are 15 mm; the sphere's sag R - sgn(R) sqrt(R^2 - h^2).
  auto sag = [](double R, double h) { return R - (R > 0 ? 1 : -1) * std::sqrt(R * R - h * h); };
  EXPECT_NEAR(v[1], 4 + sag(-120, 15) - sag(80, 15), 1e-12);
  EXPECT_EQ(operandResidual(job.operands[1], v[1]), 0);  // 1.640 mm > 1.5
  // Clear aperture of row 1: the 6 deg beam's rim ray from (10, 0) at the stop (z = 0) toward
  // (sin 6, 0, cos 6) meets the sphere R 80 whose vertex is at z = 5: the largest height of the
  // rims of both beams (the test's own intersection over 720 rim points).
  double most = 0;
  for (double deg : {0.0, 6.0})
    for (int k = 0; k < 720; ++k) {
      const double th = deg * M_PI / 180, a = 2 * M_PI * k / 720;
      const double o[3] = {10 * std::cos(a), 10 * std::sin(a), 0}, d[3] = {std::sin(th), 0, std::cos(th)};
      const double oc[3] = {o[0], o[1], o[2] - 85};
      const double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
      const double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - 80 * 80;
      const double t = -b - std::sqrt(b * b - c);
      most = std::max(most, std::hypot(o[0] + t * d[0], o[1] + t * d[1]));
    }
  EXPECT_NEAR(v[2], most, 1e-9);
  EXPECT_GT(most, 10.4);
  // Default limit: the row's semi-aperture as written (15 mm): inside, no residual.
  EXPECT_EQ(operandResidual(job.operands[2], v[2]), 0);
  // Row 2 with max 10.5: the excess is the residual.
  EXPECT_GT(v[3], 10.5);
  EXPECT_NEAR(operandResidual(job.operands[3], v[3]), v[3] - 10.5, 1e-12);
  EXPECT_EQ(job.operands[3].label(), "clear_aperture(surface 2)");
}

// Two singlets with the stop between them (rows 1 and 2 are the air gaps on its two sides).
const char* kStopBetween =
    "# stop between\n"
    "40     4    1.5168  20\n"
    "-200   8    1       20\n"
    "0      8    1       10\n"
    "200    4    1.5168  20\n"
    "-40    45   1       20\n";

TEST(LensDesign, StopPositionSlidesTheStopAndFindsTheScannedOptimum) {
  TempDir dir;
  dir.write("stop.dat", kStopBetween);
  const std::string job_text =
      "{\"lens\": \"stop.dat\", \"fields_deg\": [12],\n"
      " \"variables\": [{\"type\": \"stop_position\", \"min\": 1, \"max\": 15}],\n"
      " \"operands\": [{\"type\": \"distortion\", \"field_deg\": 12, \"target\": 0}]}\n";
  const DesignJob job = readDesignJob(dir.write("job.json", job_text));
  ASSERT_EQ(job.variables.size(), 1u);
  EXPECT_EQ(job.variables[0].surface, 2);
  EXPECT_EQ(variableValues(job.variables, job.start)[0], 8);
  // The stop slides; the rows around it keep their sum, the track stays.
  const LensPrescription moved = applyVariables(job.variables, job.start, {3.0});
  EXPECT_EQ(moved.surfaces[1].thickness_mm, 3);
  EXPECT_EQ(moved.surfaces[2].thickness_mm, 13);
  // Distortion against the stop's position, scanned in the test: the optimiser lands where the
  // scan's |distortion| is smallest (between its neighbours).
  double best_x = 0, best = 1e300;
  for (double x = 1; x <= 15 + 1e-9; x += 0.25) {
    const double d = std::abs(operandValues(job, applyVariables(job.variables, job.start, {x}))[0]);
    if (d < best) best = d, best_x = x;
  }
  const DesignResult r = optimiseDesign(job);
  const double x = variableValues(job.variables, r.lens)[0];
  EXPECT_NEAR(x, best_x, 0.25 + 1e-9) << "scan best " << best_x << " |distortion| " << best;
  EXPECT_LE(std::abs(r.values[0]), best + 1e-12);
  // A thickness variable on either side of the stop is refused at its line.
  const std::string clash =
      "{\"lens\": \"stop.dat\", \"fields_deg\": [12],\n"
      " \"variables\": [{\"type\": \"stop_position\"},\n"
      "   {\"type\": \"thickness\", \"surface\": 1}],\n"
      " \"operands\": [{\"type\": \"efl\", \"target\": 50}]}\n";
  try {
    readDesignJob(dir.write("clash.json", clash));
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("clash.json:3:4: error: a thickness variable of row 1 "
                                         "and the stop_position variable (line 2)"),
              std::string::npos)
        << e.what();
  }
}

// --- Tolerancing -------------------------------------------------------------------------------

std::string toleranceJob(const std::string& lens, int seed, const std::string& dist) {
  return std::string("{\n  \"lens\": \"") + lens + "\",\n"
         "  \"tolerancing\": {\n"
         "    \"criterion\": \"bfl\", \"compensator\": \"none\", \"monte_carlo\": 2000,\n"
         "    \"seed\": " + std::to_string(seed) + ",\n"
         "    \"tolerances\": [\n"
         "      {\"type\": \"thickness\", \"surface\": 1, \"delta\": 0.2, \"distribution\": \"" + dist + "\"},\n"
         "      {\"type\": \"radius\", \"surface\": 1, \"delta\": 0.5, \"distribution\": \"" + dist + "\"},\n"
         "      {\"type\": \"radius\", \"surface\": 2, \"delta\": 0.5, \"distribution\": \"" + dist + "\"}\n"
         "    ]\n  }\n}\n";
}

TEST(LensTolerance, MonteCarloSpreadMatchesTheLinearPrediction) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  const DesignJob job = readDesignJob(dir.write("job.json", toleranceJob("singlet.dat", 7, "uniform")));
  const ToleranceResult r = runTolerancing(job);
  const std::vector<Row> nominal = rowsOf(job.start);
  EXPECT_NEAR(r.nominal, independentBfl(nominal), 1e-9);
  // Linear response: slopes by central differences of the independent paraxial trace; uniform
  // on [-d, d] has variance d^2 / 3.
  double var = 0;
  const struct { int row; bool radius; double d; } tols[] = {{1, false, 0.2}, {1, true, 0.5}, {2, true, 0.5}};
  for (const auto& t : tols) {
    std::vector<Row> a = nominal, b = nominal;
    const double h = 1e-4;
    (t.radius ? a[t.row].radius : a[t.row].thickness) += h;
    (t.radius ? b[t.row].radius : b[t.row].thickness) -= h;
    const double slope = (independentBfl(a) - independentBfl(b)) / (2 * h);
    var += slope * slope * t.d * t.d / 3;
  }
  const double sd = std::sqrt(var), n = static_cast<double>(r.builds.size());
  // Mean within 4 standard errors (plus the small second-order bias); sd within 6%.
  EXPECT_NEAR(r.mean, r.nominal, 4 * sd / std::sqrt(n) + 1e-3 * sd);
  EXPECT_NEAR(r.stddev, sd, 0.06 * sd);
  EXPECT_GE(r.p90, r.p50);
  // Seeds reproduce exactly; another seed differs.
  const ToleranceResult again = runTolerancing(job);
  EXPECT_EQ(again.builds, r.builds);
  const DesignJob other = readDesignJob(dir.write("job2.json", toleranceJob("singlet.dat", 8, "uniform")));
  EXPECT_NE(runTolerancing(other).builds, r.builds);
}

TEST(LensTolerance, DistributionsHaveTheirStatedShapes) {
  Tolerance t;
  t.delta = 2;
  double m2u = 0, m2n = 0, maxn = 0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    t.distribution = Tolerance::Distribution::Uniform;
    const double u = drawTolerance(t, 3, k, 0);
    m2u += u * u;
    t.distribution = Tolerance::Distribution::Normal;
    const double g = drawTolerance(t, 3, k, 0);
    m2n += g * g;
    maxn = std::max(maxn, std::abs(g));
    t.distribution = Tolerance::Distribution::EndPoint;
    EXPECT_EQ(std::abs(drawTolerance(t, 3, k, 0)), 2.0);
  }
  EXPECT_NEAR(m2u / n, 4.0 / 3, 0.03);  // d^2 / 3
  // sigma = d / 2 truncated at 2 sigma: variance sigma^2 (1 - 2 * 2 phi(2) / (2 Phi(2) - 1)).
  const double phi2 = std::exp(-2.0) / std::sqrt(2 * M_PI), Phi2m = std::erf(2 / std::sqrt(2.0));
  EXPECT_NEAR(m2n / n, 1.0 * (1 - 4 * phi2 / Phi2m), 0.02);
  EXPECT_LE(maxn, 2.0);
}

TEST(LensTolerance, CompensatorMinimisesTheSpot) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  std::string text = toleranceJob("singlet.dat", 1, "uniform");
  const std::string from = "\"bfl\", \"compensator\": \"none\"";
  text.replace(text.find(from), from.size(), "\"rms_spot\", \"compensator\": \"back_focus\"");
  const DesignJob job = readDesignJob(dir.write("job.json", text));
  double dz = 0;
  const double best = toleranceCriterion(job, job.start, &dz);
  // The film the compensator chose is a minimum of the RMS spot.
  for (double e : {-0.05, 0.05}) {
    LensPrescription p = job.start;
    p.surfaces.back().thickness_mm += dz + e;
    EXPECT_GT(rmsSpot_mm(p, 0, job.wavelengths_nm[0], job.wavelengths_nm[0], job.rings), best);
  }
  // An as-built lens carries its compensated film distance and reproduces its criterion.
  const LensPrescription b = asBuiltLens(job, 3);
  DesignJob fixed = job;
  fixed.tolerance.back_focus_compensator = false;
  const ToleranceResult r = runTolerancing(job);
  EXPECT_NEAR(toleranceCriterion(fixed, b), r.builds[3], 1e-9);
}

TEST(LensTolerance, IrregularityHasTheStatedSagAndMovesTheParaxialFocus) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  const DesignJob start = readDesignJob(dir.write("start.json", singletJob("singlet.dat")));
  const LensSurface& s = start.start.surfaces[1];  // R 80 mm, semi-aperture 15 mm
  const double h = 15, c = 1 / 80.0, w = 3, a = w * 632.8e-6 / 4;
  LensSurface b = s;
  applyIrregularity(b, w, 632.8);
  auto sphere = [](double curv, double r) {
    return curv * r * r / (1 + std::sqrt(1 - curv * curv * r * r));
  };
  for (double t : {0.3, 0.7, 1.0}) {
    // Along x: the spherical half alone, exactly.
    const double x = t * h;
    EXPECT_NEAR(surfaceSag(b.radius_mm, b.shape, x, 0)->z - sphere(c, x), a * std::pow(t, 4),
                1e-13);
    // Along y: a sphere of curvature c + 2A/h^2 plus the spherical half; A (y/h)^2 + A (y/h)^4
    // to lowest order, within (3/4)(c h)^2 A (y/h)^4 and higher terms.
    const double y = t * h;
    const double dep = surfaceSag(b.radius_mm, b.shape, 0, y)->z - sphere(c, y);
    EXPECT_NEAR(dep, sphere(c + 2 * a / (h * h), y) - sphere(c, y) + a * std::pow(t, 4), 1e-13);
    EXPECT_NEAR(dep, a * (t * t + std::pow(t, 4)), 1.1 * 0.75 * (c * h) * (c * h) * a * std::pow(t, 4));
  }
  // A job: the BFL of the builds at +-delta is the independent paraxial trace's with the y
  // section's curvature moved by +-2A/h^2 (the paraxial focus in the y-z plane).
  std::string text = toleranceJob("singlet.dat", 4, "end_point");
  const std::string from = "{\"type\": \"thickness\", \"surface\": 1, \"delta\": 0.2";
  text.replace(text.find(from), from.size(), "{\"type\": \"irregularity\", \"surface\": 1, \"delta\": 3");
  text.replace(text.find("2000"), 4, "20");
  const DesignJob job = readDesignJob(dir.write("job.json", text));
  const ToleranceResult r = runTolerancing(job);
  ASSERT_EQ(r.sensitivity.size(), 3u);
  EXPECT_EQ(r.sensitivity[0].label, "irregularity surface 1 +-3 fringes");
  for (double sign : {1.0, -1.0}) {
    std::vector<Row> rows = rowsOf(job.start);
    rows[1].radius = 1 / (c + sign * 2 * a / (h * h));
    const double change = independentBfl(rows) - independentBfl(rowsOf(job.start));
    EXPECT_NEAR(sign > 0 ? r.sensitivity[0].plus : r.sensitivity[0].minus, change,
                1e-9 + 1e-6 * std::abs(change));
  }
  // The stop has no surface to be irregular: refused at the tolerance's line.
  std::string stop = text;
  stop.replace(stop.find("\"irregularity\", \"surface\": 1"), 28, "\"irregularity\", \"surface\": 0");
  try {
    readDesignJob(dir.write("stop.json", stop));
    ADD_FAILURE() << "an irregularity on the stop was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("stop.json:7:7: error: surface 0 is the stop"),
              std::string::npos)
        << e.what();
  }
}

TEST(LensTolerance, IndexToleranceOnANonDispersiveMediumMovesTheIndex) {
  // The singlet's glass is a bare index 1.5168 (no V_d). End-point index builds are n = 1.5168 +- 0.01
  // and must keep the medium non-dispersive; their BFL is the independent paraxial trace's.
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  std::string text = toleranceJob("singlet.dat", 4, "end_point");
  const std::string from = "{\"type\": \"thickness\", \"surface\": 1, \"delta\": 0.2";
  text.replace(text.find(from), from.size(), "{\"type\": \"index\", \"surface\": 1, \"delta\": 0.01");
  const DesignJob job = readDesignJob(dir.write("job.json", text));
  const ToleranceResult r = runTolerancing(job);
  ASSERT_FALSE(r.builds.empty());
  for (int k = 0; k < 8; ++k) {
    const LensPrescription b = asBuiltLens(job, k);
    const double n = b.surfaces[1].ior;
    EXPECT_NEAR(std::abs(n - 1.5168), 0.01, 1e-12);
    EXPECT_FALSE(b.surfaces[1].glass.v_d.has_value());
    std::vector<Row> rows = rowsOf(b);
    EXPECT_NEAR(r.builds[k], independentBfl(rows), 1e-9);
  }
  // An Abbe tolerance on the same medium is refused at its line.
  std::string abbe = toleranceJob("singlet.dat", 4, "uniform");
  abbe.replace(abbe.find(from), from.size(), "{\"type\": \"abbe\", \"surface\": 1, \"delta\": 2");
  try {
    readDesignJob(dir.write("abbe.json", abbe));
    ADD_FAILURE() << "an Abbe tolerance on a non-dispersive medium was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("abbe.json:7:7: error: surface 1: the medium after it has "
                                         "no dispersion"),
              std::string::npos)
        << e.what();
  }
}

// --- Errors ----------------------------------------------------------------------------------

TEST(LensDesign, JobErrorsNameTheLineAndValue) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  auto err = [&](const std::string& text) {
    try {
      readDesignJob(dir.write("bad.json", text));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string job = singletJob("singlet.dat");
  job.replace(job.find("\"efl\""), 5, "\"eff\"");
  EXPECT_NE(err(job).find("bad.json:10:5: error: unknown type \"eff\""), std::string::npos) << err(job);
  job = singletJob("singlet.dat");
  job.replace(job.find("\"surface\": 2}"), 13, "\"surface\": 7}");
  EXPECT_NE(err(job).find("bad.json:6:5: error: \"surface\" 7 is not a row"), std::string::npos) << err(job);
  std::string tol = toleranceJob("singlet.dat", 1, "uniform");
  tol.replace(tol.find("\"radius\", \"surface\": 2, \"delta\": 0.5"), 36,
              "\"irregularity\", \"surface\": 2, \"delta\": 500");
  EXPECT_NE(err(tol).find("bad.json:9:7: error: \"delta\" 500 fringes must be > 0 and at most 100"),
            std::string::npos)
      << err(tol);
  tol = toleranceJob("singlet.dat", 1, "uniform");
  tol.replace(tol.find("\"delta\": 0.2"), 12, "\"delta\": 5.0");
  EXPECT_NE(err(tol).find("bad.json:7:7: error: \"delta\" 5 must be below the thickness 4 mm"),
            std::string::npos)
      << err(tol);
  EXPECT_NE(err("{\"lens\": \"singlet.dat\",\n \"rings\": 0}").find("bad.json:2:2: error: \"rings\" 0"),
            std::string::npos);
  EXPECT_NE(err("{\"lens\": \"singlet.dat\",,}").find("bad.json:1:24: error: not valid JSON"),
            std::string::npos)
      << err("{\"lens\": \"singlet.dat\",,}");
}

TEST(LensDesignCli, OptimiseAndToleranceRun) {
  TempDir dir;
  dir.write("singlet.dat", kSinglet);
  const std::string job = dir.write("job.json", singletJob("singlet.dat"));
  const std::string out = (dir.path / "out.json").string();
  test::CliResult r = test::runLensim("lens optimise " + job + " -o " + out);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("iteration   1  merit"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dominant: "), std::string::npos);
  const LensPrescription p = readLensFile(out);
  EXPECT_NEAR(independentEfl(rowsOf(p)), 100, 1e-3);
  // A bad output name is refused before the run, nothing written.
  r = test::runLensim("lens optimise " + job + " -o " + (dir.path / "out.zmx").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_FALSE(fs::exists(dir.path / "out.zmx"));
  const std::string tj = dir.write("tol.json", toleranceJob("singlet.dat", 5, "normal"));
  r = test::runLensim("lens tolerance " + tj + " --builds-dir " + (dir.path / "b").string() +
                      " --write-builds 2");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("Monte Carlo 2000 builds (seed 5)"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(dir.path / "b" / "build-0001.json"));
  EXPECT_NO_THROW(readLensFile((dir.path / "b" / "build-0000.json").string()));
  // Decentred builds are written as .zmx, which cannot hold an irregular surface: refused at the
  // irregularity's line before the run, nothing written.
  std::string both = toleranceJob("singlet.dat", 5, "normal");
  const std::string from = "{\"type\": \"thickness\", \"surface\": 1, \"delta\": 0.2";
  both.replace(both.find(from), from.size(),
               "{\"type\": \"decentre\", \"axis\": \"y\", \"element\": 1, \"delta\": 0.1},\n"
               "      {\"type\": \"irregularity\", \"surface\": 1, \"delta\": 1");
  both.replace(both.find("\"bfl\""), 5, "\"rms_spot\"");
  r = test::runLensim("lens tolerance " + dir.write("both.json", both) + " --builds-dir " +
                      (dir.path / "c").string() + " --write-builds 2");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("both.json:8:7: error: --write-builds: builds with decentres or tilts"),
            std::string::npos)
      << r.out;
  EXPECT_FALSE(fs::exists(dir.path / "c" / "build-0000.zmx"));
}

}  // namespace
