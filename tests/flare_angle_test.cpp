// Off-axis ghost intensities on the workbench (issue 31, docs/flare.md "Off-axis intensities"):
// `lens ghosts --angle` weighs each traced ghost ray by the coatings' reflectance and
// transmittance at that ray's own angles of incidence. Checked against a thin-film computation
// written here (the Airy sum of one quarter-wave MgF2 layer for s and p with tilted admittances,
// and Fresnel's equations for the bare cemented interfaces), on the same rays: the geometry is
// the lens's tracer (tested elsewhere), the reflectances are the test's own.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <vector>

#include "cli_run.h"
#include "lensim/optics/coating/ghost_trace.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/prescription.h"
#include "test_paths.h"

using namespace lensim;
using namespace lensim::optics;
using nlohmann::json;
using cd = std::complex<double>;

namespace {

/// Unpolarised reflectance of an interface from index n0 (at incidence cos0) into ns, bare or
/// with one layer of index n1 and physical thickness d1_nm on it (the layer on the side of the
/// higher index: light from that side meets it first), at wavelength lambda_nm. The Airy sum
/// r = (r01 + r12 e^{-2 i delta}) / (1 + r01 r12 e^{-2 i delta}) with the tilted admittances
/// n cos (s) and n / cos (p) and complex cosines (total internal reflection: |r| = 1).
double reflectance(double n0, double ns, double cos0, double n1, double d1_nm, double lambda_nm) {
  const double s0 = std::sqrt(std::max(0.0, 1 - cos0 * cos0));
  auto cosIn = [&](double n) { return std::sqrt(cd(1 - (n0 * s0 / n) * (n0 * s0 / n), 0)); };
  const cd c0 = cos0, c1 = cosIn(n1), cs = cosIn(ns);
  double r_sum = 0;
  for (int pol = 0; pol < 2; ++pol) {
    auto eta = [&](double n, cd c) { return pol == 0 ? n * c : n / c; };
    const cd e0 = eta(n0, c0), e1 = eta(n1, c1), es = eta(ns, cs);
    cd r;
    if (d1_nm <= 0) {
      r = (e0 - es) / (e0 + es);
    } else {
      const cd r01 = (e0 - e1) / (e0 + e1), r12 = (e1 - es) / (e1 + es);
      const cd ph = std::exp(cd(0, -2) * (2 * std::numbers::pi * n1 * d1_nm / lambda_nm) * c1);
      r = (r01 + r12 * ph) / (1.0 + r01 * r12 * ph);
    }
    r_sum += std::norm(r);
  }
  return 0.5 * r_sum;
}

/// The "single" coating (docs/flare.md): MgF2, n 1.38, a quarter wave at 550 nm, on air-glass
/// surfaces; cemented surfaces bare. R of surface with media na (air side...) from `from` to `to`.
double surfaceR(double from, double to, double cos_i, double lambda_nm) {
  const bool air_glass = (from == 1) != (to == 1);
  return reflectance(from, to, cos_i, 1.38, air_glass ? 550 / (4 * 1.38) : 0, lambda_nm);
}

/// The film energy of traceSpot's grid along a path (the ghost (first, second), or the direct
/// path when first < 0), per wavelength, with the reflectances above at the traced angles.
std::vector<double> energy(const LensSystem& lens, int first, int second, double angle, int grid,
                           const std::vector<double>& wl) {
  const bool ghost = first >= 0;
  const std::vector<Interface> path =
      ghost ? ghostPathInterfaces(lens, first, second) : lens.interfaces();
  const LensTracer<double> tracer(path);
  const auto& s = lens.interfaces();
  const double r = 1.25 * s[0].semi_aperture_mm, back = 2 * r + 1;
  const Vec3T<double> dir{std::sin(angle), 0.0, std::cos(angle)};
  std::vector<double> e(wl.size(), 0.0);
  for (int i = 0; i < grid; ++i)
    for (int j = 0; j < grid; ++j) {
      const double gx = r * (-1 + 2 * (i + 0.5) / grid), gy = r * (-1 + 2 * (j + 0.5) / grid);
      if (gx * gx + gy * gy > r * r) continue;
      std::vector<Vec3T<double>> pts;
      const TraceResult res = tracer.traceFromScene(
          Ray{{gx - back / dir.z * dir.x, gy, s[0].z_mm - back}, dir}, {}, &pts);
      if (!res.ok() || !(res.ray.direction.z > 0)) continue;
      std::vector<double> f(wl.size(), 1.0);
      for (size_t k = 0; k < path.size(); ++k) {
        // The lens surface and the side the light comes from, counted here from the path's
        // order: surfaces 0..first forward, then back to `second`, then forward again.
        int surf = int(k);
        bool from_film = false;
        if (ghost && int(k) > first) {
          const int back_end = 2 * first - second;
          from_film = int(k) <= back_end;
          surf = from_film ? 2 * first - int(k) : int(k) - 2 * (first - second);
        }
        const bool reflects = ghost && (int(k) == first || int(k) == 2 * first - second);
        const Interface& sf = s[size_t(surf)];
        if (sf.ior_before == sf.ior_after) continue;
        const double from = from_film ? sf.ior_after : sf.ior_before;
        const double to = from_film ? sf.ior_before : sf.ior_after;
        // The incidence angle from the surface normal at the hit point (sphere centre on the
        // axis at z_vertex + radius).
        const Vec3T<double>& p = pts[k + 1];
        const Vec3T<double> in = normalize(pts[k + 1] - pts[k]);
        Vec3T<double> nrm{0, 0, 1};
        if (sf.radius_mm != 0) nrm = normalize(p - Vec3T<double>{0, 0, sf.z_mm + sf.radius_mm});
        const double cos_i = std::min(1.0, std::abs(dot(in, nrm)));
        for (size_t w = 0; w < wl.size(); ++w) {
          const double R = surfaceR(from, to, cos_i, wl[w]);
          f[w] *= reflects ? R : 1 - R;
        }
      }
      for (size_t w = 0; w < wl.size(); ++w) e[w] += f[w];
    }
  return e;
}

}  // namespace

