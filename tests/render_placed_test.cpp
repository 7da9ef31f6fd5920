// Rendering through lenses with tilted or decentred surfaces (issues 28 and 30,
// camera/realistic_placed.h), checked against closed forms computed here: a decentred singlet's
// image of a small lamp lands where a paraxial y-nu trace about the lens's own axis puts it; a
// tilted plane-parallel plate in the converging beam shifts the image by
// t sin(theta) (1 - cos(theta) / sqrt(n^2 - sin^2(theta))); and a lens made non-coaxial only by
// a decentred dummy surface renders the flat field the coaxial camera renders (per-block z-test,
// and the centre's irradiance pi sin^2 of the real marginal ray).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "lensim/camera/realistic.h"
#include "lensim/camera/realistic_placed.h"
#include "lensim/io/image.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/render/image_compare.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "test_paths.h"

using namespace lensim;

namespace {

constexpr double kN = 1.5168;  // the singlet's and the plate's glass (n_d)
constexpr double kRadius = 50, kThick = 5, kStopGap = 10, kImage = 93.4528125;

std::string testFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "lensim_render_placed_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::string write(const std::string& name, const std::string& text) {
  const std::string path = testFile(name);
  std::ofstream(path) << text;
  return path;
}

// Zemax rows.
std::string surf(int n, const std::string& body) {
  return fmt::format("SURF {}\n{}", n, body);
}
std::string plane(double disz, double diam, const std::string& extra = "") {
  return fmt::format("  TYPE STANDARD\n  CURV 0.0\n  DISZ {}\n  DIAM {}\n{}", disz, diam, extra);
}
std::string coordbrk(double dx, double dy, double tilt_x_deg, double disz) {
  return fmt::format(
      "  TYPE COORDBRK\n  CURV 0.0\n  PARM 1 {}\n  PARM 2 {}\n  PARM 3 {}\n  PARM 4 0\n"
      "  PARM 5 0\n  PARM 6 0\n  DISZ {}\n",
      dx, dy, tilt_x_deg, disz);
}
const std::string kGlass = "  GLAS ___BLANK 1 0 1.5168 64.17 0 0 0 0 0 0\n";
const std::string kHead =
    "VERS 190513 80 123457 L123457\nMODE SEQ\nNAME {}\nUNIT MM X W X CM MR CPMM\n"
    "WAVM 1 0.5875618 1\nPWAV 1\nSURF 0\n  TYPE STANDARD\n  CURV 0.0\n  DISZ INFINITY\n";

// The singlet (R 50 plano-convex, 5 mm, semi-diameter 6 mm) 10 mm behind a stop of semi-diameter
// stop_semi; `middle`: rows between the stop and the lens, `after`: rows between the lens and the
// image (which is image_gap behind the last of them).
std::string singlet(const std::string& name, double stop_semi,
                    const std::vector<std::string>& middle, const std::vector<std::string>& after,
                    double image_gap) {
  std::string s = fmt::format(fmt::runtime(kHead), name);
  int n = 1;
  s += surf(n++, "  STOP\n" + plane(middle.empty() ? kStopGap : 0, stop_semi));
  for (size_t i = 0; i < middle.size(); ++i) s += surf(n++, middle[i]);
  s += surf(n++, fmt::format("  TYPE STANDARD\n  CURV {}\n  DISZ {}\n{}  DIAM 6\n", 1 / kRadius,
                             kThick, kGlass));
  s += surf(n++, plane(after.empty() ? image_gap : 0, 6));
  for (const std::string& a : after) s += surf(n++, a);
  s += surf(n, "  TYPE STANDARD\n  CURV 0.0\n  DISZ 0\n");
  return s;
}

