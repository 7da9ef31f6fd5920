// Raw DNG files from Film "raw" (issue 34) read by real third-party clients: dcraw and LibRaw's
// raw-identify decode the mosaic bit for bit and report the written metadata; dcraw_emu
// develops a ColorChecker (the shared Ohta 1997 reflectances, independent of the Pascale data
// the colour matrices are fitted to) to within a mean CIEDE2000 of 3; darktable-cli opens the
// file; a split render merged by lensim merge has the very same noisy raw values.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
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

namespace {

// CIE L*a*b* of XYZ relative to the white (Xn, Yn, Zn).
std::array<double, 3> lab(const Vec3& xyz, const Vec3& white) {
  auto f = [](double t) {
    return t > 216.0 / 24389 ? std::cbrt(t) : (24389.0 / 27 * t + 16) / 116;
  };
  const double fx = f(xyz.x / white.x), fy = f(xyz.y / white.y), fz = f(xyz.z / white.z);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

// CIEDE2000 (Sharma, Wu and Dalal, Color Res. Appl. 30, 2005), written out from the paper.
double deltaE2000(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  const double kPi = M_PI;
  const double L1 = p[0], a1 = p[1], b1 = p[2], L2 = q[0], a2 = q[1], b2 = q[2];
  const double C1 = std::hypot(a1, b1), C2 = std::hypot(a2, b2), Cm = (C1 + C2) / 2;
  const double G = 0.5 * (1 - std::sqrt(std::pow(Cm, 7) / (std::pow(Cm, 7) + std::pow(25.0, 7))));
  const double a1p = (1 + G) * a1, a2p = (1 + G) * a2;
  const double C1p = std::hypot(a1p, b1), C2p = std::hypot(a2p, b2);
  auto hue = [&](double b, double a) {
    if (a == 0 && b == 0) return 0.0;
    double h = std::atan2(b, a) * 180 / kPi;
    return h < 0 ? h + 360 : h;
  };
  const double h1p = hue(b1, a1p), h2p = hue(b2, a2p);
  const double dLp = L2 - L1, dCp = C2p - C1p;
  double dhp = 0;
  if (C1p * C2p != 0) {
    dhp = h2p - h1p;
    if (dhp > 180) dhp -= 360;
    if (dhp < -180) dhp += 360;
  }
  const double dHp = 2 * std::sqrt(C1p * C2p) * std::sin(dhp / 2 * kPi / 180);
  const double Lpm = (L1 + L2) / 2, Cpm = (C1p + C2p) / 2;
  double hpm = h1p + h2p;
  if (C1p * C2p != 0) {
    if (std::abs(h1p - h2p) <= 180)
      hpm = (h1p + h2p) / 2;
    else
      hpm = (h1p + h2p < 360) ? (h1p + h2p + 360) / 2 : (h1p + h2p - 360) / 2;
  }
  const double T = 1 - 0.17 * std::cos((hpm - 30) * kPi / 180) +
                   0.24 * std::cos(2 * hpm * kPi / 180) +
                   0.32 * std::cos((3 * hpm + 6) * kPi / 180) -
                   0.20 * std::cos((4 * hpm - 63) * kPi / 180);
  const double dTheta = 30 * std::exp(-std::pow((hpm - 275) / 25, 2));
  const double Rc = 2 * std::sqrt(std::pow(Cpm, 7) / (std::pow(Cpm, 7) + std::pow(25.0, 7)));
  const double Sl = 1 + 0.015 * std::pow(Lpm - 50, 2) / std::sqrt(20 + std::pow(Lpm - 50, 2));
  const double Sc = 1 + 0.045 * Cpm, Sh = 1 + 0.015 * Cpm * T;
  const double Rt = -std::sin(2 * dTheta * kPi / 180) * Rc;
  return std::sqrt(std::pow(dLp / Sl, 2) + std::pow(dCp / Sc, 2) + std::pow(dHp / Sh, 2) +
                   Rt * (dCp / Sc) * (dHp / Sh));
}

// The 24 patches of the shared Ohta (1997) reflectance table.
std::vector<PiecewiseLinearSpectrum> ohtaPatches() {
  std::ifstream in(std::string(LENSIM_SHARED_DIR) + "/data/colorchecker/colorchecker-ohta1997.csv");
  std::vector<double> lambda;
  std::vector<std::vector<double>> refl(24);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string v;
    std::getline(ss, v, ',');
    lambda.push_back(std::stod(v));
    for (int i = 0; i < 24 && std::getline(ss, v, ','); ++i) refl[size_t(i)].push_back(std::stod(v));
  }
  std::vector<PiecewiseLinearSpectrum> out;
  for (const auto& r : refl) out.emplace_back(lambda, r);
  return out;
}

class Product final : public Spectrum {
 public:
  Product(const Spectrum& a, const Spectrum& b) : a_(a), b_(b) {}
  double eval(double l) const override { return a_.eval(l) * b_.eval(l); }
  double maxValue() const override { return a_.maxValue() * b_.maxValue(); }