// The double Gauss (12 mm stop) with the single-layer coating and a light 10 degrees off axis:
// every listed ghost's traced intensity per wavelength equals the test's own sum over the same
// rays (1e-9), the ranking follows those intensities, and the angles matter (the intensity at the
// traced angles differs from the same rays weighed at normal incidence).
TEST(FlareAngle, TracedGhostIntensitiesUseTheCoatingsAtTheRaysAngles) {
  const std::string lens_file = test::lensPath("dgauss.50mm.dat");
  const int grid = 24;
  const test::CliResult r = test::runLensim(
      "lens ghosts " + lens_file +
      " --aperture-diameter 12 --coating single --angle 10 --grid 24 --wavelengths 450,550,650 "
      "--top 12 --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = json::parse(r.out);
  LensSetup setup;
  setup.aperture_diameter_mm = 12;
  const FocusedLens fl = focusLens(readLensFile(lens_file), setup);
  const LensSystem& lens = *fl.lens;
  const std::vector<double> wl = {450, 550, 650};
  const double angle = 10 * std::numbers::pi / 180;
  const std::vector<double> direct = energy(lens, -1, -1, angle, grid, wl);
  int checked = 0;
  double most_angle_effect = 0;
  for (const json& g : j["ghosts"]) {
    if (g["spot"].is_null()) continue;
    const int first = g["first_reflection_surface"], second = g["second_reflection_surface"];
    const std::vector<double> e = energy(lens, first, second, angle, grid, wl);
    const auto got = g["spot"]["relative_intensity_per_wavelength"].get<std::vector<double>>();
    ASSERT_EQ(got.size(), wl.size());
    double mean = 0;
    for (size_t w = 0; w < wl.size(); ++w) {
      const double want = e[w] / direct[w];
      EXPECT_NEAR(got[w], want, 1e-9 * want + 1e-15) << first << "," << second << " " << wl[w];
      mean += want / 3;
    }
    EXPECT_NEAR(g["spot"]["relative_intensity"].get<double>(), mean, 1e-9 * mean + 1e-15);
    ++checked;
    // At normal incidence at every surface (the quarter-wave closed form's setting): the same
    // rays' weights with cos = 1.
    if (mean > 0) {
      double normal = 0;
      const std::vector<Interface>& s = lens.interfaces();
      for (size_t w = 0; w < wl.size(); ++w) {
        double f = 1;
        for (int k = 0; k < lens.surfaceCount(); ++k) {
          const Interface& sf = s[size_t(k)];
          if (sf.ior_before == sf.ior_after) continue;
          const double rf = surfaceR(sf.ior_before, sf.ior_after, 1, wl[w]);
          const double rb = surfaceR(sf.ior_after, sf.ior_before, 1, wl[w]);
          if (k == first)
            f *= rf * (1 - rf);  // reflects, and is passed after the reflections
          else if (k == second)
            f *= (1 - rf) * rb;  // passed, then reflects from the film side
          else if (k > second && k < first)
            f *= (1 - rf) * (1 - rf) * (1 - rb);
          else
            f *= 1 - rf;
        }
        double direct_f = 1;
        for (int k = 0; k < lens.surfaceCount(); ++k) {
          const Interface& sf = s[size_t(k)];
          if (sf.ior_before != sf.ior_after)
            direct_f *= 1 - surfaceR(sf.ior_before, sf.ior_after, 1, wl[w]);
        }
        // The same arriving rays (their count ratio) at normal-incidence weights.
        normal += f / direct_f / 3;
      }
      const int arrived = g["spot"]["rays_arrived"],
                direct_arrived = j["direct_spot"]["rays_arrived"];
      normal *= double(arrived) / direct_arrived;
      most_angle_effect = std::max(most_angle_effect, std::abs(mean / normal - 1));
    }
  }
  std::printf(
      "%d ghosts checked; largest change of a ghost's intensity from normal incidence to "
      "the traced angles: %.1f %%\n",
      checked, 100 * most_angle_effect);
  EXPECT_GE(checked, 10);
  EXPECT_GT(most_angle_effect, 0.05);
  // The ranking at the angle: descending traced intensities, the brightest first.
  const json& rank = j["angle_ranking"];
  ASSERT_EQ(rank.size(), j["ghosts"].size());
  for (size_t i = 1; i < rank.size(); ++i)
    EXPECT_GE(rank[i - 1]["relative_intensity"].get<double>(),
              rank[i]["relative_intensity"].get<double>());
  double brightest = 0;
  for (const json& g : j["ghosts"])
    if (!g["spot"].is_null())
      brightest = std::max(brightest, g["spot"]["relative_intensity"].get<double>());
  EXPECT_GE(rank[0]["relative_intensity"].get<double>(), brightest);
}

// `lens plot ghosts --angle` plots the intensities `lens ghosts --angle` ranks (the same traced
// rays, default grid), brightest first; --angle with another plot is refused.
TEST(FlareAngle, PlotGhostsAtAnAngleShowsTheTracedRanking) {
  const std::string lens_file = test::lensPath("dgauss.50mm.dat");
  const std::string svg =
      (std::filesystem::temp_directory_path() / "lensim_flare_angle_plot.svg").string();
  const test::CliResult plot =
      test::runLensim("--quiet lens plot ghosts " + lens_file +
                      " --aperture-diameter 12 --angle 10 --json -o " + svg);
  ASSERT_EQ(plot.status, 0) << plot.out;
  const test::CliResult ghosts = test::runLensim(
      "lens ghosts " + lens_file + " --aperture-diameter 12 --angle 10 --top 20 --json");
  ASSERT_EQ(ghosts.status, 0) << ghosts.out;
  const json p = json::parse(plot.out);
  const json g = json::parse(ghosts.out);
  EXPECT_EQ(p["angle_deg"].get<double>(), 10.0);
  const json& bars = p["bars"];
  ASSERT_GE(bars.size(), 10u);
  for (size_t i = 0; i < bars.size(); ++i) {
    const json& r = g["angle_ranking"][i];
    EXPECT_EQ(bars[i]["first_reflection_surface"], r["first_reflection_surface"]) << i;
    EXPECT_EQ(bars[i]["second_reflection_surface"], r["second_reflection_surface"]) << i;
    EXPECT_DOUBLE_EQ(bars[i]["relative_intensity"].get<double>(),
                     r["relative_intensity"].get<double>())
        << i;
  }
  const test::CliResult bad =
      test::runLensim("lens plot spot " + lens_file + " --angle 10 -o " + svg);
  EXPECT_EQ(bad.status, 1) << bad.out;
  EXPECT_NE(bad.out.find("--angle applies to 'ghosts'"), std::string::npos) << bad.out;
}
