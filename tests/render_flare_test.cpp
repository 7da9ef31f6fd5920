// Lens flare in the renderer (issue 31): the realistic camera's "bool flare", the ghost layer and
// the refusals. Checked against closed forms computed here (Fresnel's equations, the cone of a
// flat field), not against the camera's own numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "lensim/camera/realistic.h"
#include "lensim/io/image.h"
#include "lensim/optics/coating/ghosts.h"
#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/optics/lens_system.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/builder.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;

namespace {

std::string testFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_render_flare_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

/// An uncoated plane-parallel plate (index n, 5 mm) and behind it a stop of radius a, the film
/// `film_mm` behind the stop; the plate's clear aperture is wide enough never to clip. (Its
/// front face has a radius of 200 m: lensim refuses afocal lenses; the power, 1/400 m, tilts no
/// ray of the test by more than 2e-5 rad.)
std::string writePlate(double n, double a, double film_mm) {
  const std::string path = testFile("plate.json");
  std::ofstream f(path);
  f << "{\"format\": \"lensim-lens\", \"name\": \"plate\", \"coating\": \"uncoated\", "
       "\"surfaces\": ["
    << "{\"radius_mm\": 2e5, \"thickness_mm\": 5, \"semi_aperture_mm\": 40, \"ior\": " << n << "},"
    << "{\"radius_mm\": 0, \"thickness_mm\": 2, \"semi_aperture_mm\": 40, \"ior\": 1},"
    << "{\"radius_mm\": 0, \"thickness_mm\": " << film_mm << ", \"semi_aperture_mm\": " << a
    << ", \"ior\": 1, \"stop\": true}]}\n";
  return path;
}

/// A scene: the camera inside a uniform environment of radiance 1.
std::string writeScene(const std::string& name, const std::string& camera_params,
                       const std::string& extra = "", double diagonal_mm = 35) {
  const std::string path = testFile(name);
  std::ofstream f(path);
  f << "Camera \"realistic\" " << camera_params << "\n"
    << "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16 \"float diagonal\" "
    << diagonal_mm << "\n"
    << "Sampler \"independent\" \"integer pixelsamples\" 64\n"
    << "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
    << extra << "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n";
  return path;
}

/// Mean of channel c0..c0+2 over the central 4 x 4 pixels.
double centre(const io::Image& im, int c0) {
  double sum = 0;
  const int x0 = im.width / 2 - 2, y0 = im.height / 2 - 2;
  for (int y = y0; y < y0 + 4; ++y)
    for (int x = x0; x < x0 + 4; ++x)
      for (int c = 0; c < 3; ++c) sum += im.at(x, y, c0 + c) / 48.0;
  return sum;
}

/// Unpolarised Fresnel reflectance from index n1 into n2 at incidence angle theta (the mean of
/// R_s and R_p; 1 beyond the critical angle).
double fresnel(double n1, double n2, double theta) {
  const double ci = std::cos(theta), si = std::sin(theta), st = n1 / n2 * si;
  if (st >= 1) return 1;
  const double ct = std::sqrt(1 - st * st);
  const double rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
  const double rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
  return 0.5 * (rs * rs + rp * rp);
}

}  // namespace

