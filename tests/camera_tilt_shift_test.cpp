// The realistic camera with a tilted and shifted lens ("lenstilt", "lensshift"; docs/zoom.md):
// the film irradiance against an independent integration over directions, every camera ray
// landing back on its own film point through the lens, and the refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "lensim/camera/realistic.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/render/renderer.h"
#include "lensim/util/error.h"
#include "scene_test_util.h"
#include "test_paths.h"

using namespace lensim;

namespace {

constexpr double kDeg = M_PI / 180;

camera::RealisticSettings settings(Vec2 tilt_deg, Vec2 shift_mm) {
  camera::RealisticSettings s;
  s.lens_path = lensim::test::lensPath("dgauss.50mm.dat");
  s.setup.aperture_diameter_mm = 12;
  s.setup.focus_distance_m = 3;
  s.x_resolution = 36;
  s.y_resolution = 24;
  s.film_diagonal_mm = 35;
  s.tilt_shift.tilt_deg = tilt_deg;
  s.tilt_shift.shift_mm = shift_mm;
  return s;
}

// Film frame to lens space written out here (not optics/tilt_shift.cpp's): R = Ry(b) Rx(a),
// p_lens = R^T (p - s) + z_film.
Vec3 rotXT(const Vec3& v, double a) {  // Rx(a)^T v
  return {v.x, std::cos(a) * v.y + std::sin(a) * v.z, -std::sin(a) * v.y + std::cos(a) * v.z};
}
Vec3 rotYT(const Vec3& v, double b) {  // Ry(b)^T v
  return {std::cos(b) * v.x - std::sin(b) * v.z, v.y, std::sin(b) * v.x + std::cos(b) * v.z};
}
Vec3 lensFromFilm(Vec2 film, Vec2 tilt_deg, Vec2 shift, double z_film) {
  Vec3 p =
      rotXT(rotYT({film.x - shift.x, film.y - shift.y, 0}, tilt_deg.y * kDeg), tilt_deg.x * kDeg);
  p.z += z_film;
  return p;
}

// E / L at a lens-space film point with unit normal n: the integral of cos(theta_film) over the
// directions whose rays get through the lens, as a midpoint sum over a plane 30 mm toward the
// lens (dw = cos_plane / r^2 dA): a coarse grid finds the region (its border must carry
// nothing), a fine one (0.01-0.02 mm cells) over it integrates.
double irradianceByQuadrature(const optics::LensSystem& lens, const Vec3& x, const Vec3& n) {
  const double zp = x.z - 30;
  auto grid = [&](Vec2 lo, Vec2 hi, int m, Vec2* box_lo, Vec2* box_hi, double* border) {
    const double hx = (hi.x - lo.x) / m, hy = (hi.y - lo.y) / m;
    double sum = 0;
    for (int i = 0; i < m; ++i)
      for (int k = 0; k < m; ++k) {
        const Vec3 q{lo.x + (i + 0.5) * hx, lo.y + (k + 0.5) * hy, zp};
        const Vec3 to = q - x;
        const double r2 = dot(to, to);
        const Vec3 d = to / std::sqrt(r2);
        const double cf = -dot(d, n);
        if (!(cf > 0)) continue;
        if (!lens.tracer().traceFromFilm(optics::Ray{x, d}).ok()) continue;
        const double c = cf * (-d.z) / r2 * hx * hy;
        sum += c;
        if (border && (i == 0 || k == 0 || i == m - 1 || k == m - 1)) *border += c;
        if (box_lo) {
          box_lo->x = std::min(box_lo->x, q.x - hx), box_lo->y = std::min(box_lo->y, q.y - hy);
          box_hi->x = std::max(box_hi->x, q.x + hx), box_hi->y = std::max(box_hi->y, q.y + hy);
        }
      }
    return sum;
  };
  Vec2 lo{1e30, 1e30}, hi{-1e30, -1e30};
  double border = 0;
  grid({x.x - 45, x.y - 45}, {x.x + 45, x.y + 45}, 180, &lo, &hi, &border);
  EXPECT_EQ(border, 0.0);
  return grid(lo, hi, 700, nullptr, nullptr, nullptr);
}

}  // namespace

