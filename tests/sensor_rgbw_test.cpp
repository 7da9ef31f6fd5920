// W (panchromatic) and RGBW colour filter arrays (Film "raw", docs/sensor.md): a W pixel's QE is
// the sum of the R, G and B curves (checked against photons x QE read from the data file here);
// RGBW DNGs (four colour planes, CFAPlaneColor R G B W) decoded bit for bit by dcraw and read as
// four colours by LibRaw; a split render merged by lensim merge gives the same raw values; tiles
// dcraw cannot hold are refused for DNG and written as EXR.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
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
#include "lensim/util/error.h"

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
  const std::string d = ::testing::TempDir() + "/sensor_rgbw_" + name;
  std::filesystem::create_directories(d);
  return d;
}

// The 5D Mark IV's bundled relative curves (r, g, b every 10 nm from 380 nm), read from the
// data file independently of lensim.
std::vector<std::vector<double>> readCanonCurves() {
  std::ifstream in(std::string(LENSIM_SOURCE_DIR) + "/data/sensors/camera_sensors.csv");
  std::vector<std::vector<double>> rgb(3);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("canon_eos_5d_mkiv,", 0) != 0) continue;
    std::stringstream ss(line);
    std::string cam, ch, v;
    std::getline(ss, cam, ',');
    std::getline(ss, ch, ',');
    const int c = ch == "r" ? 0 : ch == "g" ? 1 : 2;
    while (std::getline(ss, v, ',')) rgb[size_t(c)].push_back(std::stod(v));
  }
  return rgb;
}

// A unit-area triangle of half-width 1 nm at lambda0: a monochromatic irradiance.
class Line final : public Spectrum {
 public:
  explicit Line(double l0) : l0_(l0) {}
  double eval(double l) const override { return std::max(0.0, 1 - std::abs(l - l0_)); }
  double maxValue() const override { return 1; }

 private:
  double l0_;
};

// The filter letter of pixel (x, y) of a pattern written as rows separated by '/'.
char patternLetter(const std::string& rows_text, int x, int y) {
  std::vector<std::string> rows;
  std::stringstream ss(rows_text);
  for (std::string r; std::getline(ss, r, '/');) rows.push_back(r);
  const std::string& row = rows[size_t(y) % rows.size()];
  return row[size_t(x) % row.size()];
}

// A raw film's image of w x h pixels with varied electrons per channel (their sum, a W pixel's
// electrons, stays below the full well).
io::Image electronImage(int w, int h, const SensorConfig& cfg) {
  io::Image im(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        im.at(x, y, c) = float(200 + ((x * 131 + y * 71 + c * 977) % 9000));
  im.metadata[kRawSensorKey] = cfg.toText();
  return im;
}

SensorConfig quietConfig(const std::string& cfa) {
  SensorConfig cfg;
  cfg.cfa = cfa;
  cfg.noise = false;
  cfg.read_noise_e = 0;
  cfg.dark_current_e_s = 0;
  return cfg;
}

}  // namespace

