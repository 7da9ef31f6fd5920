// Lens flare with absorbing glasses (issue 31, docs/flare.md): the ghost path's weight carries
// the glasses' internal transmittance over its real path lengths. Checked against an absorbing
// plate whose ghost is computed here: Fresnel's equations, N-SF66's index from its Sellmeier
// coefficients and its absorption from its IT rows, both read from the AGF file in this test,
// and the path lengths from the plate's geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "lensim/camera/realistic.h"
#include "test_paths.h"

using namespace lensim;

namespace {

const std::string kSchott = std::string(LENSIM_SOURCE_DIR) + "/data/glass/agf/schott.agf";

struct Row {
  double lambda_um, tau, thickness_mm;
};

/// One glass of an AGF file: its CD coefficients and IT rows, read line by line.
struct AgfGlass {
  std::vector<double> cd;
  std::vector<Row> it;
};
AgfGlass readAgf(const std::string& agf, const std::string& glass) {
  std::ifstream in(agf);
  std::string line;
  AgfGlass g;
  bool inside = false;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "NM") {
      std::string name;
      s >> name;
      inside = name == glass;
    } else if (inside && tag == "CD") {
      double c;
      while (s >> c) g.cd.push_back(c);
    } else if (inside && tag == "IT") {
      Row r{};
      if (s >> r.lambda_um >> r.tau >> r.thickness_mm && r.tau > 0 && r.tau <= 1 &&
          r.thickness_mm > 0)
        g.it.push_back(r);
    }
  }
  return g;
}

/// Zemax formula 2 (Sellmeier 1): n^2 - 1 = sum K_i l^2 / (l^2 - L_i), l in micrometres.
double sellmeier(const std::vector<double>& cd, double lambda_nm) {
  const double l2 = lambda_nm * lambda_nm * 1e-6;
  double n2 = 1;
  for (int i = 0; i < 3; ++i) n2 += cd[size_t(2 * i)] * l2 / (l2 - cd[size_t(2 * i + 1)]);
  return std::sqrt(n2);
}

/// The absorption coefficient (1/mm): -ln(tau)/d of the rows, linear in lambda between rows,
/// held beyond the end rows (docs/glass.md).
double alpha(const std::vector<Row>& rows, double lambda_nm) {
  const double l = lambda_nm / 1000;
  auto a = [](const Row& r) { return -std::log(r.tau) / r.thickness_mm; };
  if (l <= rows.front().lambda_um) return a(rows.front());
  if (l >= rows.back().lambda_um) return a(rows.back());
  for (size_t i = 1; i < rows.size(); ++i)
    if (rows[i].lambda_um >= l) {
      const double t = (l - rows[i - 1].lambda_um) / (rows[i].lambda_um - rows[i - 1].lambda_um);
      return (1 - t) * a(rows[i - 1]) + t * a(rows[i]);
    }
  return a(rows.back());
}

/// Unpolarised Fresnel reflectance from n1 into n2 at incidence theta (1 beyond the critical
/// angle).
double fresnel(double n1, double n2, double theta) {
  const double ci = std::cos(theta), si = std::sin(theta), st = n1 / n2 * si;
  if (st >= 1) return 1;
  const double ct = std::sqrt(1 - st * st);
  const double rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
  const double rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
  return 0.5 * (rs * rs + rp * rp);
}

std::string testFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_flare_absorption_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

/// An uncoated N-SF66 plate kThick_mm thick (front radius 200 m: lensim refuses afocal lenses;
/// the rear face flat), 2 mm of air, then a stop of radius kStop_mm, the film kFilm_mm behind.
constexpr double kThick_mm = 10, kStop_mm = 5, kFilm_mm = 20;
std::string writePlate() {
  const std::string path = testFile("sf66_plate.json");
  std::ofstream(path)
      << "{\"format\": \"lensim-lens\", \"name\": \"sf66 plate\", \"coating\": \"uncoated\", "
         "\"surfaces\": ["
      << "{\"radius_mm\": 2e5, \"thickness_mm\": " << kThick_mm
      << ", \"semi_aperture_mm\": 40, \"glass\": {\"name\": \"schott:N-SF66\"}},"
      << "{\"radius_mm\": 0, \"thickness_mm\": 2, \"semi_aperture_mm\": 40, \"ior\": 1},"
      << "{\"radius_mm\": 0, \"thickness_mm\": " << kFilm_mm
      << ", \"semi_aperture_mm\": " << kStop_mm << ", \"ior\": 1, \"stop\": true}]}\n";
  return path;
}