// A scene: the camera at the origin (the front vertex) looking down +z through `lens`, a lamp
// (an emitting sphere of radius 1 mm) on the axis at `distance` m, focused on it (focusdistance
// is measured from the film: `track_mm` from the front vertex to the film, near enough); the
// film 1.6 mm square at 160 pixels (10 um each).
std::string lampScene(const std::string& name, const std::string& lens, double aperture_mm,
                      double distance, double track_mm, int spp) {
  return write(
      name,
      fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float aperturediameter\" "
                  "{} \"float focusdistance\" {}\n"
                  "Film \"rgb\" \"integer xresolution\" 160 \"integer yresolution\" 160 "
                  "\"float diagonal\" {}\n"
                  "Sampler \"independent\" \"integer pixelsamples\" {}\n"
                  "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
                  "WorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n"
                  "Translate 0 0 {}\nShape \"sphere\" \"float radius\" 0.001\nAttributeEnd\n",
                  lens, aperture_mm, distance + track_mm / 1000, 1.6 * std::sqrt(2.0), spp,
                  distance));
}

constexpr double kPixel_mm = 0.01, kHalf_mm = 0.8;

// The image's brightness centroid on the film (mm, the image surface's frame: raster x runs
// along -x, raster y along +y).
Vec2 centroidMm(const io::Image& im) {
  double sum = 0, sx = 0, sy = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const double v = im.at(x, y, 0) + im.at(x, y, 1) + im.at(x, y, 2);
      sum += v, sx += v * (x + 0.5), sy += v * (y + 0.5);
    }
  EXPECT_GT(sum, 0);
  return {kHalf_mm - sx / sum * kPixel_mm, -kHalf_mm + sy / sum * kPixel_mm};
}

// Paraxial y-nu trace (reduced slopes) of a ray through the singlet about its own axis from the
// plane z0 (height h, slope u), to where the ray crosses the lens's paraxial image of the plane
// z0: found from two rays of the same object point. Returns the image height.
double paraxialImageHeight(double h0, double object_distance_to_lens_mm) {
  auto trace = [&](double u) {  // (height, slope) after the lens's back surface
    double h = h0 + u * object_distance_to_lens_mm, nu = u;
    nu -= h * (kN - 1) / kRadius;
    h += kThick * nu / kN;
    return std::pair{h, nu};
  };
  const auto [h1, u1] = trace(0.0);
  const auto [h2, u2] = trace(1e-3);
  const double z = -(h1 - h2) / (u1 - u2);  // behind the back surface
  return h1 + u1 * z;
}

render::RenderResult renderScene(const std::string& path, int seed, int spp = 0) {
  render::RenderOptions o;
  o.seed = seed;
  if (spp > 0) o.spp = spp;
  return render::render(scene::loadScene(path), o);
}

}  // namespace

// The singlet decentred 0.5 mm in y behind a stop on the object axis, the decentre undone before
// the image (tests/data/lenses/decentred_singlet.zmx, here at f/16 for fewer wasted samples): a
// lamp on the object axis 1 m away is 0.5 mm below the lens's axis, and its image lies at
// 0.5 (1 - m) mm, m the paraxial magnification, about 5 pixels from where the lens's axis meets
// the film.
TEST(PlacedRender, DecentredLensDisplacesTheImageByTheParaxialAmount) {
  constexpr double d = 0.5, distance_m = 1;
  const std::string lens = write(
      "decentred.zmx",
      singlet("decentred", 3, {coordbrk(0, d, 0, kStopGap)}, {coordbrk(0, -d, 0, kImage)}, 0));
  ASSERT_TRUE(optics::readLensFile(lens).noncoaxial_loc.has_value());
  const Vec2 c = centroidMm(
      renderScene(lampScene("decentred.pbrt", lens, 6, distance_m, kStopGap + kThick + kImage, 32),
                  1)
          .image);
  const double image_from_lens_axis = paraxialImageHeight(-d, 1000 * distance_m + kStopGap);
  const double expected = d + image_from_lens_axis;
  std::printf("decentred singlet: image centroid (%.5f, %.5f) mm, paraxial (0, %.5f) mm\n", c.x,
              c.y, expected);
  EXPECT_NEAR(c.y, expected, kPixel_mm);
  EXPECT_NEAR(c.x, 0, kPixel_mm);
  EXPECT_GT(std::abs(expected - d), 4 * kPixel_mm);  // distinguishable from the lens's axis
}