TEST(SensorRgbw, WPixelsCountPhotonsTimesTheSumOfTheRgbCurves) {
  const auto curves = readCanonCurves();
  ASSERT_EQ(curves[0].size(), 35u);
  double peak = 0;
  for (const auto& c : curves)
    for (double v : c) peak = std::max(peak, v);
  for (const char* cfa : {"RGBW", "mono"}) {
    SensorConfig cfg = quietConfig(cfa);
    cfg.peak_qe = 0.4;
    cfg.pixel_pitch_um = 4;
    cfg.exposure_s = 0.02;
    cfg.irradiance_scale = 1e-3;
    cfg.conversion_gain_e_dn = 1;
    cfg.adc_bits = 16;
    cfg.black_level_dn = 0;
    cfg.full_well_e = 1e6;
    const SensorModel m(cfg);
    const bool mono = std::string(cfa) == "mono";
    const int wx = mono ? 0 : 1, wy = mono ? 0 : 1;  // "RGBW" is RG/BW: W at (1, 1)
    const double h = 6.62607015e-34, c = 299792458.0;
    for (int k : {7, 12, 17, 22, 27}) {  // 450 to 650 nm
      const double lambda = 380 + 10 * k;
      const double photons = 1e-3 * (4e-6 * 4e-6) * 0.02 / (h * c / (lambda * 1e-9));
      const double qe_w =
          0.4 * (curves[0][size_t(k)] + curves[1][size_t(k)] + curves[2][size_t(k)]) / peak;
      EXPECT_NEAR(m.qe(mono ? 0 : CfaPattern::kW, lambda), qe_w, 1e-12) << cfa << " " << lambda;
      // Scaled up to thousands of electrons, the W pixel's DN (1 DN per electron, no noise).
      const double scale = 5000 / photons;
      auto e = m.expectedElectrons(Line(lambda));
      for (double& v : e) v *= scale;
      EXPECT_EQ(m.digitize(wx, wy, e), uint16_t(std::lround(5000 * qe_w)))
          << cfa << " at " << lambda << " nm";
      if (!mono) {  // the R pixel at (0, 0) keeps its own curve
        EXPECT_EQ(m.digitize(0, 0, e),
                  uint16_t(std::lround(5000 * 0.4 * curves[0][size_t(k)] / peak)));
      }
    }
  }
  // A W curve above 1 (the sum at a high peakqe) is refused, naming the value and the fix.
  SensorConfig high = quietConfig("RGBW");
  high.peak_qe = 0.9;
  try {
    SensorModel m(high, FileLoc{"s.pbrt", 4, 2});
    ADD_FAILURE() << "W QE above 1 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("s.pbrt:4:2: error: \"cfa\" \"RG/BW\""), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("expected at most 1"), std::string::npos) << e.what();
  }
}

TEST(SensorRgbw, DcrawDecodesRgbwDngsBitForBitAndLibRawReadsFourColours) {
  const std::string dir = tmpDir("dng");
  for (const char* cfa : {"RG/BW", "WG/RW/WB/GW", "R/G/B/W", "RW/WG/GW/WB/RW/WG/GW/WB"})
    for (const auto& [x0, y0] : std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {3, 5}}) {
      EXPECT_TRUE(parseCfa(cfa).dngReadable()) << cfa;
      SensorConfig cfg;
      cfg.cfa = cfa;
      cfg.seed = 4;
      const io::Image im = electronImage(42, 30, cfg);
      const std::string path = dir + "/w.dng";
      writeRawImage(path, im, x0, y0);
      int st = -1, w = 0, h = 0;
      const std::vector<uint16_t> got = parsePgm(run("dcraw -D -4 -c " + path, &st), w, h);
      ASSERT_EQ(st, 0);
      ASSERT_EQ(w, 42);
      ASSERT_EQ(h, 30);
      std::vector<float> rgb(im.pixels.begin(), im.pixels.end());
      EXPECT_EQ(got, digitizeImage(SensorModel(cfg), rgb, 42, 30, x0, y0))
          << cfa << " at " << x0 << "," << y0;
      // Noise off: each DN is the electrons of the pixel's filter as the test reads the
      // pattern, W the sum of the three channels.
      io::Image quiet = im;
      const SensorConfig q = quietConfig(cfa);
      quiet.metadata[kRawSensorKey] = q.toText();
      writeRawImage(path, quiet, x0, y0);
      const std::vector<uint16_t> dn = parsePgm(run("dcraw -D -4 -c " + path, &st), w, h);
      ASSERT_EQ(dn.size(), size_t(42 * 30));
      for (int y = 0; y < 30; y += 3)
        for (int x = 0; x < 42; x += 5) {
          const char f = patternLetter(cfa, x0 + x, y0 + y);
          const double e = f == 'W' ? double(im.at(x, y, 0)) + im.at(x, y, 1) + im.at(x, y, 2)
                                    : im.at(x, y, int(std::string("RGB").find(f)));
          EXPECT_EQ(dn[size_t(y * 42 + x)], uint16_t(std::lround(e * q.gainDnPerE()) + 512))
              << cfa << " pixel " << x << "," << y;
        }
      // LibRaw reads four colour planes and the pattern of rows 0-7, columns 0-1; it names the
      // planes of a four-colour CFA G, M, C, Y (its default) whatever CFAPlaneColor says, so
      // R, G, B, W appear as G, M, C, Y.
      const std::string info = run("raw-identify -v " + path, &st);
      ASSERT_EQ(st, 0) << info;
      std::string pattern;
      for (int i = 0; i < 16; ++i)
        pattern +=
            "GMCY"[std::string("RGBW").find(patternLetter(cfa, x0 + (i & 1), y0 + (i >> 1)))];
      EXPECT_NE(info.find("Raw colors: 4"), std::string::npos) << info;
      EXPECT_NE(info.find("Filter pattern: " + pattern + "\n"), std::string::npos)
          << cfa << " " << x0 << "," << y0 << ": expected " << pattern << "\n"
          << info;
    }
}

