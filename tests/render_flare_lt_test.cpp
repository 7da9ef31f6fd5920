// Lens flare in the light tracer and bdpt (issue 31; docs/flare.md, "Flare in the light tracer
// and bdpt"): their image and ghost layer against the path tracer's (per-block z-tests, the
// standard errors from the pixels' scatter) and against Fresnel's equations integrated here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "lensim/io/image.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "test_paths.h"

using namespace lensim;

namespace {

std::string testFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_render_flare_lt_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

/// Unpolarised Fresnel reflectance from index n1 into n2 at incidence angle theta.
double fresnel(double n1, double n2, double theta) {
  const double ci = std::cos(theta), si = std::sin(theta), st = n1 / n2 * si;
  if (st >= 1) return 1;
  const double ct = std::sqrt(1 - st * st);
  const double rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
  const double rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
  return 0.5 * (rs * rs + rp * rp);
}

/// An uncoated plate (index n, 5 mm; a 200 m front radius: lensim refuses afocal lenses), a stop
/// of radius a 2 mm behind it and the film `film_mm` behind the stop. Its clear semi-aperture of
/// 12 mm never clips a ray (or a ghost ray) that reaches the 3.5 mm film through the stop.
std::string writePlate(double n, double a, double film_mm) {
  const std::string path = testFile("plate.json");
  std::ofstream f(path);
  f << "{\"format\": \"lensim-lens\", \"name\": \"plate\", \"coating\": \"uncoated\", "
       "\"surfaces\": ["
    << "{\"radius_mm\": 2e5, \"thickness_mm\": 5, \"semi_aperture_mm\": 12, \"ior\": " << n << "},"
    << "{\"radius_mm\": 0, \"thickness_mm\": 2, \"semi_aperture_mm\": 12, \"ior\": 1},"
    << "{\"radius_mm\": 0, \"thickness_mm\": " << film_mm << ", \"semi_aperture_mm\": " << a
    << ", \"ior\": 1, \"stop\": true}]}\n";
  return path;
}

/// Per block of b x b pixels: the mean of channels c0..c0+2 over its pixels and the standard
/// error of that mean from the pixels' scatter (which also holds the small variation of the
/// expected value across a block, so the error is, if anything, overestimated).
struct Block {
  double mean = 0, se = 0;
};
std::vector<Block> blocks(const io::Image& im, int c0, int b) {
  std::vector<Block> out;
  for (int by = 0; by + b <= im.height; by += b)
    for (int bx = 0; bx + b <= im.width; bx += b) {
      double s = 0, s2 = 0;
      for (int y = by; y < by + b; ++y)
        for (int x = bx; x < bx + b; ++x) {
          double v = 0;
          for (int c = 0; c < 3; ++c) v += im.at(x, y, c0 + c) / 3;
          s += v, s2 += v * v;
        }
      const double n = b * b, m = s / n;
      out.push_back({m, std::sqrt(std::max(0.0, s2 / n - m * m) / (n - 1))});
    }
  return out;
}

io::Image renderScene(const std::string& path, int seed) {
  render::RenderOptions o;
  o.seed = seed;
  o.threads = 2;
  return render::render(scene::loadScene(path), o).image;
}

}  // namespace