 private:
  const Spectrum &a_, &b_;
};

// The chart lit by D65 as a sensor with the CFA `cfa` records it (noise on), written as a DNG,
// developed by LibRaw's dcraw_emu (as-shot white balance, AHD demosaic for three colours, VNG for
// four, the DNG's ColorMatrix2 to linear sRGB), against the patches' colours computed here from
// the same reflectances and the CIE 1931 observer; exposure normalised on the white patch. The
// mean CIEDE2000 over the 24 patches, and the largest in `worst`.
double dcrawEmuChartDeltaE(const std::string& cfa, double* worst_out) {
  const std::vector<PiecewiseLinearSpectrum> patches = ohtaPatches();
  EXPECT_EQ(patches.size(), 24u);
  if (patches.size() != 24) return 1e9;
  const std::shared_ptr<const Spectrum> d65 = daylightIlluminant(6500);
  SensorConfig cfg;
  cfg.cfa = cfa;
  cfg.seed = 3;
  const SensorModel m(cfg);
  const auto white = m.expectedElectrons(Product(patches[18], *d65));
  // The white patch at 40000 e- in its brightest pixel (a W pixel: the channels' sum).
  const double scale = 40000 / (m.cfa().hasW() ? white[0] + white[1] + white[2]
                                               : std::max({white[0], white[1], white[2]}));
  const int p = 24, w = 6 * p, h = 4 * p;
  io::Image im(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto e = m.expectedElectrons(Product(patches[size_t((y / p) * 6 + x / p)], *d65));
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = float(e[size_t(c)] * scale);
    }
  im.metadata[kRawSensorKey] = cfg.toText();
  const std::string dir = tmpDir("colour");
  const std::string path = dir + "/chart.dng";
  writeRawImage(path, im, 0, 0);
  int st = -1;
  const std::string log = run("dcraw_emu -w -o 1 -4 -q 3 -T " + path, &st);
  EXPECT_EQ(st, 0) << log;
  const io::Image dev = io::readImage(path + ".tiff");
  EXPECT_EQ(dev.width, w);
  EXPECT_EQ(dev.height, h);
  if (dev.width != w || dev.height != h) return 1e9;
  // Linear sRGB to XYZ (IEC 61966-2-1).
  auto toXyz = [](double r, double g, double b) {
    return Vec3{0.4124 * r + 0.3576 * g + 0.1805 * b, 0.2126 * r + 0.7152 * g + 0.0722 * b,
                0.0193 * r + 0.1192 * g + 0.9505 * b};
  };
  std::vector<Vec3> got, want;
  const ConstantSpectrum one(1.0);
  const Vec3 wn = spectrumToXyz(Product(one, *d65));
  for (int k = 0; k < 24; ++k) {
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int y = (k / 6) * p + 6; y < (k / 6) * p + p - 6; ++y)
      for (int x = (k % 6) * p + 6; x < (k % 6) * p + p - 6; ++x, ++n)
        for (int c = 0; c < 3; ++c) s[c] += dev.at(x, y, c);
    got.push_back(toXyz(s[0] / n, s[1] / n, s[2] / n));
    want.push_back(spectrumToXyz(Product(patches[size_t(k)], *d65)) / wn.y);
  }
  const double expose = want[18].y / got[18].y;
  const Vec3 white_ref = wn / wn.y;
  double sum = 0, worst = 0;
  for (int k = 0; k < 24; ++k) {
    const double de = deltaE2000(lab(got[size_t(k)] * expose, white_ref), lab(want[size_t(k)], white_ref));
    sum += de;
    worst = std::max(worst, de);
  }
  *worst_out = worst;
  return sum / 24;
}

}  // namespace

TEST(SensorDng, ColorCheckerDevelopedByDcrawEmuWithinDeltaE2000) {
  double worst = 0;
  const double mean = dcrawEmuChartDeltaE("RGGB", &worst);
  std::printf("ColorChecker through dcraw_emu: mean dE2000 %.2f, max %.2f\n", mean, worst);
  EXPECT_LT(mean, 3.0);
}