// A flat field through an uncoated plate: without flare the film centre reads the irradiance of
// the cone through the stop, E0 = integral of cos(theta) dOmega; with flare the direct path
// carries (1 - R)^2 and the one ghost (reflected at the rear face, then the front face) R^2 (1 -
// R)^2 at every angle of the cone (the plate never clips the ghost), so that the image is
// integral of cos (1 - R)^2 (1 + R^2) dOmega: the first two terms of the plate's
// (1 - R)^2 / (1 - R^2). Computed here by quadrature with Fresnel's equations.
TEST(FlareRender, UncoatedPlateFlatFieldIsDirectPlusTwoReflectionTerm) {
  const double n = 1.5, a = 5, film = 20;
  const std::string lens = writePlate(n, a, film);
  const std::string common = "\"string lensfile\" \"" + lens +
                             "\" \"float aperturediameter\" 10 \"float filmdistance\" " +
                             std::to_string(film);
  render::RenderOptions o;
  o.seed = 5;
  o.threads = 2;
  // A 3.5 mm film: the centre pixels lie within 0.3 mm of the axis, where the cone's irradiance
  // differs from the axial one by under 0.1%.
  const io::Image off =
      render::render(scene::loadScene(writeScene("plate_off.pbrt", common, "", 3.5)), o).image;
  const io::Image on =
      render::render(
          scene::loadScene(writeScene("plate_on.pbrt", common + " \"bool flare\" true", "", 3.5)),
          o)
          .image;
  ASSERT_EQ(off.channelCount(), 3);
  ASSERT_EQ(on.channelCount(), 6);
  ASSERT_EQ(on.channels[3], "ghost.R");
  // Quadrature over the cone of the film centre (half-angle atan(a / film)).
  const double alpha = std::atan(a / film);
  double e0 = 0, ed = 0, eg = 0;
  const int steps = 20000;
  for (int i = 0; i < steps; ++i) {
    const double t = (i + 0.5) / steps * alpha;
    const double w = 2 * std::numbers::pi * std::sin(t) * std::cos(t) * alpha / steps;
    const double r = fresnel(1, n, t);  // the same at the exit face (reciprocity)
    e0 += w;
    ed += w * (1 - r) * (1 - r);
    eg += w * r * r * (1 - r) * (1 - r);
  }
  const double c_off = centre(off, 0), c_on = centre(on, 0), c_ghost = centre(on, 3);
  const double r0 = std::pow((n - 1) / (n + 1), 2);
  std::printf(
      "plate flat field: off %.6f (pi sin^2 %.6f), on %.6f, ghost layer %.3e; expected on/off "
      "%.6f, ghost/off %.4e (normal incidence: (1-R)^2 (1+R^2) = %.6f, plate T = %.6f)\n",
      c_off, e0, c_on, c_ghost, (ed + eg) / e0, eg / e0, (1 - r0) * (1 - r0) * (1 + r0 * r0),
      (1 - r0) * (1 - r0) / (1 - r0 * r0));
  // volpath renders the same ghosts (the same camera rays and weights; the sky seen directly).
  const io::Image vol =
      render::render(scene::loadScene(writeScene("plate_vol.pbrt", common + " \"bool flare\" true",
                                                 "Integrator \"volpath\"\n", 3.5)),
                     o)
          .image;
  EXPECT_NEAR(centre(vol, 0), c_on, 1e-6 * c_on);
  EXPECT_NEAR(centre(vol, 3), c_ghost, 1e-6 * c_ghost);
  EXPECT_NEAR(c_off, e0, 0.015 * e0);  // the pupil bound's blocked samples: ~1% noise
  EXPECT_NEAR(c_on / c_off, (ed + eg) / e0, 3e-4);
  EXPECT_NEAR(c_ghost / c_off, eg / e0, 0.01 * eg / e0);
}