// A flat field through the uncoated plate: an emitting disc (radiance 1) filling the view of the
// 3.5 mm film, rendered with flare by path, lighttracer and bdpt. Expected at the film centre
// (Fresnel's equations integrated over the cone through the stop here): the sum
// integral of cos (1 - R)^2 (1 + R^2) dOmega, the ghost layer integral of cos R^2 (1 - R)^2
// dOmega (the plate's one ghost, rear face then front face). Per 4 x 4 block: lighttracer and
// bdpt against path, and the four central blocks against the quadrature, as z-scores.
TEST(FlareLightTracing, PlateFlatFieldAgreesWithPathAndFresnel) {
  const double n = 1.5, a = 5, film = 20;
  const std::string lens = writePlate(n, a, film);
  auto scene = [&](const std::string& name, const std::string& integrator, int spp,
                   const std::string& extra = "") {
    const std::string path = testFile(name);
    std::ofstream f(path);
    f << "LookAt 0 0 0  0 0 1  0 1 0\n"
      << "Camera \"realistic\" \"string lensfile\" \"" << lens
      << "\" \"float aperturediameter\" 10 \"float filmdistance\" " << film
      << " \"bool flare\" true" << extra << "\n"
      << "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16 "
         "\"float diagonal\" 3.5\n"
      << "Sampler \"independent\" \"integer pixelsamples\" " << spp << "\n"
      << "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
      << "Integrator \"" << integrator << "\" \"integer maxdepth\" 1\n"
      << "WorldBegin\nAttributeBegin\nTranslate 0 0 1\n"
      << "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n"
      << "Shape \"disk\" \"float radius\" 0.5\nAttributeEnd\n";
    return path;
  };
  const io::Image path = renderScene(scene("pt.pbrt", "path", 256), 3);
  const io::Image lt = renderScene(scene("lt.pbrt", "lighttracer", 8192), 4);
  const io::Image bd = renderScene(scene("bd.pbrt", "bdpt", 64), 5);
  ASSERT_EQ(lt.channelCount(), 6);
  ASSERT_EQ(lt.channels[3], "ghost.R");
  ASSERT_EQ(bd.channelCount(), 6);
  // The quadrature over the film centre's cone (half-angle atan(a / film)).
  const double alpha = std::atan(a / film);
  double ed = 0, eg = 0;
  const int steps = 20000;
  for (int i = 0; i < steps; ++i) {
    const double t = (i + 0.5) / steps * alpha;
    const double w = 2 * std::numbers::pi * std::sin(t) * std::cos(t) * alpha / steps;
    const double r = fresnel(1, n, t);
    ed += w * (1 - r) * (1 - r);
    eg += w * r * r * (1 - r) * (1 - r);
  }
  const int b = 4;
  for (int layer : {0, 3}) {
    const std::vector<Block> p = blocks(path, layer, b);
    const double expect = layer == 0 ? ed + eg : eg;
    for (const auto& [name, im] : {std::pair{"lighttracer", &lt}, std::pair{"bdpt", &bd}}) {
      const std::vector<Block> q = blocks(*im, layer, b);
      double zmax = 0, zc = 0, mc = 0;
      for (size_t k = 0; k < q.size(); ++k) {
        const double z = (q[k].mean - p[k].mean) / std::hypot(q[k].se, p[k].se);
        zmax = std::max(zmax, std::abs(z));
        EXPECT_LT(std::abs(z), 4.0) << name << " layer " << layer << " block " << k << ": "
                                    << q[k].mean << " against path's " << p[k].mean;
      }
      // The four central blocks (within 0.9 mm of the axis) against the quadrature.
      double se2 = 0;
      for (size_t k : {5u, 6u, 9u, 10u}) mc += q[k].mean / 4, se2 += q[k].se * q[k].se / 16;
      zc = (mc - expect) / std::sqrt(se2);
      std::printf(
          "plate flat field, %s, %s: centre %.6f (quadrature %.6f, z %.2f, relative error "
          "%.2f%%), path's %.6f; largest block |z| against path %.2f\n",
          name, layer == 0 ? "sum" : "ghost layer", mc, expect, zc, 100 * std::sqrt(se2) / mc,
          (p[5].mean + p[6].mean + p[9].mean + p[10].mean) / 4, zmax);
      EXPECT_LT(std::abs(zc), 4.0) << name << " layer " << layer;
      // The ratio too, so that a gross error cannot hide in a large standard error.
      EXPECT_NEAR(mc / expect, 1, layer == 0 ? 0.02 : 0.1) << name << " layer " << layer;
    }
  }
  // A hexagonal stop: the light tracer's ghost connections are passed by the shape where they
  // cross the stop, as the camera's ghost paths are; per block against path with the same stop.
  const std::string hex = " \"integer blades\" 6";
  const io::Image path_hex = renderScene(scene("pt_hex.pbrt", "path", 256, hex), 3);
  const io::Image lt_hex = renderScene(scene("lt_hex.pbrt", "lighttracer", 8192, hex), 4);
  for (int layer : {0, 3}) {
    const std::vector<Block> p = blocks(path_hex, layer, b), q = blocks(lt_hex, layer, b);
    double zmax = 0, sum_p = 0, sum_q = 0;
    for (size_t k = 0; k < q.size(); ++k) {
      const double z = (q[k].mean - p[k].mean) / std::hypot(q[k].se, p[k].se);
      zmax = std::max(zmax, std::abs(z));
      sum_p += p[k].mean, sum_q += q[k].mean;
      EXPECT_LT(std::abs(z), 4.0) << "hexagonal stop, layer " << layer << " block " << k;
    }
    std::printf("plate, hexagonal stop, lighttracer %s: image mean %.6g (path's %.6g), largest "
                "block |z| %.2f\n",
                layer == 0 ? "sum" : "ghost layer", sum_q / q.size(), sum_p / p.size(), zmax);
  }
}