// A plate t = 5 mm thick (perpendicular to its faces) tilted 20 degrees about x in the
// converging beam behind a centred singlet shifts the image of an axial lamp by
// t sin(theta) (1 - cos(theta) / sqrt(n^2 - sin^2(theta))) = 0.622 mm, toward -y (Zemax's
// tilt about x is right-handed: the plate's normal turns to (0, -sin, cos), and the ray bends
// toward it inside the glass). Faces: a break that tilts, the face, a break that untilts (so
// the axis and the next vertex stay on the object axis).
TEST(PlacedRender, TiltedPlateShiftsTheImageByTheClosedForm) {
  constexpr double theta_deg = 20, t = 5;
  const double theta = theta_deg * std::numbers::pi / 180;
  const double axial = t / std::cos(theta);  // vertex to vertex along the object axis
  const std::vector<std::string> plate = {
      coordbrk(0, 0, theta_deg, 0), plane(0, 3, kGlass), coordbrk(0, 0, -theta_deg, axial),
      coordbrk(0, 0, theta_deg, 0), plane(0, 3),         coordbrk(0, 0, -theta_deg, 84)};
  std::vector<std::string> after = {plane(20, 6)};
  after.insert(after.end(), plate.begin(), plate.end());
  const std::string lens = write("plate.zmx", singlet("plate", 1, {}, after, 0));
  ASSERT_TRUE(optics::readLensFile(lens).noncoaxial_loc.has_value());
  const Vec2 c = centroidMm(
      renderScene(lampScene("plate.pbrt", lens, 2, 1, kStopGap + kThick + 20 + axial + 84, 64), 2)
          .image);
  const double s = std::sin(theta),
               shift = t * s * (1 - std::cos(theta) / std::sqrt(kN * kN - s * s));
  std::printf("tilted plate: image centroid (%.5f, %.5f) mm, closed form (0, %.5f) mm\n", c.x, c.y,
              -shift);
  EXPECT_NEAR(c.y, -shift, kPixel_mm);
  EXPECT_NEAR(c.x, 0, kPixel_mm);
}