// The film irradiance of a uniform radiance field (the camera's mean ray weight at a film point)
// through a tilted and a shifted lens against the quadrature above, per block of samples a
// z-test (|z| < 4.5 for every block mean and the total; the total's standard error < 1%).
TEST(TiltShiftCamera, FlatFieldIrradianceMatchesAnIndependentIntegration) {
  struct Case {
    Vec2 tilt, shift;
  };
  for (const Case& c : {Case{{0, 0}, {4, -3}}, Case{{-6, 3}, {0, 0}}, Case{{5, 0}, {-2, 5}}}) {
    const camera::RealisticCamera cam(settings(c.tilt, c.shift));
    const optics::LensSystem& lens = *cam.lens().lens;
    ASSERT_TRUE(cam.placement().has_value());
    // Film normal: R^T z by the same hand-written rotations.
    const Vec3 n = rotXT(rotYT({0, 0, 1}, c.tilt.y * kDeg), c.tilt.x * kDeg);
    for (const Vec2 raster : {Vec2{18, 12}, Vec2{2, 3}, Vec2{33, 20}}) {
      const Vec2 film = cam.filmPoint(raster);
      const Vec3 x = lensFromFilm(film, c.tilt, c.shift, lens.filmZ_mm());
      const double ref = irradianceByQuadrature(lens, x, n);
      std::mt19937_64 rng(7);
      std::uniform_real_distribution<double> u01(0, 1);
      const int blocks = 20, per = 3000;
      std::vector<double> means;
      double total = 0, total2 = 0;
      for (int b = 0; b < blocks; ++b) {
        double s = 0;
        for (int i = 0; i < per; ++i) {
          camera::CameraSample cs;
          cs.film_raster = raster;
          cs.lens = {u01(rng), u01(rng)};
          const double w = [&] {
            const std::optional<camera::CameraRay> r = cam.generateRay(cs);
            return r ? r->weight : 0.0;
          }();
          s += w;
          total += w;
          total2 += w * w;
        }
        means.push_back(s / per);
      }
      const double nn = double(blocks) * per, mean = total / nn;
      const double se_one = std::sqrt((total2 / nn - mean * mean));
      const double se_block = se_one / std::sqrt(double(per)), se = se_one / std::sqrt(nn);
      std::printf(
          "tilt (%g, %g) shift (%g, %g) raster (%g, %g): E/L %.6f, quadrature %.6f, "
          "z %+.2f, rel. se %.4f\n",
          c.tilt.x, c.tilt.y, c.shift.x, c.shift.y, raster.x, raster.y, mean, ref,
          (mean - ref) / se, se / ref);
      for (double m : means) EXPECT_LT(std::abs(m - ref) / se_block, 4.5) << raster.x;
      EXPECT_LT(std::abs(mean - ref) / se, 4.5) << raster.x << ": " << mean << " vs " << ref;
      EXPECT_LT(se, 0.01 * ref);  // the test has the power to see a 4.5% error
      EXPECT_GT(ref, 0.005);
    }
  }
}

// Every camera ray, taken back into lens space by the shift and tilt written out here and
// traced back through the lens (double tracer), meets the film plane at its own film point
// (within the float tracer's 1e-4 mm): a scene point's image moves with the film placement
// exactly, e.g. by the shift for a shift.
TEST(TiltShiftCamera, RaysTraceBackToTheirFilmPoints) {
  for (const auto& [tilt, shift] :
       {std::pair{Vec2{0, 0}, Vec2{6, -4}}, std::pair{Vec2{-7, 2}, Vec2{1, 2}}}) {
    const camera::RealisticCamera cam(settings(tilt, shift));
    const optics::LensSystem& lens = *cam.lens().lens;
    const double zf = lens.filmZ_mm();
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u01(0, 1);
    int got = 0;
    for (int i = 0; i < 400; ++i) {
      camera::CameraSample cs;
      cs.film_raster = {36 * u01(rng), 24 * u01(rng)};
      cs.lens = {u01(rng), u01(rng)};
      const std::optional<camera::CameraRay> r = cam.generateRay(cs);
      if (!r) continue;
      ++got;
      // World = camera space here (no transform); camera units are metres, z toward the scene.
      const Vec3 o_f{r->origin.x * 1000, r->origin.y * 1000, -r->origin.z * 1000};
      const Vec3 d_f{r->direction.x, r->direction.y, -r->direction.z};
      const Vec3 o = lensFromFilm({o_f.x, o_f.y}, tilt, shift, zf) +
                     rotXT(rotYT({0, 0, o_f.z}, tilt.y * kDeg), tilt.x * kDeg);
      const Vec3 d = rotXT(rotYT(d_f, tilt.y * kDeg), tilt.x * kDeg);
      // From 20 mm out along the ray (its origin lies on the front surface).
      const optics::TraceResult b =
          lens.tracer().traceFromScene(optics::Ray{o + d * 20.0, -1.0 * d});
      ASSERT_TRUE(b.ok());
      const Vec2 film = cam.filmPoint(cs.film_raster);
      const Vec3 x = lensFromFilm(film, tilt, shift, zf);
      // The back-traced ray passes through x: its distance from the line.
      const Vec3 e = x - b.ray.origin;
      const Vec3 perp = e - b.ray.direction * dot(e, b.ray.direction);
      EXPECT_LT(length(perp), 2e-4) << i;
    }
    EXPECT_GT(got, 100);
  }
}