// A small light 10 degrees off the axis (a sphere of angular radius 2 degrees at 10 m, on black)
// through the uncoated double Gauss at 12 mm stop: the light tracer's ghost layer (ghost
// connections from the light's own points through the 45 ghost paths) has its power-weighted
// centroid on the film within a pixel of the path tracer's (ghost camera paths that see the
// light), and its power within 10 %; the direct images' centroids within a quarter pixel.
TEST(FlareLightTracing, OffAxisLightGhostCentroidMatchesThePathTracer) {
  const double theta = 10 * std::numbers::pi / 180, delta = 2 * std::numbers::pi / 180, L = 250;
  const int xres = 64, yres = 48;
  auto scene = [&](const std::string& name, const std::string& integrator, int spp) {
    const std::string path = testFile(name);
    std::ofstream f(path);
    f << "LookAt 0 0 0  0 0 1  0 1 0\n"
      << "Camera \"realistic\" \"string lensfile\" \"" << test::lensPath("dgauss.50mm.dat")
      << "\" \"float aperturediameter\" 12 \"float focusdistance\" 10 \"bool flare\" true\n"
      << "Film \"rgb\" \"integer xresolution\" " << xres << " \"integer yresolution\" " << yres
      << " \"float diagonal\" 43.3\n"
      << "Sampler \"independent\" \"integer pixelsamples\" " << spp << "\n"
      << "Integrator \"" << integrator << "\" \"integer maxdepth\" 1\n"
      << "WorldBegin\nAttributeBegin\nTranslate " << 10 * std::sin(theta) << " 0 "
      << 10 * std::cos(theta) << "\nAreaLightSource \"diffuse\" \"rgb L\" [" << L << " " << L
      << " " << L << "]\nShape \"sphere\" \"float radius\" " << 10 * std::sin(delta)
      << "\nAttributeEnd\n";
    return path;
  };
  struct Moments {
    double power = 0, x = 0, y = 0;
  };
  // Power and first moments (pixels) of the direct image (sum less ghost) and the ghost layer.
  auto moments = [&](const io::Image& im, Moments& direct, Moments& ghost) {
    for (int y = 0; y < yres; ++y)
      for (int x = 0; x < xres; ++x) {
        double g = 0, all = 0;
        for (int c = 0; c < 3; ++c) all += im.at(x, y, c) / 3, g += im.at(x, y, 3 + c) / 3;
        direct.power += all - g, direct.x += (all - g) * x, direct.y += (all - g) * y;
        ghost.power += g, ghost.x += g * x, ghost.y += g * y;
      }
  };
  const io::Image pt = renderScene(scene("off_pt.pbrt", "path", 256), 2);
  const io::Image lt = renderScene(scene("off_lt.pbrt", "lighttracer", 256), 6);
  Moments dp, gp, dl, gl;
  moments(pt, dp, gp);
  moments(lt, dl, gl);
  std::printf(
      "light at 10 deg: path's ghost power %.4g at (%.2f, %.2f) px, lighttracer's %.4g at "
      "(%.2f, %.2f) px; direct %.4g at (%.2f, %.2f) against %.4g at (%.2f, %.2f)\n",
      gp.power, gp.x / gp.power, gp.y / gp.power, gl.power, gl.x / gl.power, gl.y / gl.power,
      dp.power, dp.x / dp.power, dp.y / dp.power, dl.power, dl.x / dl.power, dl.y / dl.power);
  EXPECT_NEAR(gl.x / gl.power, gp.x / gp.power, 1.0);
  EXPECT_NEAR(gl.y / gl.power, gp.y / gp.power, 1.0);
  EXPECT_NEAR(gl.power, gp.power, 0.1 * gp.power);
  EXPECT_NEAR(dl.x / dl.power, dp.x / dp.power, 0.25);
  EXPECT_NEAR(dl.y / dl.power, dp.y / dp.power, 0.25);
  EXPECT_NEAR(dl.power, dp.power, 0.03 * dp.power);
  // bdpt: its ghosts are the camera side's ghost paths with bdpt's strategies t >= 2.
  const io::Image bd = renderScene(scene("off_bd.pbrt", "bdpt", 128), 8);
  Moments db, gb;
  moments(bd, db, gb);
  std::printf("bdpt: ghost power %.4g at (%.2f, %.2f) px; direct %.4g at (%.2f, %.2f)\n",
              gb.power, gb.x / gb.power, gb.y / gb.power, db.power, db.x / db.power,
              db.y / db.power);
  EXPECT_NEAR(gb.x / gb.power, gp.x / gp.power, 1.0);
  EXPECT_NEAR(gb.y / gb.power, gp.y / gp.power, 1.0);
  EXPECT_NEAR(gb.power, gp.power, 0.1 * gp.power);
  EXPECT_NEAR(db.x / db.power, dp.x / dp.power, 0.25);
  EXPECT_NEAR(db.power, dp.power, 0.03 * dp.power);
}