// The singlet at f/9.7 made non-coaxial only by a dummy plane surface decentred 3 mm (a break
// there and back) against the plain coaxial file, whose film is put where the placed camera's
// focus put it: the flat field (uniform radiance 1) agrees block by block (z-test on two seeds
// of the placed render against the coaxial camera at 4x the samples), and its centre reads
// pi sin^2 of the real marginal ray's angle, as in RealisticRender.FlatFieldAndExposure.
TEST(PlacedRender, DecentredByNothingMatchesTheCoaxialFlatField) {
  const std::string coaxial = write("coaxial.zmx", singlet("coaxial", 5, {}, {}, kImage));
  const std::string placed =
      write("dummy.zmx",
            singlet("dummy", 5, {coordbrk(0, 3, 0, 0), plane(0, 40), coordbrk(0, -3, 0, kStopGap)},
                    {}, kImage));
  ASSERT_FALSE(optics::readLensFile(coaxial).noncoaxial_loc.has_value());
  ASSERT_TRUE(optics::readLensFile(placed).noncoaxial_loc.has_value());
  const std::string common =
      "Film \"rgb\" \"integer xresolution\" 30 \"integer yresolution\" 30 \"float diagonal\" 12\n"
      "Sampler \"independent\" \"integer pixelsamples\" 64\n"
      "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
      "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n";
  const std::string placed_scene =
      write("dummy.pbrt", fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float "
                                      "aperturediameter\" 10 \"float focusdistance\" 1e6\n{}",
                                      placed, common));
  camera::RealisticSettings settings;
  settings.setup.aperture_diameter_mm = 10;
  settings.setup.focus_distance_m = 1e6;
  settings.x_resolution = settings.y_resolution = 30;
  settings.film_diagonal_mm = 12;
  const camera::PlacedRealisticCamera cam(settings, optics::readLensFile(placed));
  const double film_mm = kImage + cam.filmOffset_mm();
  // The focus at infinity against third-order theory: with transverse aberration a rho^3 + b rho
  // over a uniformly filled stop the RMS spot is smallest at b = -2a/3, two thirds of the way
  // from the paraxial focus (the file's image distance kImage is the paraxial back focal length)
  // to where the marginal ray (stop edge, traced here) crosses the axis.
  {
    const double h = 5, n1 = 1, n2 = kN;
    // Refraction at the sphere (centre at kRadius behind the vertex), then at the plane.
    const double sin_i = h / kRadius, i = std::asin(sin_i), t = std::asin(sin_i * n1 / n2);
    const double slope_in = -(i - t);  // angle to the axis inside the glass (toward it)
    const double sag = kRadius - std::sqrt(kRadius * kRadius - h * h);
    const double h2 = h + std::tan(slope_in) * (kThick - sag);
    const double out = std::asin(n2 * std::sin(slope_in));
    const double marginal_focus = h2 / std::tan(-out);  // behind the plane surface
    const double expected = 2.0 / 3.0 * (marginal_focus - kImage);
    std::printf("focus at infinity: film moved %.5f mm; third order 2/3 x LSA %.5f mm\n",
                cam.filmOffset_mm(), expected);
    EXPECT_LT(expected, -0.05);
    EXPECT_NEAR(cam.filmOffset_mm(), expected, 0.05 * std::abs(expected));
  }
  const std::string coaxial_scene =
      write("coaxial.pbrt", fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float "
                                        "aperturediameter\" 10 \"float filmdistance\" {:.9f}\n{}",
                                        coaxial, film_mm, common));
  const io::Image a = renderScene(placed_scene, 1).image;
  const io::Image b = renderScene(placed_scene, 2).image;
  const io::Image ref = renderScene(coaxial_scene, 3, 256).image;
  render::CompareOptions o;
  o.block = 5;
  o.second = &b;
  o.spp = 64;
  o.reference_spp = 256;
  const render::CompareResult m = render::compareImages(a, ref, o);
  std::printf("decentred by nothing vs coaxial: mean ratio %.4f, %d of %d blocks beyond z %.2f\n",
              m.mean_ratio, m.z_failures, m.blocks, m.z_bound);
  EXPECT_NEAR(m.mean_ratio, 1.0, 0.02);
  EXPECT_EQ(m.z_failures, 0);
  // The centre against pi sin^2(theta) of the coaxial lens at that film distance.
  camera::RealisticSettings cs;
  cs.lens_path = coaxial;
  cs.setup.aperture_diameter_mm = 10;
  cs.setup.film_distance_mm = film_mm;
  const camera::RealisticCamera coax(cs);
  const double sin_theta = test::realMarginalSin(*coax.lens().lens);
  double centre = 0;
  for (int y = 11; y < 19; ++y)  // +-1.1 mm: cos^4 there is 0.9986
    for (int x = 11; x < 19; ++x)
      for (int k = 0; k < 3; ++k) centre += (a.at(x, y, k) + b.at(x, y, k)) / (2 * 3 * 64);
  const double expected = std::numbers::pi * sin_theta * sin_theta;
  std::printf("flat field centre %.5f, pi sin^2 %.5f\n", centre, expected);
  EXPECT_NEAR(centre, expected, 0.02 * expected);
}