TEST(SensorDng, RgbwColorCheckerDevelopedByDcrawEmuWithinDeltaE2000) {
  // An RGBW sensor's DNG (four colour planes, the W row of ColorMatrix the sum of the others):
  // LibRaw develops it as a four-colour CFA.
  double worst = 0;
  const double mean = dcrawEmuChartDeltaE("RG/BW", &worst);
  std::printf("RGBW ColorChecker through dcraw_emu: mean dE2000 %.2f, max %.2f\n", mean, worst);
  EXPECT_LT(mean, 3.0);
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

// The 24 patches as spectral diffuse quads (the Ohta 1997 reflectances) on a 0.2 grid under a
// uniform D65 sky, seen from `distance` on the axis through `camera`, rendered to a raw DNG with
// noise and developed by dcraw_emu as above. Returns the mean CIEDE2000 (and the largest in
// *worst). The patches are located from the black patch's centroid (Y 3 % of the sky's; the only
// region of the lower right quarter below 5 %), which gives the image scale.
double renderedChartDeltaE(const std::string& name, const std::string& camera, double distance,
                           const std::string& film_extra, double* worst,
                           const std::string& developer = "dcraw_emu") {
  std::ifstream csv(std::string(LENSIM_SHARED_DIR) +
                    "/data/colorchecker/colorchecker-ohta1997.csv");
  std::vector<std::string> spectra(24);
  std::string line;
  std::getline(csv, line);
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string lambda, v;
    std::getline(ss, lambda, ',');
    for (int i = 0; i < 24 && std::getline(ss, v, ','); ++i)
      spectra[size_t(i)] += lambda + " " + v + " ";
  }
  const std::string dir = tmpDir(name);
  const std::string scene = dir + "/chart.pbrt";
  {
    std::ofstream f(scene);
    f << "LookAt 0 0 " << -distance << "  0 0 0  0 1 0\n"
      << camera << "\n"
      << "Sampler \"independent\" \"integer pixelsamples\" 16\n"
         "Film \"raw\" \"integer xresolution\" 240 \"integer yresolution\" 160\n"
         "  \"float pixelpitch\" 5 \"float nits\" 10 \"float fnumber\" 4 "
      << film_extra
      << "\nIntegrator \"path\" \"integer maxdepth\" 1\n"
         "WorldBegin\n"
         "LightSource \"infinite\" \"spectrum L\" \"stdillum-D65\"\n";
    // Patch k: column k % 6, row k / 6 (row 0 at the top), 0.16 wide on a 0.2 grid.
    for (int k = 0; k < 24; ++k) {
      const double cx = (k % 6 - 2.5) * 0.2, cy = (1.5 - k / 6) * 0.2, r = 0.08;
      f << "AttributeBegin\nMaterial \"diffuse\" \"spectrum reflectance\" [" << spectra[size_t(k)]
        << "]\nShape \"bilinearmesh\" \"point3 P\" [" << cx - r << " " << cy - r << " 0 "
        << cx + r << " " << cy - r << " 0 " << cx - r << " " << cy + r << " 0 " << cx + r << " "
        << cy + r << " 0]\nAttributeEnd\n";
    }
  }
  auto r = lensim::test::runLensim("render -q " + scene + " -o " + dir + "/chart.dng");
  EXPECT_EQ(r.status, 0) << r.out;
  int st = -1;
  std::string developed = dir + "/chart.dng.tiff";
  if (developer == "lensim" || developer == "lensim-ignore-w") {
    developed = dir + "/developed.exr";
    r = lensim::test::runLensim("develop -q " + dir + "/chart.dng -o " + developed +
                                (developer == "lensim" ? "" : " --ignore-w"));
    EXPECT_EQ(r.status, 0) << r.out;
  } else if (developer == "darktable") {
    // darktable-cli with no workflow defaults (no filmic or base curve: its raw steps, the DNG's
    // ColorMatrix and as-shot white balance, sRGB output), a fresh configuration, no library.
    developed = dir + "/darktable.png";
    std::filesystem::remove(developed);
    const std::string log =
        run("timeout 120 darktable-cli " + dir + "/chart.dng " + developed + " --core --configdir " +
                dir + "/dtconfig --library :memory: --conf plugins/darkroom/workflow=none",
            &st);
    EXPECT_EQ(st, 0) << log;
  } else if (developer == "dcraw") {
    // dcraw's own X-Trans interpolation (LibRaw 0.20's fails on X-Trans DNGs at -q 3).
    developed = dir + "/chart.tiff";
    const std::string log = run("dcraw -w -o 1 -4 -T " + dir + "/chart.dng", &st);
    EXPECT_EQ(st, 0) << log;
  } else {
    const std::string log = run("dcraw_emu -w -o 1 -4 -q 3 -T " + dir + "/chart.dng", &st);
    EXPECT_EQ(st, 0) << log;
  }
  const io::Image dev = io::readImage(developed);
  if (dev.width != 240 || dev.height != 160) {
    ADD_FAILURE() << "developed image " << dev.width << "x" << dev.height;
    return 1e9;
  }
  const std::vector<PiecewiseLinearSpectrum> patches = ohtaPatches();
  const std::shared_ptr<const Spectrum> d65 = daylightIlluminant(6500);
  const ConstantSpectrum one(1.0);
  const Vec3 wn = spectrumToXyz(Product(one, *d65));
  auto toXyz = [](double r, double g, double b) {
    return Vec3{0.4124 * r + 0.3576 * g + 0.1805 * b, 0.2126 * r + 0.7152 * g + 0.0722 * b,
                0.0193 * r + 0.1192 * g + 0.9505 * b};
  };
  // The scale from the black patch's centroid (its centre is at (0.5, -0.3) on the chart).
  const double sky = toXyz(dev.at(6, 6, 0), dev.at(6, 6, 1), dev.at(6, 6, 2)).y;
  double sx = 0, sy = 0, n_dark = 0;
  for (int y = 80; y < 156; ++y)  // the lower right quarter, not the demosaic's edge pixels
    for (int x = 120; x < 236; ++x)
      if (toXyz(dev.at(x, y, 0), dev.at(x, y, 1), dev.at(x, y, 2)).y < 0.05 * sky)
        sx += x + 0.5, sy += y + 0.5, ++n_dark;
  EXPECT_GT(n_dark, 50);
  const double scale = (sx / n_dark - 120) / 0.5;  // pixels per metre on the chart
  EXPECT_NEAR((sy / n_dark - 80) / 0.3, scale, 0.1 * scale);
  std::vector<Vec3> got, want;
  for (int k = 0; k < 24; ++k) {
    const double cx = (k % 6 - 2.5) * 0.2, cy = (1.5 - k / 6) * 0.2;
    const int x0 = int(std::lround(120 + cx * scale)), y0 = int(std::lround(80 - cy * scale));
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int y = y0 - 7; y < y0 + 7; ++y)
      for (int x = x0 - 7; x < x0 + 7; ++x, ++n)
        for (int c = 0; c < 3; ++c) s[c] += dev.at(std::clamp(x, 0, 239), std::clamp(y, 0, 159), c);
    got.push_back(toXyz(s[0] / n, s[1] / n, s[2] / n));
    want.push_back(spectrumToXyz(Product(patches[size_t(k)], *d65)) / wn.y);
  }
  const double expose = want[18].y / got[18].y;
  double sum = 0;
  *worst = 0;
  for (int k = 0; k < 24; ++k) {
    const double de =
        deltaE2000(lab(got[size_t(k)] * expose, wn / wn.y), lab(want[size_t(k)], wn / wn.y));
    sum += de;
    *worst = std::max(*worst, de);
  }
  return sum / 24;
}

}  // namespace