// The uncoated double Gauss (12 mm stop) before an emitting disc that fills its view: the light
// tracer's and bdpt's sum and ghost layer against the path tracer's, per 4 x 4 block (z-scores
// from the pixels' scatter), and the direct part (sum less ghosts) over the render without flare
// against the product of the ten index steps' normal-incidence Fresnel transmittances (the real
// rays' angles add under 1.5 %, as in render_flare_test).
TEST(FlareLightTracing, DoubleGaussFlatFieldAgreesWithPath) {
  auto scene = [&](const std::string& name, const std::string& integrator, int spp, bool flare) {
    const std::string path = testFile(name);
    std::ofstream f(path);
    f << "LookAt 0 0 0  0 0 1  0 1 0\n"
      << "Camera \"realistic\" \"string lensfile\" \"" << test::lensPath("dgauss.50mm.dat")
      << "\" \"float aperturediameter\" 12 \"float focusdistance\" 3"
      << (flare ? " \"bool flare\" true" : "") << "\n"
      << "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16 "
         "\"float diagonal\" 35\n"
      << "Sampler \"independent\" \"integer pixelsamples\" " << spp << "\n"
      << "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
      << "Integrator \"" << integrator << "\" \"integer maxdepth\" 1\n"
      << "WorldBegin\nAttributeBegin\nTranslate 0 0 1\n"
      << "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n"
      << "Shape \"disk\" \"float radius\" 1.5\nAttributeEnd\n";
    return path;
  };
  const io::Image off = renderScene(scene("dg_off.pbrt", "path", 64, false), 1);
  const io::Image path = renderScene(scene("dg_pt.pbrt", "path", 128, true), 3);
  const io::Image lt = renderScene(scene("dg_lt.pbrt", "lighttracer", 4096, true), 4);
  const io::Image bd = renderScene(scene("dg_bd.pbrt", "bdpt", 32, true), 5);
  const double steps[][2] = {{1, 1.67},  {1.67, 1},      {1, 1.67},  {1.67, 1.699}, {1.699, 1},
                             {1, 1.603}, {1.603, 1.658}, {1.658, 1}, {1, 1.717},    {1.717, 1}};
  double t = 1;
  for (const auto& s : steps) t *= 1 - fresnel(s[0], s[1], 0);
  const int b = 4;
  const std::vector<Block> o = blocks(off, 0, b);
  for (int layer : {0, 3}) {
    const std::vector<Block> p = blocks(path, layer, b);
    for (const auto& [name, im] : {std::pair{"lighttracer", &lt}, std::pair{"bdpt", &bd}}) {
      const std::vector<Block> q = blocks(*im, layer, b);
      double zmax = 0, sum_q = 0, sum_p = 0, var = 0;
      for (size_t k = 0; k < q.size(); ++k) {
        const double z = (q[k].mean - p[k].mean) / std::hypot(q[k].se, p[k].se);
        zmax = std::max(zmax, std::abs(z));
        sum_q += q[k].mean, sum_p += p[k].mean;
        var += q[k].se * q[k].se + p[k].se * p[k].se;
        EXPECT_LT(std::abs(z), 4.0) << name << " layer " << layer << " block " << k << ": "
                                    << q[k].mean << " against path's " << p[k].mean;
      }
      const double z_all = (sum_q - sum_p) / std::sqrt(var);
      std::printf("double Gauss flat field, %s, %s: image mean %.5f, path's %.5f (z %.2f); "
                  "largest block |z| %.2f\n",
                  name, layer == 0 ? "sum" : "ghost layer", sum_q / q.size(), sum_p / p.size(),
                  z_all, zmax);
      EXPECT_LT(std::abs(z_all), 4.0) << name << " layer " << layer;
    }
  }
  // The direct part at the four central blocks over the render without flare.
  for (const auto& [name, im] : {std::pair{"path", &path}, std::pair{"lighttracer", &lt},
                                 std::pair{"bdpt", &bd}}) {
    const std::vector<Block> s = blocks(*im, 0, b), g = blocks(*im, 3, b);
    double direct = 0, plain = 0, se2 = 0;
    for (size_t k : {5u, 6u, 9u, 10u}) {
      direct += s[k].mean - g[k].mean, plain += o[k].mean;
      se2 += s[k].se * s[k].se + o[k].se * o[k].se;
    }
    std::printf(
        "double Gauss flat field, %s: direct / no flare %.4f +- %.4f (normal incidence %.4f)\n",
        name, direct / plain, std::sqrt(se2) / plain, t);
    EXPECT_NEAR(direct / plain, t, 0.02) << name;
  }
}