// The flat field through a lens whose rear surface is tilted (the tilted plate's back face, 20
// degrees to the film): the film centre's irradiance E = integral of L cos(theta) d(omega) over
// the directions that pass the lens, computed here by a midpoint rule over a fine grid of
// direction slopes (each traced backward through the lens, so only the camera's sampling and
// weights are under test: the disc on the tilted rear plane, its projected-area cosines). A glass
// of V_d 1e6 keeps the index the same at every wavelength of the render.
TEST(PlacedRender, FlatFieldThroughATiltedRearSurfaceMatchesTheIntegral) {
  constexpr double theta_deg = 20, t = 5;
  const double axial = t / std::cos(theta_deg * std::numbers::pi / 180);
  const std::string glass = "  GLAS ___BLANK 1 0 1.5168 1000000 0 0 0 0 0 0\n";
  std::vector<std::string> after = {plane(20, 6),
                                    coordbrk(0, 0, theta_deg, 0),
                                    plane(0, 4, glass),
                                    coordbrk(0, 0, -theta_deg, axial),
                                    coordbrk(0, 0, theta_deg, 0),
                                    plane(0, 4),
                                    coordbrk(0, 0, -theta_deg, 84)};
  std::string text = singlet("tilted_rear", 3, {}, after, 0);
  const size_t at = text.find(kGlass);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, kGlass.size(), glass);
  const std::string lens = write("tilted_rear.zmx", text);
  const optics::LensPrescription p = optics::readLensFile(lens);
  ASSERT_TRUE(p.noncoaxial_loc.has_value());
  const std::string scene = write(
      "tilted_rear.pbrt",
      fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float aperturediameter\" 6 "
                  "\"float focusdistance\" 1e6\nFilm \"rgb\" \"integer xresolution\" 30 "
                  "\"integer yresolution\" 30 \"float diagonal\" 1.2\n"
                  "Sampler \"independent\" \"integer pixelsamples\" 512\n"
                  "PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n"
                  "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n",
                  lens));
  const io::Image im = renderScene(scene, 4).image;
  double mean = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int k = 0; k < 3; ++k) mean += im.at(x, y, k) / (3.0 * im.width * im.height);
  // The integral at the film's centre: the image surface's frame is the object axis's here.
  camera::RealisticSettings settings;
  settings.setup.aperture_diameter_mm = 6;
  settings.setup.focus_distance_m = 1e6;
  const camera::PlacedRealisticCamera cam(settings, p);
  const Vec3 film{p.image_frame.origin_mm[0], p.image_frame.origin_mm[1],
                  p.image_frame.origin_mm[2] + cam.filmOffset_mm()};
  constexpr int kGrid = 600;
  constexpr double kSlope = 0.04, h = 2 * kSlope / kGrid;
  double e = 0;
  int passed = 0, edge = 0;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const double sx = -kSlope + (i + 0.5) * h, sy = -kSlope + (j + 0.5) * h;
      const Vec3 d = normalize(Vec3{sx, sy, -1});
      if (!cam.lens().traceBackward({film, d}).ok()) continue;
      ++passed;
      if (i == 0 || j == 0 || i == kGrid - 1 || j == kGrid - 1) ++edge;
      const double q = 1 + sx * sx + sy * sy;
      e += h * h / (q * q);  // cos(theta) d(omega) = dx dy / (1 + x^2 + y^2)^2
    }
  ASSERT_GT(passed, 1000);
  ASSERT_EQ(edge, 0);  // the grid holds the whole cone
  std::printf("tilted rear surface: flat field %.6f, integral %.6f (%d of %d directions pass)\n",
              mean, e, passed, kGrid * kGrid);
  // 512 spp: the mean's noise is about 0.6% (three seeds at 1024 spp: 1.0001, 0.9956, 1.0033);
  // a cosine of the tilted plane left out or doubled would be 6% off.
  EXPECT_NEAR(mean, e, 0.02 * e);
}

// The backward trace the camera uses retraces the forward one (reciprocity): a ray traced from
// the object side to the image surface and sent back from there reversed leaves the front
// surface where it entered, reversed (tilted plate and decentred lens: both media orders).
TEST(PlacedRender, BackwardTraceRetracesTheForwardOne) {
  const std::string lens = write(
      "retrace.zmx",
      singlet("retrace", 3, {coordbrk(0.2, 0.5, 0, kStopGap)},
              {plane(20, 6), coordbrk(0, 0, 15, 0), plane(0, 5, kGlass), coordbrk(0, 0, -15, 5),
               coordbrk(0, 0, 15, 0), plane(0, 5), coordbrk(-0.2, -0.5, -15, 70)},
              0));
  const optics::PlacedLens pl(optics::readLensFile(lens), 550);
  int traced = 0;
  for (double x : {-2.0, 0.0, 1.5})
    for (double y : {-2.5, 0.0, 1.0}) {
      optics::PlacedLens::Field f;
      f.angle_x_deg = 0.5, f.angle_y_deg = -1;
      const optics::Ray in = pl.fieldRay(f, {x, y});
      std::vector<Vec3> path;
      const optics::TraceResult fwd = pl.trace(in, {}, &path);
      if (!fwd.ok()) continue;
      ++traced;
      const optics::TraceResult back = pl.traceBackward({fwd.ray.origin, -1.0 * fwd.ray.direction});
      ASSERT_TRUE(back.ok());
      const Vec3 entry = path[1];  // the front surface's hit
      EXPECT_NEAR(length(back.ray.origin - entry), 0, 1e-9);
      EXPECT_NEAR(length(back.ray.direction + in.direction), 0, 1e-9);
    }
  EXPECT_GE(traced, 5);
}