TEST(SensorDng, RenderedColorCheckerDevelopedByDcrawEmu) {
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_pinhole", "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1", 5,
      "", &worst);
  std::printf("rendered ColorChecker (perspective) through dcraw_emu: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
}

TEST(SensorDng, ColorCheckerThroughDoubleGaussDevelopedByDcrawEmu) {
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_dgauss",
      "Camera \"realistic\" \"string lensfile\" \"" + std::string(LENSIM_SOURCE_DIR) +
          "/lenses/dgauss.50mm.dat\" \"float aperturediameter\" 12.5 \"float focusdistance\" 6 "
          "\"float shutterclose\" 1",
      6, "\"float diagonal\" 15", &worst);
  std::printf("ColorChecker through the double Gauss, dcraw_emu: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
}

TEST(SensorDng, ColorCheckerThroughDoubleGaussDevelopedByLensim) {
  // The same DNG developed by lensim's own pipeline (`lensim develop`).
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_dgauss_lensim",
      "Camera \"realistic\" \"string lensfile\" \"" + std::string(LENSIM_SOURCE_DIR) +
          "/lenses/dgauss.50mm.dat\" \"float aperturediameter\" 12.5 \"float focusdistance\" 6 "
          "\"float shutterclose\" 1",
      6, "\"float diagonal\" 15", &worst, "lensim");
  std::printf("ColorChecker through the double Gauss, lensim develop: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
  // Refusals: not a DNG, an unknown output format.
  auto r = lensim::test::runLensim("develop " + std::string(LENSIM_SOURCE_DIR) +
                                   "/lenses/dgauss.50mm.dat -o " + tmpDir("dev_bad") + "/x.png");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("dgauss.50mm.dat: error: cannot read the file as TIFF/DNG"),
            std::string::npos)
      << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmpDir("dev_bad") + "/x.png"));
}

// ---- Other CFA patterns (docs/sensor.md, "Colour filter arrays") ----

namespace {

// The filter letter of pixel (x, y) of a pattern written as rows joined by '/' (the test's own
// reading of the pattern, not parseCfa's).
char patternLetter(const std::string& rows_text, int x, int y) {
  std::vector<std::string> rows;
  std::stringstream ss(rows_text);
  for (std::string r; std::getline(ss, r, '/');) rows.push_back(r);
  const std::string& row = rows[size_t(y) % rows.size()];
  return row[size_t(x) % row.size()];
}

// Fujifilm's X-Trans 6x6 tile (as dcraw's built-in xtrans table).
const char* const kXTrans = "GGRGGB/GGBGGR/BRGRBG/GGBGGR/GGRGGB/RBGBRG";

}  // namespace

TEST(SensorDng, OtherCfaPatternsDecodeBitForBitAndLibRawReadsThem) {
  const std::string dir = tmpDir("patterns");
  for (const char* cfa : {kXTrans, "RG/GB/GR/BG", "R/G/B/G", "RG/GB/RG/GB/GR/BG/GR/BG", "RB/GG"})
    for (const auto& [x0, y0] : std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {3, 5}}) {
      SensorConfig cfg;
      cfg.cfa = cfa;
      cfg.seed = 9;
      const io::Image im = electronImage(42, 30, cfg);
      const std::string path = dir + "/p.dng";
      writeRawImage(path, im, x0, y0);
      int st = -1, w = 0, h = 0;
      const std::string pgm = run("dcraw -D -4 -c " + path, &st);
      ASSERT_EQ(st, 0) << pgm;
      const std::vector<uint16_t> got = parsePgm(pgm, w, h);
      ASSERT_EQ(w, 42);
      ASSERT_EQ(h, 30);
      const std::vector<uint16_t> want = expectedDn(im, cfg, x0, y0);
      EXPECT_EQ(got, want) << cfa << " at " << x0 << "," << y0;
      // Each DN is the electrons of the channel the pattern puts there (noise off: exact).
      cfg.noise = false;
      cfg.read_noise_e = 0;
      cfg.dark_current_e_s = 0;
      io::Image quiet = im;
      quiet.metadata[kRawSensorKey] = cfg.toText();
      writeRawImage(path, quiet, x0, y0);
      const std::vector<uint16_t> q = parsePgm(run("dcraw -D -4 -c " + path, &st), w, h);
      ASSERT_EQ(q.size(), size_t(42 * 30));
      for (int y = 0; y < 30; y += 7)
        for (int x = 0; x < 42; x += 5) {
          const int c = int(std::string("RGB").find(patternLetter(cfa, x0 + x, y0 + y)));
          const double e = im.at(x, y, c);
          EXPECT_EQ(q[size_t(y * 42 + x)], uint16_t(std::lround(e * cfg.gainDnPerE()) + 512))
              << cfa << " pixel " << x << "," << y;
        }
      // LibRaw's filter pattern: the colours of rows 0-7, columns 0-1 of the written image.
      const std::string info = run("raw-identify -v " + path, &st);
      ASSERT_EQ(st, 0) << info;
      std::string pattern;
      for (int i = 0; i < 16; ++i) pattern += patternLetter(cfa, x0 + (i & 1), y0 + (i >> 1));
      EXPECT_NE(info.find("Filter pattern: " + pattern + "\n"), std::string::npos)
          << cfa << " " << x0 << "," << y0 << ": expected " << pattern << "\n" << info;
      EXPECT_NE(info.find("Raw colors: 3"), std::string::npos) << info;
    }
}