TEST(TiltShiftCamera, RefusalsNameTheParameterOrTheCamera) {
  const std::string lens = lensim::test::lensPath("dgauss.50mm.dat");
  auto errorOf = [&](const std::string& params, const std::string& integrator,
                     const std::string& film = "") {
    scene::Scene s = lensim::testutil::buildText(
        "Camera \"realistic\" \"string lensfile\" \"" + lens + "\" " + params +
        "\nFilm \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16 " + film + "\n" +
        integrator + "\nWorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n");
    std::string message = lensim::testutil::errorsOf(s);
    if (!message.empty()) return message;
    try {
      render::RenderOptions o;
      o.spp = 1;
      render::render(s, o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  for (const char* p :
       {"\"float lenstilt\" [50 0]", "\"float lenstilt\" [3]", "\"float lensshift\" [1e9 0]"}) {
    const std::string m = errorOf(p, "");
    EXPECT_EQ(m.rfind("test.pbrt:1:", 0), 0u) << p << ": " << m;
  }
  // lighttracer renders a tilted and shifted lens (camera_tilt_importance_test.cpp).
  EXPECT_EQ(
      errorOf("\"float lensshift\" [2 0] \"float lenstilt\" [3 0]", "Integrator \"lighttracer\""),
      "");
  // A tilt that drives the (large) film's corner into the lens.
  {
    const std::string m = errorOf("\"float lenstilt\" [0 40]", "", "\"float diagonal\" [200]");
    EXPECT_EQ(m.rfind("test.pbrt:1:", 0), 0u) << m;
    EXPECT_NE(m.find("into the lens"), std::string::npos) << m;
  }
}

namespace {

// Squared horizontal contrast per image row (mean square of I(x+1) - I(x) over mean I squared
// across the middle half of the columns, green channel) of a render of a long checkerboard
// table, the camera 0.4 m above it pitched 12 degrees down, the double Gauss at f/2 (12.5 cm
// checks; the table is wider than the frame, so the middle columns see only checks); rows
// without the table (black) are left out. The mean square is that of the product of two
// renders' differences (seeds 5 and 6), whose noise is independent: noise does not count as
// contrast (a noisier sampler scored sharper); a row's value can come out negative. Returns the
// table's rows, top (far) to bottom (near).
std::vector<double> tableRowContrast(double tilt_x_deg, double shift_y_mm) {
  const std::string lens = lensim::test::lensPath("dgauss.50mm.dat");
  const std::string text =
      "LookAt 0 0.4 0   0 " + std::to_string(0.4 - std::tan(12 * kDeg)) + " 1   0 1 0\n" +
      "Camera \"realistic\" \"string lensfile\" \"" + lens +
      "\" \"float aperturediameter\" 17 \"float focusdistance\" 1.28 \"float lenstilt\" [" +
      std::to_string(tilt_x_deg) + " 0] \"float lensshift\" [0 " + std::to_string(shift_y_mm) +
      "]\n" +
      "Film \"rgb\" \"integer xresolution\" 96 \"integer yresolution\" 64 "
      "\"float diagonal\" 43.3\nSampler \"independent\" \"integer pixelsamples\" 128\n"
      "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
      "Integrator \"path\" \"integer maxdepth\" 1\nWorldBegin\n"
      "LightSource \"distant\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0] \"rgb L\" [3 3 3]\n"
      "Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 80 \"float vscale\" 64 "
      "\"rgb tex1\" [0.8 0.8 0.8] \"rgb tex2\" [0.05 0.05 0.05]\n"
      "Material \"diffuse\" \"texture reflectance\" \"c\"\n"
      "Shape \"trianglemesh\" \"point3 P\" [-6 0 0  6 0 0  6 0 8  -6 0 8] "
      "\"integer indices\" [0 1 2 0 2 3] \"point2 uv\" [0 0 1 0 1 1 0 1]\n";
  const scene::Scene s = lensim::testutil::buildText(text);
  render::RenderOptions o;
  o.seed = 5;
  const io::Image a = render::render(s, o).image;
  o.seed = 6;
  const io::Image b = render::render(s, o).image;
  std::vector<double> rows;
  for (int y = 0; y < a.height; ++y) {
    double sum = 0, diff2 = 0;
    int n = 0;
    for (int x = a.width / 4; x < 3 * a.width / 4; ++x, ++n) {
      sum += a.at(x, y, 1) + b.at(x, y, 1);
      diff2 += (a.at(x + 1, y, 1) - a.at(x, y, 1)) * (b.at(x + 1, y, 1) - b.at(x, y, 1));
    }
    const double mean = sum / (2 * n);
    rows.push_back(mean > 0.02 ? diff2 / n / (mean * mean) : 0.0);
  }
  return rows;
}

double meanOf(const std::vector<double>& v, size_t from, size_t to) {
  double s = 0;
  for (size_t i = from; i < to; ++i) s += v[i];
  return s / double(to - from);
}

}  // namespace

// The hinge rule by hand: with the lens tilted down by asin(f cos(pitch) / height) the hinge line
// lies on the table and the plane of focus along it, so the far end of the table stays sharp;
// untilted, or tilted the other way, the far rows blur at f/2 (their row
// contrast, the same rows of the same framing, below 1/1.4 of the tilted render's; measured
// 0.090 tilted, 0.006 level, 0.008 the other way; 0.102, 0.006, 0.022 with the disc sampler).
TEST(TiltShiftCamera, TiltedRenderIsSharpAlongTheTable) {
  optics::LensSetup setup;
  setup.focus_distance_m = 1.28;
  const optics::FocusedLens fl =
      optics::focusLens(optics::readLensFile(lensim::test::lensPath("dgauss.50mm.dat")), setup);
  const double f = fl.paraxial.effective_focal_length_mm;
  const double tilt = std::asin(f * std::cos(12 * kDeg) / 400) / kDeg;  // 7.0 deg
  // The tilt turns the lens about the film's axial point, which moves the rear nodal point
  // sideways by v' sin(tilt); a shift of -v' sin(tilt) puts it back, so that all three renders
  // frame the table alike (to a pixel) and their rows compare.
  const double v = fl.lens->filmZ_mm() - fl.paraxial.nodal_point_back_z_mm;
  const double back = v * std::sin(tilt * kDeg);
  const std::vector<double> tilted = tableRowContrast(-tilt, back), level = tableRowContrast(0, 0),
                            wrong = tableRowContrast(tilt, -back);
  ASSERT_GT(tilted.size(), 20u);
  if (getenv("LENSIM_TEST_VERBOSE"))
    for (size_t i = 0; i < tilted.size(); ++i)
      std::printf("row %zu: %.3f %.3f %.3f\n", i, tilted[i], i < level.size() ? level[i] : 0.0,
                  i < wrong.size() ? wrong[i] : 0.0);
  ASSERT_EQ(level.size(), tilted.size());
  // The table's rows in all three (the far end, row 0 side, is where it meets the black).
  size_t top = 0;
  while (top < tilted.size() && (tilted[top] == 0 || level[top] == 0 || wrong[top] == 0)) ++top;
  const size_t rows = tilted.size() - top, k = rows / 5;
  ASSERT_GT(rows, 30u);
  // The rms contrast of the far and near fifths of the rows.
  const auto rms = [](const std::vector<double>& v, size_t from, size_t to) {
    return std::sqrt(std::max(0.0, meanOf(v, from, to)));
  };
  const double far_tilted = rms(tilted, top, top + k),
               near_tilted = rms(tilted, top + 4 * k, tilted.size());
  const double far_level = rms(level, top, top + k),
               near_level = rms(level, top + 4 * k, level.size());
  const double far_wrong = rms(wrong, top, top + k),
               near_wrong = rms(wrong, top + 4 * k, wrong.size());
  std::printf(
      "row contrast far / near: tilted %.3f / %.3f, level %.3f / %.3f, tilted the other "
      "way %.3f / %.3f\n",
      far_tilted, near_tilted, far_level, near_level, far_wrong, near_wrong);
  // Far rows only: the near rows of the other two renders sit far off the axis, where vignetting
  // raises the relative noise that this contrast also counts.
  EXPECT_GT(far_tilted, 1.4 * far_level);
  EXPECT_GT(far_tilted, 1.4 * far_wrong);
}
