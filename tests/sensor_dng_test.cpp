// Raw DNG files from Film "raw" (issue 34) read by real third-party clients: dcraw and LibRaw's
// raw-identify decode the mosaic bit for bit and report the written metadata (white level,
// exposure, the lens of the realistic camera against a paraxial trace written here); darktable-cli
// opens the file; a split render merged by lensim merge has the very same noisy raw values.
// Other CFA patterns: sensor_dng_cfa_test.cpp; colour: sensor_dng_color_test.cpp.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/io/dng.h"
#include "lensim/io/image.h"
#include "lensim/render/sensor/develop.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/render/sensor/sensor_color.h"
#include "lensim/render/sensor/sensor_model.h"
#include "sensor_dng_util.h"

using namespace lensim;
using namespace lensim::render;
using namespace lensim::test::dng;

TEST(SensorDng, DcrawAndLibRawDecodeTheMosaicBitForBit) {
  const std::string dir = tmpDir("mosaic");
  for (const char* cfa : {"RGGB", "BGGR", "GRBG", "GBRG"})
    for (const auto& [x0, y0] : std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {0, 1}, {3, 5}}) {
      SensorConfig cfg;
      cfg.cfa = cfa;
      cfg.seed = 5;
      cfg.read_noise_e = 3;
      const io::Image im = electronImage(40, 30, cfg);
      const std::string path = dir + "/m.dng";
      writeRawImage(path, im, x0, y0);
      int st = -1, w = 0, h = 0;
      const std::string pgm = run("dcraw -D -4 -c " + path, &st);
      ASSERT_EQ(st, 0) << pgm;
      const std::vector<uint16_t> got = parsePgm(pgm, w, h);
      ASSERT_EQ(w, 40);
      ASSERT_EQ(h, 30);
      EXPECT_EQ(got, expectedDn(im, cfg, x0, y0)) << cfa << " at " << x0 << "," << y0;
      // LibRaw: the CFA pattern of the written window, the black level and the colour matrix.
      const std::string info = run("raw-identify -v " + path, &st);
      ASSERT_EQ(st, 0) << info;
      const CfaPattern layout = parseCfa(cfa);
      std::string pattern;
      for (int k = 0; k < 4; ++k) pattern += "RGB"[cfaChannel(layout, x0 + (k & 1), y0 + (k >> 1))];
      EXPECT_NE(info.find("Filter pattern: " + pattern), std::string::npos)
          << cfa << " " << x0 << "," << y0 << ": expected " << pattern << "\n" << info;
      EXPECT_NE(info.find("black: 512"), std::string::npos) << info;
      EXPECT_NE(info.find("DNG Illuminant 2: D65"), std::string::npos) << info;
      // ColorMatrix2 as LibRaw prints it (4 decimals).
      const DngColor col = fitDngColor(SensorModel(cfg), 0);
      const size_t at = info.find("DNG color matrix 2:");
      ASSERT_NE(at, std::string::npos) << info;
      std::istringstream cm(info.substr(at + 19));
      for (int i = 0; i < 9; ++i) {
        double v = 0;
        cm >> v;
        EXPECT_NEAR(v, col.color_matrix2[size_t(i)], 1.5e-4) << "ColorMatrix2[" << i << "]";
      }
    }
}

TEST(SensorDng, WhiteLevelExposureAndLensInLibRaw) {
  const std::string dir = tmpDir("meta");
  SensorConfig cfg;
  cfg.adc_bits = 12;
  cfg.black_level_dn = 256;
  cfg.exposure_s = 0.004;
  cfg.iso = 400;
  io::Image im = electronImage(32, 24, cfg);  // LibRaw refuses images under 22 pixels
  im.metadata[kRawFNumberKey] = "5.6";
  im.metadata[kRawFocalKey] = "50";
  im.metadata[kRawLensKey] = "dgauss.50mm.dat";
  const std::string path = dir + "/meta.dng";
  writeRawImage(path, im, 0, 0);
  int st = -1;
  const std::string info = run("raw-identify -v " + path, &st);
  ASSERT_EQ(st, 0);
  EXPECT_NE(info.find("ISO speed: 400"), std::string::npos) << info;
  EXPECT_NE(info.find("Shutter: 1/250.0"), std::string::npos) << info;
  EXPECT_NE(info.find("Aperture: f/5.6"), std::string::npos) << info;
  EXPECT_NE(info.find("Focal length: 50.0 mm"), std::string::npos) << info;
  EXPECT_NE(info.find("Lens: dgauss.50mm.dat"), std::string::npos) << info;
  EXPECT_NE(info.find("black: 256"), std::string::npos) << info;
  // The white level: a saturated frame decodes to WhiteLevel (2^12 - 1) everywhere.
  io::Image sat = im;
  for (float& v : sat.pixels) v = 1e7f;
  writeRawImage(path, sat, 0, 0);
  int w = 0, h = 0;
  const std::vector<uint16_t> got = parsePgm(run("dcraw -D -4 -c " + path, &st), w, h);
  ASSERT_FALSE(got.empty());
  for (uint16_t v : got) EXPECT_EQ(v, 4095);
}