TEST(SensorRgbw, DngColorMatrixHasTheWRowAsTheSumOfTheOthers) {
  // The W plane's ColorMatrix2 row, as LibRaw prints it, is the sum of the R, G, B rows (its
  // response is R + G + B); those rows are the three-colour sensor's.
  SensorConfig cfg;
  cfg.cfa = "RGBW";
  const io::Image im = electronImage(32, 24, cfg);
  const std::string path = tmpDir("matrix") + "/m.dng";
  writeRawImage(path, im, 0, 0);
  int st = -1;
  const std::string info = run("raw-identify -v " + path, &st);
  ASSERT_EQ(st, 0) << info;
  SensorConfig rgb;
  const DngColor col = fitDngColor(SensorModel(rgb), 0);
  const size_t at = info.find("DNG color matrix 2:");
  ASSERT_NE(at, std::string::npos) << info;
  std::istringstream cm(info.substr(at + 19));
  std::array<double, 12> v{};
  for (double& x : v) cm >> x;
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(v[size_t(i)], col.color_matrix2[size_t(i)], 1.5e-4) << i;
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(v[size_t(9 + c)],
                col.color_matrix2[size_t(c)] + col.color_matrix2[size_t(3 + c)] +
                    col.color_matrix2[size_t(6 + c)],
                3e-4)
        << "W row, column " << c;
}