camera::RealisticSettings settings(bool flare, bool absorb) {
  camera::RealisticSettings s;
  s.lens_path = writePlate();
  s.setup.aperture_diameter_mm = 2 * kStop_mm;
  s.setup.film_distance_mm = kFilm_mm;
  s.film_diagonal_mm = 3.5;
  s.x_resolution = s.y_resolution = 16;
  s.flare = flare;
  s.glass_absorption = absorb;
  return s;
}

}  // namespace

// Each ghost ray of the plate (its one ghost: reflected at the rear face, then at the front face
// from inside) carries, at its hero wavelength lambda,
//   cos^4(theta) pi a^2 / D^2 x (1 - R)^2 R^2 x exp(-alpha(lambda) 3 t / cos(theta_g))
// (the film irradiance measure of the stop's disc, radius a at D from the film, where its
// directions are drawn; Fresnel at the two passes and the two reflections, all at the same
// angle in a plate; three passes through the glass at theta_g = asin(sin(theta) / n(lambda))).
// The direct ray's weight with flare over without is (1 - R)^2. Every wavelength of the visible
// is drawn; N-SF66 absorbs 10-70% of the three passes below 420 nm.
TEST(FlareAbsorption, GhostRayIsFresnelTimesInternalTransmittance) {
  const AgfGlass sf66 = readAgf(kSchott, "N-SF66");
  ASSERT_GE(sf66.cd.size(), 6u);
  ASSERT_GT(sf66.it.size(), 10u);
  ASSERT_NEAR(sellmeier(sf66.cd, 587.5618), 1.92286, 2e-5);  // the catalogue's n_d
  const camera::RealisticCamera on(settings(true, true)), plain(settings(true, false)),
      off(settings(false, true));
  ASSERT_EQ(on.ghostChoices().size(), 1u);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  int ghosts = 0, directs = 0;
  double min_t = 1;
  for (int k = 0; k < 2000; ++k) {
    camera::CameraSample s;
    s.film_raster = {16 * u(rng), 16 * u(rng)};
    s.lens = {u(rng), u(rng)};
    s.ghost_u = {u(rng), u(rng), u(rng)};
    const double lambda = 380 + 320 * u(rng);
    s.lambda_nm = {lambda, 0, 0, 0};
    const double n = sellmeier(sf66.cd, lambda);
    const auto g = on.generateGhostRay(s);
    const auto gp = plain.generateGhostRay(s);
    ASSERT_EQ(g.has_value(), gp.has_value());
    if (g) {
      ASSERT_TRUE(g->hero_only);
      const double c = std::abs(g->direction.z);  // camera space = world: the axis is z
      const double theta = std::acos(std::min(1.0, c));
      const double r = fresnel(1, n, theta);
      const double cg = std::sqrt(1 - std::pow(std::sin(theta) / n, 2));
      const double t = std::exp(-alpha(sf66.it, lambda) * 3 * kThick_mm / cg);
      const double geometric = std::pow(c, 4) * std::numbers::pi * kStop_mm * kStop_mm /
                               (kFilm_mm * kFilm_mm);
      const double expected = geometric * (1 - r) * (1 - r) * r * r * t;
      ASSERT_NEAR(g->weight, expected, 1e-3 * expected) << lambda << " nm, theta " << theta;
      // The optical depth to 1e-4 (the front face's sag changes a path by up to 2.5e-5).
      ASSERT_NEAR(std::log(g->weight / gp->weight), std::log(t), 1e-4 * std::abs(std::log(t)))
          << lambda << " nm";
      min_t = std::min(min_t, t);
      ++ghosts;
    }
    const auto d = on.generateRay(s), d0 = off.generateRay(s);
    ASSERT_EQ(d.has_value(), d0.has_value());
    if (d) {
      ASSERT_TRUE(d->hero_only);
      const double theta = std::acos(std::min(1.0, std::abs(d->direction.z)));
      const double r = fresnel(1, n, theta);
      ASSERT_NEAR(d->weight / d0->weight, (1 - r) * (1 - r), 2e-5) << lambda << " nm";
      ++directs;
    }
  }
  EXPECT_GT(ghosts, 1000);
  EXPECT_GT(directs, 1000);
  EXPECT_LT(min_t, 0.7);  // the test reached wavelengths where the glass absorbs
}