// A dispersive lens's (an N-BK7 singlet's) flare is traced at each sample's hero wavelength on the camera side; the
// light side's ghost connections use the primary-wavelength indices, so lighttracer and bdpt
// refuse it at the Camera line (path renders it).
TEST(FlareLightTracing, DispersiveLensIsRefusedByLightTracingIntegrators) {
  const std::string lens = testFile("bk7_singlet.json");
  std::ofstream(lens) << "{\"format\": \"lensim-lens\", \"name\": \"bk7 singlet\", \"surfaces\": ["
                         "{\"radius_mm\": 50, \"thickness_mm\": 4, \"semi_aperture_mm\": 12, "
                         "\"glass\": {\"name\": \"N-BK7\"}},"
                         "{\"radius_mm\": -50, \"thickness_mm\": 2, \"semi_aperture_mm\": 12},"
                         "{\"radius_mm\": 0, \"thickness_mm\": 45, \"semi_aperture_mm\": 4, "
                         "\"stop\": true}]}\n";
  for (const char* integrator : {"lighttracer", "bdpt", "path"}) {
    const std::string path = testFile(std::string("dispersive_") + integrator + ".pbrt");
    std::ofstream(path) << "Camera \"realistic\" \"string lensfile\" \"" << lens
                        << "\" \"bool flare\" true\n"
                           "Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\n"
                           "Sampler \"independent\" \"integer pixelsamples\" 1\n"
                           "Integrator \""
                        << integrator
                        << "\"\nWorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n";
    const bool refused = std::string(integrator) != "path";
    try {
      renderScene(path, 1);
      EXPECT_FALSE(refused) << integrator;
    } catch (const Error& e) {
      EXPECT_TRUE(refused) << integrator << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(path + ":1:1: error: realistic camera: \"flare\" "
                                           "through a dispersive lens"),
                std::string::npos)
          << e.what();
    }
  }
}