TEST(SensorDng, MonochromeDngDecodes) {
  const std::string dir = tmpDir("mono");
  SensorConfig cfg;
  cfg.cfa = "mono";
  const io::Image im = electronImage(24, 24, cfg);
  const std::string path = dir + "/mono.dng";
  writeRawImage(path, im, 0, 0);
  int st = -1, w = 0, h = 0;
  const std::vector<uint16_t> got = parsePgm(run("dcraw -D -4 -c " + path, &st), w, h);
  ASSERT_EQ(st, 0);
  EXPECT_EQ(got, expectedDn(im, cfg, 0, 0));
}

TEST(SensorDng, DarktableDevelopsTheDng) {
  if (std::system("command -v darktable-cli >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "darktable-cli is not installed (scripts/install-deps installs it)";
  const std::string dir = tmpDir("darktable");
  SensorConfig cfg;
  const io::Image im = electronImage(32, 32, cfg);
  const std::string path = dir + "/dt.dng", out = dir + "/dt.png";
  std::filesystem::remove(out);
  writeRawImage(path, im, 0, 0);
  int st = -1;
  const std::string log = run("timeout 60 darktable-cli " + path + " " + out +
                                  " --core --configdir " + dir + "/config --library :memory:",
                              &st);
  ASSERT_EQ(st, 0) << log;
  const io::Image dev = io::readImage(out);
  EXPECT_EQ(dev.width, 32);
  EXPECT_EQ(dev.height, 32);
}

TEST(SensorDng, SplitRenderMergedHasTheSameNoiseAsOneRender) {
  // Film "raw" through the CLI: the whole image with 1 and 2 threads, and two tiles merged by
  // lensim merge, give the very same noisy raw values (the noise is applied once, per pixel
  // position, at write or merge time).
  const std::string dir = tmpDir("split");
  const std::string scene = dir + "/raw.pbrt";
  {
    std::ofstream f(scene);
    f << "LookAt 0 0 0  0 0 1  0 1 0\n"
         "Camera \"perspective\" \"float fov\" 40\n"
         "Sampler \"independent\" \"integer pixelsamples\" 4 \"integer seed\" 9\n"
         "Film \"raw\" \"integer xresolution\" 32 \"integer yresolution\" 24\n"
         "  \"float nits\" 0.05 \"float fnumber\" 2.8 \"float readnoise\" 3 \"float prnu\" 0.01\n"
         "  \"float dsnu\" 2 \"string cfa\" \"GRBG\"\n"
         "WorldBegin\n"
         "LightSource \"infinite\" \"blackbody L\" [5000]\n"
         "LightSource \"point\" \"blackbody I\" [3000] \"float scale\" 2\n"
         "Material \"diffuse\" \"rgb reflectance\" [0.8 0.3 0.2]\n"
         "Shape \"sphere\" \"float radius\" 1\n";  // seen from inside, lit by the point light
  }
  using lensim::test::runLensim;
  auto decode = [&](const std::string& dng) {
    int st = -1, w = 0, h = 0;
    const auto v = parsePgm(run("dcraw -D -4 -c " + dng, &st), w, h);
    EXPECT_EQ(st, 0) << dng;
    return v;
  };
  auto r = runLensim("render -q --threads 1 " + scene + " -o " + dir + "/one.dng");
  ASSERT_EQ(r.status, 0) << r.out;
  r = runLensim("render -q --threads 2 " + scene + " -o " + dir + "/two.dng");
  ASSERT_EQ(r.status, 0) << r.out;
  for (int t = 0; t < 2; ++t) {
    r = runLensim("render -q --tile " + std::to_string(t) + "/2 " + scene + " -o " + dir +
                  "/part" + std::to_string(t) + ".exr");
    ASSERT_EQ(r.status, 0) << r.out;
  }
  r = runLensim("merge -q " + dir + "/merged.dng " + dir + "/part0.exr " + dir + "/part1.exr");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto one = decode(dir + "/one.dng");
  ASSERT_EQ(one.size(), 32u * 24u);
  EXPECT_EQ(decode(dir + "/two.dng"), one);
  EXPECT_EQ(decode(dir + "/merged.dng"), one);
  // The image is not flat black: some signal above the black level.
  int lit = 0;
  for (uint16_t v : one) lit += v > 512 + 50;
  EXPECT_GT(lit, 100);
  // The EXR output carries the noise-free electrons and the same DN.
  r = runLensim("render -q " + scene + " -o " + dir + "/one.exr");
  ASSERT_EQ(r.status, 0) << r.out;
  const io::Image exr = io::readImage(dir + "/one.exr");
  const auto dn = exr.channelIndex("DN");
  ASSERT_TRUE(dn.has_value());
  ASSERT_TRUE(exr.channelIndex("electrons").has_value());
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x)
      ASSERT_EQ(exr.at(x, y, *dn), float(one[size_t(y * 32 + x)])) << x << "," << y;
  // Bad output and bad parameters are refused with the file and the value.
  r = runLensim("render -q " + scene + " -o " + dir + "/x.png");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find(".dng or .exr"), std::string::npos) << r.out;
  const std::string bad = dir + "/bad.pbrt";
  {
    std::ofstream f(bad);
    f << "Film \"raw\" \"integer adcbits\" 20\nWorldBegin\n";
  }
  r = runLensim("render -q " + bad + " -o " + dir + "/bad.dng");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("bad.pbrt:1:1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"adcbits\": 20"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.dng"));
  // A QE file travels with the parts: lensim merge does not need it.
  {
    std::ofstream q(dir + "/qe_ok.csv");
    q << "400, 0.1, 0.2, 0.3\n550, 0.2, 0.6, 0.2\n700, 0.5, 0.1, 0.05\n";
    std::ifstream in(scene);
    std::stringstream text;
    text << in.rdbuf();
    std::string t = text.str();
    t.replace(t.find("\"string cfa\""), 0, "\"string qe\" \"qe_ok.csv\" ");
    std::ofstream f(dir + "/qe.pbrt");
    f << t;
  }
  r = runLensim("render -q " + dir + "/qe.pbrt -o " + dir + "/qe_one.dng");
  ASSERT_EQ(r.status, 0) << r.out;
  for (int t = 0; t < 2; ++t) {
    r = runLensim("render -q --tile " + std::to_string(t) + "/2 " + dir + "/qe.pbrt -o " + dir +
                  "/qe_part" + std::to_string(t) + ".exr");
    ASSERT_EQ(r.status, 0) << r.out;
  }
  std::filesystem::remove(dir + "/qe_ok.csv");
  r = runLensim("merge -q " + dir + "/qe_merged.dng " + dir + "/qe_part0.exr " + dir +
                "/qe_part1.exr");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(decode(dir + "/qe_merged.dng"), decode(dir + "/qe_one.dng"));
  EXPECT_NE(decode(dir + "/qe_one.dng"), one);
  // A QE file beside the scene, with a bad value: its row and column.
  {
    std::ofstream q(dir + "/qe.csv");
    q << "# lambda_nm, qe_r, qe_g, qe_b\n400, 0.1, 0.2, 0.3\n700, 0.1, 1.2, 0.3\n";
    std::ofstream f(bad);
    f << "Film \"raw\" \"string qe\" \"qe.csv\"\nWorldBegin\n";
  }
  r = runLensim("render -q " + bad + " -o " + dir + "/bad.dng");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("qe.csv:3:11: error: quantum efficiency 1.2"), std::string::npos) << r.out;
  // A DNG needs Film "raw".
  {
    std::ofstream f(bad);
    f << "Film \"rgb\"\nWorldBegin\n";
  }
  r = runLensim("render -q " + bad + " -o " + dir + "/bad.dng");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.dng"));
}