// With "bool flare" false the render is the one without the parameter, bit for bit, with no ghost
// layer; with flare the uncoated double Gauss's flat field drops to its direct transmittance
// (eight air-glass surfaces, Fresnel at each, here at normal incidence: the real rays' angles of
// up to ~20 degrees add under 1%) plus a ghost layer of a few per cent.
TEST(FlareRender, DoubleGaussFlatField) {
  const std::string common = "\"string lensfile\" \"" + test::lensPath("dgauss.50mm.dat") +
                             "\" \"float aperturediameter\" 12 \"float focusdistance\" 3";
  render::RenderOptions o;
  o.seed = 7;
  o.threads = 2;
  o.spp = 32;
  const io::Image plain =
      render::render(scene::loadScene(writeScene("dg_plain.pbrt", common)), o).image;
  const io::Image off =
      render::render(scene::loadScene(writeScene("dg_off.pbrt", common + " \"bool flare\" false")),
                     o)
          .image;
  ASSERT_EQ(plain.channels, off.channels);
  ASSERT_EQ(plain.pixels, off.pixels);
  const io::Image on =
      render::render(scene::loadScene(writeScene("dg_on.pbrt", common + " \"bool flare\" true")), o)
          .image;
  ASSERT_EQ(on.channelCount(), 6);
  // Independent: the prescription's index steps (dgauss.50mm.dat, in order) at normal incidence.
  const double steps[][2] = {{1, 1.67},  {1.67, 1},      {1, 1.67},  {1.67, 1.699}, {1.699, 1},
                             {1, 1.603}, {1.603, 1.658}, {1.658, 1}, {1, 1.717},    {1.717, 1}};
  double t = 1;
  for (const auto& s : steps) t *= 1 - fresnel(s[0], s[1], 0);
  const double c_off = centre(off, 0), c_on = centre(on, 0), c_ghost = centre(on, 3);
  const double direct = (c_on - c_ghost) / c_off;
  std::printf("double Gauss flat field: direct/off %.4f (normal incidence %.4f), ghost/off %.4f\n",
              direct, t, c_ghost / c_off);
  EXPECT_NEAR(direct, t, 0.015);
  // The ghosts of an extended field: the sum of `lens ghosts`' axial intensities is 5.5e-2 of the
  // direct image; the field's off-axis points' ghosts are clipped more.
  EXPECT_GT(c_ghost / c_off, 0.01);
  EXPECT_LT(c_ghost / c_off, 0.08);
}

// Refused at the Camera line, with nothing rendered: integrators that splat, films without the
// ghost layer, dispersive lenses, parts; "flarecoating" without flare or with an unknown name at
// its parameter.
TEST(FlareRender, Refusals) {
  const std::string common = "\"string lensfile\" \"" + test::lensPath("dgauss.50mm.dat") +
                             "\" \"float aperturediameter\" 12 \"float focusdistance\" 3";
  auto expectError = [](const std::string& path, const std::string& what, int line,
                        const render::RenderOptions& o = {}) {
    try {
      render::render(scene::loadScene(path), o);
      ADD_FAILURE() << "no error for " << what;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_EQ(e.loc().line, line) << e.what();
    }
  };
  const std::string on = common + " \"bool flare\" true";
  expectError(writeScene("bdpt.pbrt", on, "Integrator \"bdpt\"\n"), "not \"bdpt\"", 1);
  expectError(writeScene("lt.pbrt", on, "Integrator \"lighttracer\"\n"), "not \"lighttracer\"", 1);
  {
    const std::string path = testFile("spectral.pbrt");
    std::ofstream f(path);
    f << "Camera \"realistic\" " << on << "\nFilm \"spectral\" \"integer xresolution\" 8 "
      << "\"integer yresolution\" 8\nWorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n";
    f.close();
    expectError(path, "needs Film \"rgb\"", 1);
  }
  expectError(writeScene("glass.pbrt", on + " \"bool glassmatch\" true"), "disperses", 1);
  render::RenderOptions parts;
  parts.keep_sums = true;
  expectError(writeScene("parts.pbrt", on), "parts", 1, parts);
  try {
    scene::loadScene(writeScene("coat.pbrt", common + " \"string flarecoating\" \"multi\""));
    ADD_FAILURE() << "flarecoating without flare accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("flarecoating"), std::string::npos) << e.what();
  }
  expectError(writeScene("unknown.pbrt", on + " \"string flarecoating\" \"bogus\""), "bogus", 1);
}