// A decentred lens is a shifted lens: the 1897 double Gauss decentred 3 mm by coordinate breaks
// (scenes/lenses/decentred-double-gauss.zmx) renders the flat field over the whole 36 x 24 mm
// film as the coaxial camera renders the plain file with "lensshift" [0 3] (optics/tilt_shift.h,
// its own sampling through exit-pupil bounds) at the same film distance: per-block z-test.
TEST(PlacedRender, DecentredLensMatchesTheCoaxialCameraShifted) {
  const std::string plain = std::string(LENSIM_SHARED_DIR) + "/lenses/zmx/US00583336-2-scaled.zmx";
  if (!std::filesystem::exists(plain)) GTEST_SKIP() << plain << " not present";
  const std::string decentred =
      std::string(LENSIM_SOURCE_DIR) + "/scenes/lenses/decentred-double-gauss.zmx";
  camera::RealisticSettings settings;
  settings.setup.aperture_diameter_mm = 8.43;
  settings.setup.focus_distance_m = 3.3;
  settings.x_resolution = 30, settings.y_resolution = 20;
  settings.film_diagonal_mm = 43.3;
  const camera::PlacedRealisticCamera cam(settings, optics::readLensFile(decentred));
  const double film_mm = 42.35170011441 + cam.filmOffset_mm();  // the file's image gap + the move
  const auto scene = [&](const std::string& name, const std::string& camera_line) {
    return write(name, camera_line +
                           "\nFilm \"rgb\" \"integer xresolution\" 30 \"integer yresolution\" 20 "
                           "\"float diagonal\" 43.3\nSampler \"independent\" \"integer "
                           "pixelsamples\" 256\nPixelFilter \"box\" \"float xradius\" 0.5 "
                           "\"float yradius\" 0.5\nWorldBegin\nLightSource \"infinite\" \"rgb "
                           "L\" [1 1 1]\n");
  };
  const std::string placed = scene(
      "dg_decentred.pbrt", fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float "
                                       "aperturediameter\" 8.43 \"float focusdistance\" 3.3",
                                       decentred));
  const std::string shifted = scene(
      "dg_shifted.pbrt",
      fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float aperturediameter\" "
                  "8.43 \"float filmdistance\" {:.9f} \"float lensshift\" [0 3]",
                  plain, film_mm));
  const render::RenderResult ra = renderScene(placed, 1), rref = renderScene(shifted, 3);
  const io::Image& a = ra.image;
  const io::Image b = renderScene(placed, 2).image;
  const io::Image& ref = rref.image;
  // The sampling waste, a measurement printed for docs/lens-files.md (camera samples without a
  // ray; light reaches the whole film here): the placed camera's disc against the coaxial
  // camera's exit-pupil bounds.
  const auto waste = [](const render::RenderStats& st) {
    return double(st.no_ray_samples) / double(st.camera_samples);
  };
  std::printf(
      "camera samples without a ray: placed %.1f %%, coaxial shifted %.1f %% (%llu samples)\n",
      100 * waste(ra.stats), 100 * waste(rref.stats),
      static_cast<unsigned long long>(ra.stats.camera_samples));
  render::CompareOptions o;
  o.block = 5;
  o.second = &b;
  o.spp = 256;
  o.reference_spp = 256;
  const render::CompareResult m = render::compareImages(a, ref, o);
  std::printf("decentred vs shifted double Gauss: mean ratio %.4f, %d of %d blocks beyond z %.2f\n",
              m.mean_ratio, m.z_failures, m.blocks, m.z_bound);
  EXPECT_NEAR(m.mean_ratio, 1.0, 0.02);  // 1.0012 at 1024 spp
  EXPECT_EQ(m.z_failures, 0);
}