TEST(SensorDng, CfaPatternsRefusedWithTheReason) {
  auto message = [](const std::string& text) {
    try {
      parseCfa(text, FileLoc{"s.pbrt", 3, 7});
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("RGGX").find("s.pbrt:3:7: error: \"cfa\": \"RGGX\" has the letter 'X'"),
            std::string::npos)
      << message("RGGX");
  EXPECT_NE(message("RGG").find("has 3 letters, not a square tile"), std::string::npos);
  EXPECT_NE(message("RG/G").find("has rows of 2 and 1 letters"), std::string::npos);
  EXPECT_NE(message("RRGG").find("has no B filter"), std::string::npos);
  EXPECT_NE(message("RGBRGBRGB/R").find("is 9x2"), std::string::npos);
  EXPECT_NE(message("RG//GB").find("has rows of 2 and 0 letters"), std::string::npos);
  // Parsed: the letters row by row; "mono".
  const CfaPattern q = parseCfa("RRGG/RRGG/GGBB/GGBB");
  EXPECT_EQ(q.width, 4);
  EXPECT_EQ(q.height, 4);
  EXPECT_EQ(q.channel(2, 0), 1);
  EXPECT_EQ(q.channel(6, 3), 2);
  EXPECT_EQ(q.channel(5, 3), 1);
  EXPECT_EQ(q.channel(-1, -1), 2);
  EXPECT_EQ(q.text(), "RRGG/RRGG/GGBB/GGBB");
  EXPECT_EQ(parseCfa("RGGB"), parseCfa("RG/GB"));
  EXPECT_TRUE(parseCfa("mono").mono);
}

TEST(SensorDng, PatternsRefusedForDngAreThoseDcrawMisreads) {
  // Written anyway (io::writeDng has no such check), dcraw -D decodes some pixels as 0.
  const std::string dir = tmpDir("misread");
  for (const char* cfa :
       {"GR/BG/GB/RG/RG/GB/BG/GR", "G/R/G/B", "RG/GB/BG/GR", "RRGG/RRGG/GGBB/GGBB"}) {
    const CfaPattern p = parseCfa(cfa);
    EXPECT_FALSE(p.dngReadable()) << cfa;
    io::DngImage d;
    d.width = 32;
    d.height = 24;
    d.data.assign(32 * 24, 1000);
    d.cfa_width = p.width == 1 ? 2 : p.width;
    d.cfa_height = p.height;
    d.cfa.clear();
    for (int y = 0; y < d.cfa_height; ++y)
      for (int x = 0; x < d.cfa_width; ++x) d.cfa.push_back(uint8_t(p.channel(x, y)));
    d.color_matrix1 = d.color_matrix2 = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const std::string path = dir + "/x.dng";
    io::writeDng(path, d);
    int st = -1, w = 0, h = 0;
    const std::vector<uint16_t> got = parsePgm(run("dcraw -D -4 -c " + path, &st), w, h);
    ASSERT_EQ(got.size(), size_t(32 * 24)) << cfa;
    EXPECT_NE(std::count(got.begin(), got.end(), uint16_t(0)), 0) << cfa;
    if (p.width == 4) {
      // LibRaw 0.20 takes the Quad Bayer's 16 CFAPattern values as its 8 rows x 2 columns, not
      // the tile's first two columns (RR/RR/GG/GG/RR/RR/GG/GG).
      const std::string info = run("raw-identify -v " + path, &st);
      EXPECT_NE(info.find("Filter pattern: RRGGRRGGGGBBGGBB\n"), std::string::npos) << info;
    }
    // Refused by lensim's writer, naming the pattern.
    SensorConfig cfg;
    cfg.cfa = cfa;
    try {
      writeRawImage(path, electronImage(32, 24, cfg), 0, 0);
      ADD_FAILURE() << cfa << " written";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("\"") + cfa + "\" would be misread"),
                std::string::npos)
          << e.what();
    }
  }
  for (const char* cfa : {"RG/GB/GR/BG", "R/G/B/G", "RB/GG", "RGGB", "GBRG"})
    EXPECT_TRUE(parseCfa(cfa).dngReadable()) << cfa;
}

TEST(SensorDng, QuadBayerWritesExrButRefusesDng) {
  const std::string dir = tmpDir("quad");
  SensorConfig cfg;
  cfg.cfa = "RRGG/RRGG/GGBB/GGBB";
  const io::Image im = electronImage(24, 24, cfg);
  EXPECT_THROW(writeRawImage(dir + "/q.dng", im, 0, 0), Error);
  EXPECT_FALSE(std::filesystem::exists(dir + "/q.dng"));
  writeRawImage(dir + "/q.exr", im, 0, 0);
  const io::Image exr = io::readImage(dir + "/q.exr");
  ASSERT_EQ(exr.channelCount(), 5);
  const int electrons = exr.channelIndex("electrons").value_or(-1);
  ASSERT_GE(electrons, 0);
  // The noise-free mosaic takes each pixel's channel from the 4x4 tile.
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      const int c = (y % 4 < 2 ? 0 : 1) + (x % 4 < 2 ? 0 : 1);
      EXPECT_EQ(exr.at(x, y, electrons), im.at(x, y, c)) << x << "," << y;
    }
  // A scene writing an .exr renders; asked for a .dng on the command line, it is refused before
  // rendering.
  {
    std::ofstream f(dir + "/e.pbrt");
    f << "Camera \"perspective\"\nSampler \"independent\" \"integer pixelsamples\" 1\n"
         "Film \"raw\" \"integer xresolution\" 32 \"integer yresolution\" 24 \"string cfa\" "
         "\"RRGG/RRGG/GGBB/GGBB\"\nWorldBegin\nLightSource \"infinite\"\n";
  }
  auto ok = lensim::test::runLensim("render -q " + dir + "/e.pbrt -o " + dir + "/e.exr");
  EXPECT_EQ(ok.status, 0) << ok.out;
  ok = lensim::test::runLensim("render " + dir + "/e.pbrt -o " + dir + "/e.dng");
  EXPECT_EQ(ok.status, 1) << ok.out;
  EXPECT_NE(ok.out.find(dir + "/e.dng: error: \"cfa\": a DNG of the 4x4 pattern"),
            std::string::npos)
      << ok.out;
  EXPECT_EQ(ok.out.find("samples"), std::string::npos) << "rendered first:\n" << ok.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/e.dng"));
  // At the scene's line: the pattern with a .dng output, and a 4x4 RGBW one.
  for (const auto& [cfa, what] : std::vector<std::pair<std::string, std::string>>{
           {"RRGG/RRGG/GGBB/GGBB", "would be misread by dcraw"},
           {"WBWG/BWGW/WGWR/GWRW", "would be misread by dcraw"}}) {
    const std::string scene = dir + "/q.pbrt";
    const std::string line3 = "  \"string filename\" \"q.dng\" \"string cfa\" \"" + cfa + "\"";
    {
      std::ofstream f(scene);
      f << "Camera \"perspective\"\nFilm \"raw\" \"integer xresolution\" 32\n"
        << line3 << "\nWorldBegin\nLightSource \"infinite\"\n";
    }
    const auto r = lensim::test::runLensim("render -q " + scene);
    EXPECT_EQ(r.status, 1) << r.out;
    const std::string at =
        fmt::format("{}:3:{}: error: \"cfa\"", scene, line3.find("\"string cfa\"") + 1);
    EXPECT_NE(r.out.find(at), std::string::npos) << at << "\n" << r.out;
    EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(dir + "/q.dng"));
  }
}

