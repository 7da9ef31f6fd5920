// Lens flare on a raw (sensor) film (issue 31, docs/flare.md "Raw films"): the ghosts are light
// on the sensor like the direct image, so they reach the DN through the same photons-to-electrons
// conversion, CFA and noise (applied once). Checked against the RGB film's ghost irradiance turned
// into electrons by docs/sensor.md's S = integral E A F t QE lambda / (h c) d lambda, written here
// with the CIE y-bar of Wyman, Sloan & Shirley (JCGT 2013, the multi-lobe fit) and Planck's law;
// the DNG's mosaic is read back by dcraw.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/renderer.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/scene/description.h"
#include "test_paths.h"

namespace fs = std::filesystem;
using namespace lensim;

namespace {

fs::path tempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() /
                     ("lensim_flare_sensor_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string run(const std::string& cmd, int* status) {
  std::string out;
  FILE* p = popen((cmd + " 2>/dev/null").c_str(), "r");
  if (!p) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int st = pclose(p);
  *status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return out;
}

/// A 16-bit binary PGM (P5, big-endian) as `dcraw -D -4 -c` writes it.
std::vector<int> parsePgm(const std::string& s, int& w, int& h) {
  std::istringstream in(s);
  std::string magic;
  int maxv = 0;
  in >> magic >> w >> h >> maxv;
  in.get();
  std::vector<int> v;
  if (magic != "P5" || maxv < 256) return v;
  for (int i = 0; i < w * h; ++i) {
    const int hi = in.get(), lo = in.get();
    if (lo < 0) return {};
    v.push_back(hi << 8 | lo);
  }
  return v;
}

/// CIE 1931 y-bar, the multi-lobe piecewise-Gaussian fit of Wyman, Sloan & Shirley (2013).
double ybar(double lambda_nm) {
  const auto g = [](double x, double mu, double t1, double t2) {
    const double t = (x - mu) * (x < mu ? t1 : t2);
    return std::exp(-0.5 * t * t);
  };
  return 0.821 * g(lambda_nm, 568.8, 0.0213, 0.0247) + 0.286 * g(lambda_nm, 530.9, 0.0613, 0.0322);
}

/// Planck's spectral radiance at temperature t (arbitrary scale).
double planck(double lambda_nm, double t) {
  const double l = lambda_nm * 1e-9;
  return 1 / (std::pow(l, 5) * (std::exp(1.438776877e-2 / (l * t)) - 1));
}

constexpr double kH = 6.62607015e-34, kC = 299792458;
constexpr int kXres = 64, kYres = 48;
constexpr double kTemperature = 5000, kQe = 0.5, kNits = 1e-2, kPitchUm = 20;
constexpr double kQeMin = 400, kQeMax = 700;
constexpr int kBlack = 512;

/// A small 5000 K light 10 degrees off the axis of the uncoated double Gauss (flare on): its
/// ghosts fall on pixels the direct image does not reach. `film`: the Film line.
std::string writeScene(const fs::path& dir, const std::string& name, const std::string& film) {
  const double theta = 10 * std::numbers::pi / 180, delta = 2 * std::numbers::pi / 180;
  const std::string path = (dir / name).string();
  std::ofstream f(path);
  f << "LookAt 0 0 0  0 0 1  0 1 0\n"
    << "Camera \"realistic\" \"string lensfile\" \"" << test::lensPath("dgauss.50mm.dat")
    << "\" \"float aperturediameter\" 12 \"float focusdistance\" 10 \"bool flare\" true\n"
    << film << " \"integer xresolution\" " << kXres << " \"integer yresolution\" " << kYres
    << " \"float diagonal\" 43.3 \"float iso\" 100\n"
    << "Sampler \"independent\" \"integer pixelsamples\" 64\n"
    << "Integrator \"path\" \"integer maxdepth\" 1\n"
    << "WorldBegin\nAttributeBegin\nTranslate " << 10 * std::sin(theta) << " 0 "
    << 10 * std::cos(theta) << "\nAreaLightSource \"diffuse\" \"blackbody L\" [" << kTemperature
    << "] \"float scale\" 250\nShape \"sphere\" \"float radius\" " << 10 * std::sin(delta)
    << "\nAttributeEnd\n";
  return path;
}

}  // namespace