// What the placed camera does not model is refused at the scene's Camera line (bdpt renders as
// path, warned, as for every camera without importance).
TEST(PlacedRender, UnsupportedSettingsAreRefused) {
  const std::string lens = test::dataPath("lenses/decentred_singlet.zmx");
  auto refused = [&](const std::string& extra, const std::string& integrator,
                     const std::string& needle) {
    const std::string path = write(
        "refused.pbrt",
        fmt::format("Camera \"realistic\" \"string lensfile\" \"{}\" \"float aperturediameter\" 2 "
                    "{}\nFilm \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8 "
                    "\"float diagonal\" 2\n{}WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 "
                    "1]\n",
                    lens, extra, integrator));
    try {
      renderScene(path, 1, 1);
      ADD_FAILURE() << "accepted: " << extra << integrator;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(e.loc().line, 1) << e.what();
    }
  };
  refused("\"float filmdistance\" 90", "", "filmdistance");
  refused("\"bool flare\" true", "", "flare");
  refused("\"float lensshift\" [1 0]", "", "lenstilt/lensshift");
  refused("", "Integrator \"lighttracer\"\n", "no importance");
}

// focusdistance is measured from the film to the object (docs/conventions.md) where the object
// and image axes are parallel: the singlet made non-coaxial only by a decentred dummy surface,
// stopped to 0.4 mm, focused at 0.5 m, puts its film where an independent paraxial y-nu trace
// does for an object 0.5 m from that film (solved here by bisection) plus the third-order
// best-focus shift (2/3 of the exactly traced marginal ray's longitudinal aberration, 0.9 um
// here; tolerance 0.1 um, about 10 % of it: the camera's 6-ring grid is not a continuous disc),
// and where the coaxial camera's exact focus puts the plain file's film (0.1 um). Measuring from
// the front vertex instead would put the film 12 mm nearer.
TEST(PlacedRender, FocusDistanceIsMeasuredFromTheFilm) {
  constexpr double distance_m = 0.5, aperture_mm = 0.4;
  const std::string coaxial = write("focus_coaxial.zmx", singlet("coaxial", 5, {}, {}, kImage));
  const std::string placed =
      write("focus_dummy.zmx",
            singlet("dummy", 5, {coordbrk(0, 3, 0, 0), plane(0, 40), coordbrk(0, -3, 0, kStopGap)},
                    {}, kImage));
  ASSERT_TRUE(optics::readLensFile(placed).noncoaxial_loc.has_value());
  camera::RealisticSettings settings;
  settings.setup.aperture_diameter_mm = aperture_mm;
  settings.setup.focus_distance_m = distance_m;
  settings.x_resolution = settings.y_resolution = 30;
  settings.film_diagonal_mm = 12;
  const camera::PlacedRealisticCamera cam(settings, optics::readLensFile(placed));
  const double film_placed = kImage + cam.filmOffset_mm();  // from the rear vertex
  EXPECT_NE(cam.describe().find("from the film"), std::string::npos) << cam.describe();

  // Paraxial image distance behind the plane rear surface for an object `object_mm` in front
  // of the stop (the stop is kStopGap in front of the singlet's curved face).
  const auto image_distance = [](double object_mm) {
    const double u = 1e-3;
    const double h = u * (object_mm + kStopGap);
    const double nu = u - h * (kN - 1) / kRadius;
    const double h2 = h + kThick * nu / kN;
    return -h2 / nu;  // n' = 1 after the plane face
  };
  const auto mismatch = [&](double film_mm) {
    return image_distance(1000 * distance_m - kStopGap - kThick - film_mm) - film_mm;
  };
  double lo = kImage, hi = kImage + 100;
  ASSERT_GT(mismatch(lo), 0);
  ASSERT_LT(mismatch(hi), 0);
  for (int i = 0; i < 200; ++i) (mismatch((lo + hi) / 2) > 0 ? lo : hi) = (lo + hi) / 2;
  const double paraxial = (lo + hi) / 2;
  const double from_front_vertex = image_distance(1000 * distance_m);
  // The real marginal ray (stop edge) from the object, traced exactly in the meridional plane
  // (stop at z = 0): where it crosses the axis behind the rear vertex. Third order: over a
  // uniformly filled stop the RMS spot is smallest 2/3 of the way from the paraxial focus to it.
  const auto marginal_focus = [&](double film_mm) {
    const double object_mm = 1000 * distance_m - kStopGap - kThick - film_mm;
    const auto refract = [](Vec2 d, Vec2 n, double eta) {  // n faces the incoming ray
      const double cos_i = -(d.x * n.x + d.y * n.y);
      const double k = 1 - eta * eta * (1 - cos_i * cos_i);
      return d * eta + n * (eta * cos_i - std::sqrt(k));
    };
    Vec2 p{-object_mm, 0};  // (z, y)
    Vec2 d = Vec2{object_mm, aperture_mm / 2} * (1 / std::hypot(object_mm, aperture_mm / 2));
    const Vec2 centre{kStopGap + kRadius, 0};
    const Vec2 pc = p - centre;
    const double b = pc.x * d.x + pc.y * d.y, c = pc.x * pc.x + pc.y * pc.y - kRadius * kRadius;
    p = p + d * (-b - std::sqrt(b * b - c));
    d = refract(d, (p - centre) * (1 / kRadius), 1 / kN);
    p = p + d * ((kStopGap + kThick - p.x) / d.x);
    d = refract(d, Vec2{-1, 0}, kN);
    return p.x - p.y * d.x / d.y - (kStopGap + kThick);
  };
  const double best_third_order = paraxial + 2.0 / 3.0 * (marginal_focus(film_placed) - paraxial);

  camera::RealisticSettings cs;
  cs.lens_path = coaxial;
  cs.setup.aperture_diameter_mm = aperture_mm;
  cs.setup.focus_distance_m = distance_m;
  cs.setup.focus_method = optics::FocusMethod::Exact;
  const camera::RealisticCamera coax(cs);
  const double film_coaxial = coax.lens().lens->filmDistance_mm();
  std::printf(
      "focus at %g m from the film: placed %.7f mm, coaxial exact %.7f mm, paraxial %.7f mm "
      "behind the rear vertex; paraxial + 2/3 LSA %.7f mm (measured from the front vertex: "
      "%.4f mm)\n",
      distance_m, film_placed, film_coaxial, paraxial, best_third_order, from_front_vertex);
  EXPECT_NEAR(film_placed, best_third_order, 1e-4);
  EXPECT_NEAR(film_placed, film_coaxial, 1e-4);
  EXPECT_GT(std::abs(from_front_vertex - paraxial), 1.0);  // the test tells the conventions apart

  // An object closer than the film-to-front-vertex distance is refused, not traced; so is one
  // closer than the lens focuses (object-to-image distance under about 4f).
  const auto refused = [&](double d, const std::string& needle) {
    settings.setup.focus_distance_m = d;
    try {
      camera::PlacedRealisticCamera c(settings, optics::readLensFile(placed));
      ADD_FAILURE() << "focusdistance " << d << " accepted: film moved " << c.filmOffset_mm();
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  refused(0.08, "behind the lens's front vertex");
  refused(0.3, "closer than this lens focuses");
}

// A lens whose image surface's axis is not parallel to the object space's (the 20-degree plate
// left tilted: no net untilt before the image) has no line from the film to the object: its
// focusdistance stays measured from the front vertex, and describe() says so.
TEST(PlacedRender, FoldedLensFocusesFromTheFrontVertex) {
  const std::vector<std::string> after = {plane(20, 6), coordbrk(0, 0, 20, 0), plane(5, 3, kGlass),
                                          plane(84, 3)};
  const std::string lens = write("tilted_image.zmx", singlet("tilted", 1, {}, after, 0));
  ASSERT_TRUE(optics::readLensFile(lens).noncoaxial_loc.has_value());
  camera::RealisticSettings settings;
  settings.setup.aperture_diameter_mm = 2;
  settings.setup.focus_distance_m = 1;
  settings.x_resolution = settings.y_resolution = 16;
  settings.film_diagonal_mm = 2;
  const camera::PlacedRealisticCamera cam(settings, optics::readLensFile(lens));
  EXPECT_NE(cam.describe().find("from the front vertex"), std::string::npos) << cam.describe();
}