TEST(SensorDng, XTransColorCheckerDevelopedByDcrawAndLensim) {
  // The rendered chart of the tests above on an X-Trans sensor: dcraw's X-Trans demosaic and
  // lensim develop's normalised convolution.
  const std::string film = std::string("\"string cfa\" \"") + kXTrans + "\"";
  const std::string camera = "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1";
  double worst = 0;
  const double dcraw = renderedChartDeltaE("chart_xtrans", camera, 5, film, &worst, "dcraw");
  std::printf("X-Trans ColorChecker, dcraw: mean dE2000 %.2f, max %.2f\n", dcraw, worst);
  EXPECT_LT(dcraw, 3.0);
  const double own = renderedChartDeltaE("chart_xtrans_lensim", camera, 5, film, &worst, "lensim");
  std::printf("X-Trans ColorChecker, lensim develop: mean dE2000 %.2f, max %.2f\n", own, worst);
  EXPECT_LT(own, 3.0);
}

TEST(SensorDng, RgbwColorCheckerDevelopedByDcrawEmuAndLensim) {
  // The rendered chart on an RGBW sensor (RG/BW): LibRaw's four-colour path, and lensim
  // develop's normalised convolution of the R, G and B pixels, with the W pixels' luminance and
  // without: using W may not worsen the mean CIEDE2000 by more than 0.1.
  const std::string film = "\"string cfa\" \"RG/BW\"";
  const std::string camera = "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1";
  double worst = 0;
  const double emu = renderedChartDeltaE("chart_rgbw", camera, 5, film, &worst);
  std::printf("RGBW ColorChecker, dcraw_emu: mean dE2000 %.2f, max %.2f\n", emu, worst);
  EXPECT_LT(emu, 3.0);
  const double own = renderedChartDeltaE("chart_rgbw_lensim", camera, 5, film, &worst, "lensim");
  std::printf("RGBW ColorChecker, lensim develop: mean dE2000 %.2f, max %.2f\n", own, worst);
  EXPECT_LT(own, 3.0);
  const double no_w =
      renderedChartDeltaE("chart_rgbw_lensim_no_w", camera, 5, film, &worst, "lensim-ignore-w");
  std::printf("RGBW ColorChecker, lensim develop --ignore-w: mean dE2000 %.2f, max %.2f\n", no_w,
              worst);
  EXPECT_LT(own, no_w + 0.1);
}