// The render statistics count the light-side ghost connections: the light tracer's
// (sampleGhostWi splats) and bdpt's (strategies s >= 1 of its ghost camera subpaths), on a line
// of their own; none without flare, and then no line. A diffuse wall behind a two-sided area
// light gives bdpt's ghost camera subpaths a surface to connect from.
TEST(FlareLightTracing, GhostConnectionsAreCountedInTheStats) {
  const std::string lens = writePlate(1.5, 5, 20);
  for (const std::string integrator : {"lighttracer", "bdpt"})
    for (const bool flare : {true, false}) {
      const std::string path = testFile("stats_" + integrator + ".pbrt");
      {
        std::ofstream f(path);
        f << "LookAt 0 0 0  0 0 1  0 1 0\n"
          << "Camera \"realistic\" \"string lensfile\" \"" << lens
          << "\" \"float aperturediameter\" 10 \"float filmdistance\" 20 \"bool flare\" "
          << (flare ? "true" : "false") << "\n"
          << "Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12 "
             "\"float diagonal\" 3.5\n"
          << "Sampler \"independent\" \"integer pixelsamples\" "
          << (integrator == "bdpt" ? 16 : 64) << "\n"
          << "Integrator \"" << integrator << "\" \"integer maxdepth\" 1\n"
          << "WorldBegin\nAttributeBegin\nTranslate 0 0 1\n"
          << "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n"
          << "Shape \"disk\" \"float radius\" 0.3\nAttributeEnd\n"
          << "AttributeBegin\nTranslate 0 0 3\nMaterial \"diffuse\" \"rgb reflectance\" [0.8 0.8 "
             "0.8]\nShape \"disk\" \"float radius\" 10\nAttributeEnd\n";
      }
      render::RenderOptions o;
      o.seed = 7;
      o.threads = 2;
      const render::RenderResult r = render::render(scene::loadScene(path), o);
      const std::string text = render::formatStats(r.stats);
      const bool line = text.find("ghost connections") != std::string::npos;
      if (flare) {
        EXPECT_GT(r.stats.ghost_connections, 0u) << integrator;
        EXPECT_TRUE(line) << integrator << "\n" << text;
        // Connections that carried light: the ghost layer is not black.
        double ghost = 0;
        for (int y = 0; y < r.image.height; ++y)
          for (int x = 0; x < r.image.width; ++x) ghost += r.image.at(x, y, 3);
        EXPECT_GT(ghost, 0) << integrator;
        std::printf("%s with flare: %llu ghost connections, %llu ghost rays\n",
                    integrator.c_str(), (unsigned long long)r.stats.ghost_connections,
                    (unsigned long long)r.stats.ghost_rays);
      } else {
        EXPECT_EQ(r.stats.ghost_connections, 0u) << integrator;
        EXPECT_FALSE(line) << integrator << "\n" << text;
      }
    }
}