// A multicoated lens's ghosts are far weaker than the uncoated one's, and its direct
// transmission higher ("string flarecoating" as `lens ghosts --coating`).
TEST(FlareRender, MulticoatingWeakensGhosts) {
  const std::string common = "\"string lensfile\" \"" + test::lensPath("dgauss.50mm.dat") +
                             "\" \"float aperturediameter\" 12 \"float focusdistance\" 3 "
                             "\"bool flare\" true";
  render::RenderOptions o;
  o.seed = 9;
  o.threads = 2;
  o.spp = 16;
  const io::Image un = render::render(scene::loadScene(writeScene("un.pbrt", common)), o).image;
  const io::Image multi =
      render::render(
          scene::loadScene(writeScene("multi.pbrt", common + " \"string flarecoating\" \"multi\"")),
          o)
          .image;
  std::printf("flat field: uncoated %.4f (ghosts %.3e), multicoated %.4f (ghosts %.3e)\n",
              centre(un, 0), centre(un, 3), centre(multi, 0), centre(multi, 3));
  EXPECT_GT(centre(multi, 0), 1.4 * (centre(un, 0) - centre(un, 3)));
  EXPECT_LT(centre(multi, 3), 0.1 * centre(un, 3));
}

// A small bright disc on the axis (a sphere of 0.5 m at 10 m: 2.9 degrees) on a black sky: the
// ghost layer's energy over the whole film, over the direct image's, against the workbench's
// sum of the 55 ghosts' paraxial intensities (`lens ghosts` at the same stop and focus: normal
// incidence, paraxial clipping). The film is 150 mm across so that every ghost disc (up to
// 64 mm, `lens ghosts`) lies on it. Measured 0.067-0.070 (four seeds, 256 spp; +-2% noise)
// against 0.0718: real rays meet the surfaces off normal and the real apertures clip the ghost
// beams differently from the paraxial ones; the tolerance is 10%.
TEST(FlareRender, GhostEnergyOfAnAxialLightMatchesTheWorkbench) {
  const std::string path = testFile("axial.pbrt");
  {
    std::ofstream f(path);
    f << "Camera \"realistic\" \"string lensfile\" \"" << test::lensPath("dgauss.50mm.dat")
      << "\" \"float aperturediameter\" 12 \"float focusdistance\" 10 \"bool flare\" true\n"
      << "Film \"rgb\" \"integer xresolution\" 64 \"integer yresolution\" 64 "
         "\"float diagonal\" 150\n"
      << "Sampler \"independent\" \"integer pixelsamples\" 256\n"
      << "Integrator \"path\" \"integer maxdepth\" 1\n"
      << "WorldBegin\nAttributeBegin\nTranslate 0 0 10\n"
      << "AreaLightSource \"diffuse\" \"rgb L\" [2000 2000 2000]\n"
      << "Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n";
  }
  render::RenderOptions o;
  o.seed = 1;
  o.threads = 2;
  const io::Image im = render::render(scene::loadScene(path), o).image;
  ASSERT_EQ(im.channelCount(), 6);
  double total = 0, ghost = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int c = 0; c < 3; ++c) total += im.at(x, y, c), ghost += im.at(x, y, 3 + c);
  camera::RealisticSettings s;
  s.lens_path = test::lensPath("dgauss.50mm.dat");
  s.setup.aperture_diameter_mm = 12;
  s.setup.focus_distance_m = 10;
  const camera::RealisticCamera cam(s);
  const optics::LensSystem& lens = *cam.lens().lens;
  std::vector<double> wl;
  for (int l = 400; l <= 700; l += 10) wl.push_back(l);
  const optics::GhostAnalysis ga =
      optics::analyseGhosts(lens, optics::resolveCoatings(lens.prescription()), wl);
  double paraxial = 0;
  for (const optics::Ghost& g : ga.ghosts) paraxial += g.relative_intensity;
  const double ratio = ghost / (total - ghost);
  std::printf("axial light: ghost / direct energy %.4f, workbench (paraxial) %.4f\n", ratio,
              paraxial);
  EXPECT_NEAR(ratio, paraxial, 0.1 * paraxial);
}