// The same scene on Film "rgb" and Film "raw" (same seed: the same paths). In the ghost region
// (pixels the direct image does not reach, ghost luminance above a fifth of its peak) the DNG's
// DN less the black level, read by dcraw, sum to the electrons docs/sensor.md's conversion gives
// for the RGB film's ghost irradiance: with a flat QE q over [400, 700] nm, unit gain (ISO = base
// ISO, 1 e-/DN) and no dark current,
//   S = (Y / imaging ratio) nits / 683 A t q / (h c) int_400^700 B lambda / int B ybar,
// Y the RGB film's ghost luminance (Rec. 709 weights of its linear sRGB). The temporal noise is
// on (Poisson, read noise): it averages out over the region. The raw EXR's ghost layer
// (noise-free electrons) gives the same sum.
TEST(FlareSensor, RawGhostSignalIsTheRgbGhostIrradianceThroughTheSensor) {
  const fs::path d = tempDir("raw");
  {
    std::ofstream qe(d / "qe.csv");
    qe << "# flat QE, the same for R, G and B\n"
       << kQeMin << ", " << kQe << ", " << kQe << ", " << kQe << "\n"
       << kQeMax << ", " << kQe << ", " << kQe << ", " << kQe << "\n";
  }
  render::RenderOptions o;
  o.seed = 3;
  o.threads = 2;
  o.progress = false;
  const io::Image rgb =
      render::render(scene::loadScene(writeScene(d, "rgb.pbrt", "Film \"rgb\"")), o).image;
  const std::string raw_film = fmt::format(
      "Film \"raw\" \"string qe\" \"qe.csv\" \"string cfa\" \"RGGB\" \"float nits\" {} "
      "\"float pixelpitch\" {} \"float baseiso\" 100 \"float conversiongain\" 1 "
      "\"float darkcurrent\" 0 \"integer adcbits\" 16 \"integer blacklevel\" {} "
      "\"float fullwell\" 1e6",
      kNits, kPitchUm, kBlack);
  const render::RenderResult raw =
      render::render(scene::loadScene(writeScene(d, "raw.pbrt", raw_film)), o);
  ASSERT_EQ(rgb.channelCount(), 6);
  ASSERT_EQ(raw.image.channelCount(), 6);
  const std::string dng = (d / "flare.dng").string(), exr = (d / "flare.exr").string();
  render::writeRawImage(dng, raw.image, 0, 0);
  render::writeRawImage(exr, raw.image, 0, 0);

  // dcraw decodes the DNG (the mosaic in DN).
  int st = -1, w = 0, h = 0;
  const std::vector<int> dn = parsePgm(run("dcraw -D -4 -c " + dng, &st), w, h);
  ASSERT_EQ(st, 0);
  ASSERT_EQ(w, kXres);
  ASSERT_EQ(h, kYres);
  ASSERT_EQ(dn.size(), size_t(w * h));
  const io::Image ex = io::readImage(exr);
  const auto ghost_g = ex.channelIndex("ghost.G");
  ASSERT_TRUE(ghost_g.has_value());

  // Electrons per unit of the RGB film's luminance (imaging ratio 1: ISO 100, 1 s).
  double num = 0, den = 0;
  for (double l = 360; l <= 830; l += 0.05) {
    const double b = planck(l, kTemperature);
    den += b * ybar(l) * 0.05;
    if (l >= kQeMin && l <= kQeMax) num += b * l * 1e-9 * 0.05;
  }
  const double area = kPitchUm * kPitchUm * 1e-12;
  const double e_per_y = kNits / 683 * area * 1.0 * kQe / (kH * kC) * num / den;

  auto luminance = [](const io::Image& im, int x, int y, int c0) {
    return 0.212639 * im.at(x, y, c0) + 0.715169 * im.at(x, y, c0 + 1) +
           0.072192 * im.at(x, y, c0 + 2);
  };
  double peak = 0;
  for (int y = 0; y < kYres; ++y)
    for (int x = 0; x < kXres; ++x) peak = std::max(peak, luminance(rgb, x, y, 3));
  double want = 0, got_dn = 0, got_exr = 0;
  int pixels = 0;
  for (int y = 0; y < kYres; ++y)
    for (int x = 0; x < kXres; ++x) {
      const double g = luminance(rgb, x, y, 3), all = luminance(rgb, x, y, 0);
      if (g < 0.2 * peak || all - g > 1e-9 * peak) continue;  // not ghost, or direct light too
      ++pixels;
      want += g * e_per_y;
      got_dn += dn[size_t(y * w + x)] - kBlack;
      got_exr += ex.at(x, y, *ghost_g);
    }
  std::printf(
      "ghost region: %d pixels, peak ghost luminance %.4g; electrons from the RGB film %.6g, "
      "DN - black (dcraw) %.6g (%+.3f %%), raw EXR ghost layer %.6g (%+.3f %%)\n",
      pixels, peak, want, got_dn, 100 * (got_dn / want - 1), got_exr, 100 * (got_exr / want - 1));
  ASSERT_GE(pixels, 20);
  EXPECT_GT(want / pixels, 500);  // a signal well above the read noise and the DN's rounding
  EXPECT_NEAR(got_dn, want, 0.03 * want);
  EXPECT_NEAR(got_exr, want, 0.03 * want);
}

// A raw flare render split in two sample slices and merged (the parts hold the noise-free
// electrons, ghosts included; merge applies the sensor's noise once) writes the same DNG, byte
// for byte, as the whole render.
TEST(FlareSensor, RawFlarePartsMergeToTheWholeRendersDng) {
  const fs::path d = tempDir("parts");
  {
    std::ofstream qe(d / "qe.csv");
    qe << kQeMin << ", " << kQe << ", " << kQe << ", " << kQe << "\n"
       << kQeMax << ", " << kQe << ", " << kQe << ", " << kQe << "\n";
  }
  const std::string scene = writeScene(
      d, "raw.pbrt",
      fmt::format("Film \"raw\" \"string qe\" \"qe.csv\" \"float nits\" {} \"float pixelpitch\" {}",
                  kNits, kPitchUm));
  auto file = [&](const char* name) { return (d / name).string(); };
  const std::string render =
      std::string(LENSIM_BINARY) + " --quiet render " + scene + " --spp 8 --threads 2 ";
  int st = -1;
  for (const std::string& cmd :
       {render + "-o " + file("whole.dng"), render + "--spp-range 0:3 -o " + file("a.exr"),
        render + "--spp-range 3:8 -o " + file("b.exr"),
        std::string(LENSIM_BINARY) + " --quiet merge " + file("m.dng") + " " + file("a.exr") + " " +
            file("b.exr")}) {
    run(cmd, &st);
    ASSERT_EQ(st, 0) << cmd;
  }
  auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const std::string whole = bytes(file("whole.dng")), merged = bytes(file("m.dng"));
  EXPECT_GT(whole.size(), 1000u);
  EXPECT_TRUE(whole == merged);
  // The parts carry the ghost layer (read back as a part would be by merge).
  EXPECT_NE(bytes(file("a.exr")).find("ghost.sum.G.0"), std::string::npos);
}