TEST(SensorDng, QuadBayerRemosaicedToBayerDng) {
  // "string dngcfa" "bayer": a tile dcraw cannot hold written as an RGGB DNG (from the full
  // image's top-left pixel), stated in ImageDescription. A noise-free flat field of distinct
  // R, G and B levels: dcraw -D decodes each pixel as its RGGB filter's level (1 DN per 4 e- at
  // ISO 100, black 512), at three window origins; LibRaw reports the Bayer pattern.
  const std::string dir = tmpDir("remosaic");
  for (const char* cfa : {"RRGG/RRGG/GGBB/GGBB", "WBWG/BWGW/WGWR/GWRW"})
    for (const auto& [x0, y0] : std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {3, 5}}) {
      SensorConfig cfg;
      cfg.cfa = cfa;
      cfg.dng_cfa = "bayer";
      cfg.noise = false;
      cfg.dark_current_e_s = 0;
      io::Image im(28, 24, {"R", "G", "B"});
      const float level[3] = {4000, 10000, 2400};
      for (int y = 0; y < 24; ++y)
        for (int x = 0; x < 28; ++x)
          for (int c = 0; c < 3; ++c) im.at(x, y, c) = level[c];
      im.metadata[kRawSensorKey] = cfg.toText();
      const std::string path = dir + "/q.dng";
      writeRawImage(path, im, x0, y0);
      int st = -1, w = 0, h = 0;
      const std::vector<uint16_t> got = parsePgm(run("dcraw -D -4 -c " + path, &st), w, h);
      ASSERT_EQ(st, 0);
      ASSERT_EQ(got.size(), size_t(28 * 24));
      for (int y = 0; y < 24; ++y)
        for (int x = 0; x < 28; ++x) {
          const int fx = (x0 + x) % 2, fy = (y0 + y) % 2;
          const int c = fy == 0 ? (fx == 0 ? 0 : 1) : (fx == 0 ? 1 : 2);
          ASSERT_EQ(got[size_t(y * 28 + x)], 512 + int(level[c]) / 4)
              << cfa << " at " << x << "," << y << " origin " << x0 << "," << y0;
        }
      const std::string info = run("raw-identify -v " + path, &st);
      const char* pattern = x0 % 2 == 0 ? (y0 % 2 == 0 ? "RGGBRGGB" : "GBRGGBRG")
                                        : (y0 % 2 == 0 ? "GRBGGRBG" : "BGGRBGGR");
      EXPECT_NE(info.find(std::string("Filter pattern: ") + pattern), std::string::npos)
          << cfa << " " << x0 << "," << y0 << "\n" << info;
      EXPECT_NE(info.find("Raw colors: 3"), std::string::npos) << info;
      std::ifstream in(path, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      EXPECT_NE(bytes.find(std::string("Bayer RGGB remosaic by lensim of the sensor's 4x4 CFA ") +
                           cfa),
                std::string::npos);
    }
  // With noise: a pixel whose filter is its Bayer filter keeps the sensor's raw value, bit for
  // bit the DN of the .exr output (the sensor's own mosaic) of the same frame.
  SensorConfig cfg;
  cfg.cfa = "RRGG/RRGG/GGBB/GGBB";
  cfg.dng_cfa = "bayer";
  cfg.seed = 5;
  const io::Image im = electronImage(32, 24, cfg);
  writeRawImage(dir + "/n.dng", im, 2, 1);
  writeRawImage(dir + "/n.exr", im, 2, 1);
  int st = -1, w = 0, h = 0;
  const std::vector<uint16_t> got = parsePgm(run("dcraw -D -4 -c " + dir + "/n.dng", &st), w, h);
  ASSERT_EQ(got.size(), size_t(32 * 24));
  const io::Image exr = io::readImage(dir + "/n.exr");
  const int dn = exr.channelIndex("DN").value_or(-1);
  ASSERT_GE(dn, 0);
  int kept = 0;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      const int fx = (2 + x) % 2, fy = (1 + y) % 2;
      const char bayer = fy == 0 ? (fx == 0 ? 'R' : 'G') : (fx == 0 ? 'G' : 'B');
      if (patternLetter("RRGG/RRGG/GGBB/GGBB", 2 + x, 1 + y) != bayer) continue;
      ++kept;
      ASSERT_EQ(float(got[size_t(y * 32 + x)]), exr.at(x, y, dn)) << x << "," << y;
    }
  EXPECT_EQ(kept, 32 * 24 * 3 / 8);  // of a 4x4 tile: 1 of the 4 R sites, 4 of 8 G, 1 of 4 B
  // A 2x2 Bayer tile other than RGGB is written as it is (the same file as without "dngcfa").
  SensorConfig gbrg;
  gbrg.cfa = "GBRG";
  gbrg.seed = 5;
  writeRawImage(dir + "/native.dng", electronImage(32, 24, gbrg), 1, 0);
  gbrg.dng_cfa = "bayer";
  writeRawImage(dir + "/asis.dng", electronImage(32, 24, gbrg), 1, 0);
  EXPECT_EQ(parsePgm(run("dcraw -D -4 -c " + dir + "/asis.dng", &st), w, h),
            parsePgm(run("dcraw -D -4 -c " + dir + "/native.dng", &st), w, h));
  EXPECT_NE(run("raw-identify -v " + dir + "/asis.dng").find("Filter pattern: BGGRBGGR"),
            std::string::npos);
  // A bad value, at its scene line.
  const std::string scene = dir + "/bad.pbrt";
  {
    std::ofstream f(scene);
    f << "Camera \"perspective\"\nFilm \"raw\" \"integer xresolution\" 32\n"
         "  \"string dngcfa\" \"quad\"\nWorldBegin\n";
  }
  const auto r = lensim::test::runLensim("render -q " + scene + " -o " + dir + "/bad.dng");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find(scene + ":3:3: error: \"dngcfa\": \"quad\"; expected \"native\""),
            std::string::npos)
      << r.out;
}

