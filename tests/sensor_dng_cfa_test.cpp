// Raw DNG files of colour filter arrays other than Bayer (docs/sensor.md, "Colour filter arrays"):
// X-Trans and other periodic patterns decoded bit for bit by dcraw and read by LibRaw, the
// patterns refused (with the reason) where DNG or dcraw cannot hold them, and Quad Bayer
// written as EXR or remosaiced to a Bayer DNG (also split, rendered and merged).
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