TEST(SensorRgbw, TilesDcrawCannotHoldAreRefusedForDngAndWrittenAsExr) {
  const std::string dir = tmpDir("refused");
  // Kodak's 4x4 RGBW ("CFA 2.0", half the pixels W), and a 6x6 tile with W (dcraw reads a 6x6
  // tile as X-Trans, colours 0 to 2 only).
  for (const char* cfa : {"WBWG/BWGW/WGWR/GWRW", "GGRGGB/GGBGGR/BRWRBG/GGBGGR/GGRGGB/RBGBRG"}) {
    EXPECT_FALSE(parseCfa(cfa).dngReadable()) << cfa;
    SensorConfig cfg;
    cfg.cfa = cfa;
    const io::Image im = electronImage(24, 24, cfg);
    try {
      writeRawImage(dir + "/k.dng", im, 0, 0);
      ADD_FAILURE() << cfa << " written as DNG";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("\"") + cfa + "\" would be misread"),
                std::string::npos)
          << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(dir + "/k.dng"));
    writeRawImage(dir + "/k.exr", im, 0, 0);
    const io::Image exr = io::readImage(dir + "/k.exr");
    const int electrons = exr.channelIndex("electrons").value_or(-1);
    ASSERT_GE(electrons, 0);
    for (int y = 0; y < 24; ++y)
      for (int x = 0; x < 24; ++x) {
        const char f = patternLetter(cfa, x, y);
        const float e = f == 'W' ? im.at(x, y, 0) + im.at(x, y, 1) + im.at(x, y, 2)
                                 : im.at(x, y, int(std::string("RGB").find(f)));
        ASSERT_EQ(exr.at(x, y, electrons), e) << cfa << " " << x << "," << y;
      }
  }
  // A W tile still needs R, G and B; "W" alone is "mono".
  try {
    parseCfa("WG/GW", FileLoc{"s.pbrt", 2, 5});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("s.pbrt:2:5: error: \"cfa\": \"WG/GW\" has no R filter"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(parseCfa("RGBW").text(), "RG/BW");
  EXPECT_TRUE(parseCfa("RGBW").hasW());
  EXPECT_FALSE(parseCfa("RGGB").hasW());
}

TEST(SensorRgbw, SplitRenderMergedEqualsOneRender) {
  // The film keeps three channels for an RGBW sensor too: two tiles and two sample slices
  // merged by lensim merge give the very same raw values as one render.
  const std::string dir = tmpDir("split");
  const std::string scene = dir + "/w.pbrt";
  {
    std::ofstream f(scene);
    f << "LookAt 0 0 0  0 0 1  0 1 0\n"
         "Camera \"perspective\" \"float fov\" 40\n"
         "Sampler \"independent\" \"integer pixelsamples\" 4 \"integer seed\" 5\n"
         "Film \"raw\" \"integer xresolution\" 32 \"integer yresolution\" 24\n"
         "  \"float nits\" 0.0005 \"float fnumber\" 2.8 \"float prnu\" 0.01 \"float dsnu\" 2\n"
         "  \"string cfa\" \"WG/RW/WB/GW\"\n"
         "WorldBegin\n"
         "LightSource \"infinite\" \"blackbody L\" [5000]\n"
         "LightSource \"point\" \"blackbody I\" [3000] \"float scale\" 2\n"
         "Material \"diffuse\" \"rgb reflectance\" [0.8 0.3 0.2]\n"
         "Shape \"sphere\" \"float radius\" 1\n";
  }
  using lensim::test::runLensim;
  auto decode = [&](const std::string& dng) {
    int st = -1, w = 0, h = 0;
    const auto v = parsePgm(run("dcraw -D -4 -c " + dng, &st), w, h);
    EXPECT_EQ(st, 0) << dng;
    return v;
  };
  auto r = runLensim("render -q " + scene + " -o " + dir + "/one.dng");
  ASSERT_EQ(r.status, 0) << r.out;
  for (int t = 0; t < 2; ++t) {
    r = runLensim(fmt::format("render -q --tile {}/2 {} -o {}/tile{}.exr", t, scene, dir, t));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  r = runLensim("merge -q " + dir + "/tiles.dng " + dir + "/tile0.exr " + dir + "/tile1.exr");
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* range : {"0:2", "2:4"}) {
    r = runLensim(
        fmt::format("render -q --spp-range {} {} -o {}/spp{}.exr", range, scene, dir, range[0]));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  r = runLensim("merge -q " + dir + "/spp.dng " + dir + "/spp0.exr " + dir + "/spp2.exr");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto one = decode(dir + "/one.dng");
  ASSERT_EQ(one.size(), 32u * 24u);
  EXPECT_EQ(decode(dir + "/tiles.dng"), one);
  EXPECT_EQ(decode(dir + "/spp.dng"), one);
  // Lit, and not saturated.
  int lit = 0;
  for (uint16_t v : one) lit += v > 512 + 50;
  EXPECT_GT(lit, 100);
  EXPECT_LT(*std::max_element(one.begin(), one.end()), 16383);
  // W pixels collect more than the R, G and B pixels around them (their noise-free electrons).
  r = runLensim("render -q " + scene + " -o " + dir + "/one.exr");
  ASSERT_EQ(r.status, 0) << r.out;
  const io::Image exr = io::readImage(dir + "/one.exr");
  const int electrons = exr.channelIndex("electrons").value_or(-1);
  ASSERT_GE(electrons, 0);
  double w_sum = 0, rgb_sum = 0;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      const char f = patternLetter("WG/RW/WB/GW", x, y);
      const float e = exr.at(x, y, electrons);
      const float want = f == 'W'
                             ? float(double(exr.at(x, y, 0)) + exr.at(x, y, 1) + exr.at(x, y, 2))
                             : exr.at(x, y, int(std::string("RGB").find(f)));
      ASSERT_EQ(e, want) << x << "," << y;
      (f == 'W' ? w_sum : rgb_sum) += e;
    }
  EXPECT_GT(w_sum, 1.5 * rgb_sum);
}