namespace {

// Paraxial y-nu trace of a pbrt lens file (radius, thickness, index, aperture; radius 0 the
// stop), written here independently of lensim's optics: the effective focal length and the
// f-number at infinity for a stop of diameter `stop_mm` (EFL / entrance pupil diameter).
std::pair<double, double> paraxialEflAndFNumber(const std::string& file, double stop_mm) {
  std::ifstream in(file);
  double y = 1, nu = 0, n = 1, y_stop = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double r = 0, t = 0, idx = 0, ap = 0;
    if (!(ss >> r >> t >> idx >> ap)) continue;
    const double n2 = idx == 0 ? 1 : idx, c = r == 0 ? 0 : 1 / r;
    if (r == 0) y_stop = y;
    nu -= y * c * (n2 - n);
    y += t * nu / n2;
    n = n2;
  }
  const double efl = -1 / nu;
  return {efl, efl / (stop_mm / y_stop)};
}

}  // namespace

TEST(SensorDng, ExifLensFromTheRealisticCamera) {
  const std::string dir = tmpDir("exif");
  const std::string lens = std::string(LENSIM_SOURCE_DIR) + "/lenses/dgauss.50mm.dat";
  // pbrt-v3/v4's realistic camera and pbrt-v2's (CS348B: specfile, filmdistance,
  // aperture_diameter, millimetres), whose lens is the same.
  for (const bool v2 : {false, true})
    for (double stop : {12.5, 6.0}) {
      const auto [efl, fnum] = paraxialEflAndFNumber(lens, stop);
      const std::string scene = dir + "/e.pbrt";
      {
        std::ofstream f(scene);
        if (v2)
          f << "Camera \"realistic\" \"string specfile\" \"" << lens
            << "\" \"float filmdistance\" 36.77 \"float aperture_diameter\" " << stop
            << " \"float filmdiag\" 43.27\n";
        else
          f << "Camera \"realistic\" \"string lensfile\" \"" << lens
            << "\" \"float aperturediameter\" " << stop << " \"float focusdistance\" 3\n";
        f << "Sampler \"independent\" \"integer pixelsamples\" 1\n"
             "Film \"raw\" \"integer xresolution\" 36 \"integer yresolution\" 24\n"
             "WorldBegin\nLightSource \"infinite\"\n";
      }
      for (const char* ext : {"dng", "exr"}) {
        const std::string out = dir + "/e." + ext;
        const auto r = lensim::test::runLensim("render -q " + scene + " -o " + out);
        ASSERT_EQ(r.status, 0) << r.out;
        if (std::string(ext) == "exr") {
          const io::Image im = io::readImage(out);
          EXPECT_NEAR(std::stod(im.metadata.at(kRawFocalKey)), efl, 1e-6 * efl) << v2;
          EXPECT_NEAR(std::stod(im.metadata.at(kRawFNumberKey)), fnum, 1e-6 * fnum) << v2;
          EXPECT_EQ(im.metadata.at(kRawLensKey), "D-GAUSS F/2 22deg HFOV") << v2;
          continue;
        }
        int st = -1;
        const std::string info = run("raw-identify -v " + out, &st);
        ASSERT_EQ(st, 0) << info;
        EXPECT_NE(info.find(fmt::format("Aperture: f/{:.1f}\n", fnum)), std::string::npos)
            << "f/" << fnum << "\n"
            << info;
        EXPECT_NE(info.find(fmt::format("Focal length: {:.1f} mm\n", efl)), std::string::npos)
            << efl << "\n"
            << info;
        EXPECT_NE(info.find("\tLens: D-GAUSS F/2 22deg HFOV\n"), std::string::npos) << info;
      }
    }
  // A pinhole camera has no lens: no focal length, f-number or lens name.
  const std::string scene = dir + "/p.pbrt";
  {
    std::ofstream f(scene);
    f << "Camera \"perspective\"\nSampler \"independent\" \"integer pixelsamples\" 1\n"
         "Film \"raw\" \"integer xresolution\" 36 \"integer yresolution\" 24 \"float fnumber\" 2\n"
         "WorldBegin\nLightSource \"infinite\"\n";
  }
  const auto r = lensim::test::runLensim("render -q " + scene + " -o " + dir + "/p.dng");
  ASSERT_EQ(r.status, 0) << r.out;
  int st = -1;
  const std::string info = run("raw-identify -v " + dir + "/p.dng", &st);
  ASSERT_EQ(st, 0) << info;
  EXPECT_NE(info.find("Aperture: f/0.0\n"), std::string::npos) << info;
  EXPECT_NE(info.find("Focal length: 0.0 mm\n"), std::string::npos) << info;
  const size_t lens_at = info.find("\tLens: ");
  ASSERT_NE(lens_at, std::string::npos) << info;
  EXPECT_EQ(info.substr(lens_at, 8), "\tLens: \n") << info;
}