TEST(SensorDng, QuadBayerRemosaicSplitRenderMergedEqualsOneRender) {
  // The remosaic runs where the noise does, once, on the whole image: two tiles merged by
  // lensim merge give the very same Bayer DNG as one render.
  const std::string dir = tmpDir("remosaic_split");
  const std::string scene = dir + "/q.pbrt";
  {
    std::ofstream f(scene);
    f << "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
         "Sampler \"independent\" \"integer pixelsamples\" 4 \"integer seed\" 5\n"
         "Film \"raw\" \"integer xresolution\" 32 \"integer yresolution\" 24 \"float nits\" 0.0005\n"
         "  \"float fnumber\" 2.8 \"string cfa\" \"RRGG/RRGG/GGBB/GGBB\" \"string dngcfa\" \"bayer\"\n"
         "WorldBegin\nLightSource \"infinite\" \"blackbody L\" [5000]\n"
         "LightSource \"point\" \"blackbody I\" [3000] \"float scale\" 2\n"
         "Material \"diffuse\" \"rgb reflectance\" [0.8 0.3 0.2]\nShape \"sphere\" \"float radius\" 1\n";
  }
  using lensim::test::runLensim;
  auto r = runLensim("render -q " + scene + " -o " + dir + "/one.dng");
  ASSERT_EQ(r.status, 0) << r.out;
  for (int t = 0; t < 2; ++t) {
    r = runLensim(fmt::format("render -q --tile {}/2 {} -o {}/tile{}.exr", t, scene, dir, t));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  r = runLensim("merge -q " + dir + "/tiles.dng " + dir + "/tile0.exr " + dir + "/tile1.exr");
  ASSERT_EQ(r.status, 0) << r.out;
  int st = -1, w = 0, h = 0;
  const auto one = parsePgm(run("dcraw -D -4 -c " + dir + "/one.dng", &st), w, h);
  ASSERT_EQ(one.size(), 32u * 24u);
  EXPECT_EQ(parsePgm(run("dcraw -D -4 -c " + dir + "/tiles.dng", &st), w, h), one);
  int lit = 0;
  for (uint16_t v : one) lit += v > 512 + 50;
  EXPECT_GT(lit, 100);
}

TEST(SensorDng, QuadBayerColorCheckerRemosaicedDevelopedByDcrawEmuAndDarktable) {
  // The rendered chart on a Quad Bayer sensor and on Kodak's 4x4 RGBW, written as RGGB DNGs
  // ("string dngcfa" "bayer") and developed by LibRaw's dcraw_emu (AHD); the Quad Bayer one also
  // by darktable-cli (as RenderedColorCheckerDevelopedByDarktable).
  const std::string camera = "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1";
  double worst = 0;
  const double quad = renderedChartDeltaE(
      "chart_quad", camera, 5, "\"string cfa\" \"RRGG/RRGG/GGBB/GGBB\" \"string dngcfa\" \"bayer\"",
      &worst);
  std::printf("Quad Bayer remosaiced to RGGB, dcraw_emu: mean dE2000 %.2f, max %.2f\n", quad, worst);
  EXPECT_LT(quad, 3.0);
  const double kodak = renderedChartDeltaE(
      "chart_kodak", camera, 5, "\"string cfa\" \"WBWG/BWGW/WGWR/GWRW\" \"string dngcfa\" \"bayer\"",
      &worst);
  std::printf("4x4 RGBW remosaiced to RGGB, dcraw_emu: mean dE2000 %.2f, max %.2f\n", kodak, worst);
  EXPECT_LT(kodak, 3.0);
  if (std::system("command -v darktable-cli >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "darktable-cli is not installed (scripts/install-deps installs it)";
  const double dt = renderedChartDeltaE(
      "chart_quad_darktable", camera, 5,
      "\"string cfa\" \"RRGG/RRGG/GGBB/GGBB\" \"string dngcfa\" \"bayer\"", &worst, "darktable");
  std::printf("Quad Bayer remosaiced to RGGB, darktable-cli: mean dE2000 %.2f, max %.2f\n", dt, worst);
  EXPECT_LT(dt, 3.0);
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

TEST(SensorDng, RawPreviewIsNeutralForWhiteAndMatchesLensimDevelop) {
  // serve's preview of a raw film: a white surface under CIE D 6500 K (the default white
  // balance) is neutral, and a flat field equals lensim develop's picture of its DNG.
  SensorConfig cfg;
  cfg.noise = false;
  cfg.read_noise_e = 0;
  cfg.dark_current_e_s = 0;
  const SensorModel model(cfg);
  const std::shared_ptr<const Spectrum> d65 = daylightIlluminant(6500);
  const Vec3 white = cameraResponse(model, *d65);
  const double k = 20000 / std::max({white.x, white.y, white.z});  // 20000 e- at most
  io::Image im(24, 24, {"R", "G", "B"});
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      im.at(x, y, 0) = float(white.x * k);
      im.at(x, y, 1) = float(white.y * k);
      im.at(x, y, 2) = float(white.z * k);
    }
  im.metadata[kRawSensorKey] = cfg.toText();
  const io::Image p = previewRawImage(im);
  ASSERT_EQ(p.channelCount(), 3);
  EXPECT_NEAR(p.at(5, 5, 0) / p.at(5, 5, 1), 1.0, 0.01);
  EXPECT_NEAR(p.at(5, 5, 2) / p.at(5, 5, 1), 1.0, 0.01);
  // Another colour (more red, less blue), against the developed DNG's centre.
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      im.at(x, y, 0) *= 1.5f;
      im.at(x, y, 2) *= 0.6f;
    }
  const io::Image q = previewRawImage(im);
  const std::string path = tmpDir("preview") + "/flat.dng";
  writeRawImage(path, im, 0, 0);
  const io::Image d = developRaw(io::readDng(path));
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(q.at(12, 12, c), d.at(12, 12, c), 2e-3 * d.at(12, 12, 1)) << c;
  // Not a raw image: returned as it is.
  io::Image plain(2, 2, {"R", "G", "B"});
  plain.at(1, 1, 2) = 0.25f;
  EXPECT_EQ(previewRawImage(plain).at(1, 1, 2), 0.25f);
}

TEST(SensorDng, RenderedColorCheckerDevelopedByDarktable) {
  if (std::system("command -v darktable-cli >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "darktable-cli is not installed (scripts/install-deps installs it)";
  double worst = 0;
  const double mean = renderedChartDeltaE(
      "chart_darktable", "Camera \"perspective\" \"float fov\" 10.28 \"float shutterclose\" 1",
      5, "", &worst, "darktable");
  std::printf("rendered ColorChecker (perspective) through darktable-cli: mean dE2000 %.2f, max %.2f\n",
              mean, worst);
  EXPECT_LT(mean, 3.0);
}
