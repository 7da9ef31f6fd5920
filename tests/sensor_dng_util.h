// Helpers shared by the raw DNG tests (sensor_dng_test.cpp, sensor_dng_cfa_test.cpp,
// sensor_dng_color_test.cpp): running third-party programs, reading dcraw's PGM output, a raw
// film's electron image and the digital numbers lensim's sensor model makes of it, and the
// test's own reading of a CFA pattern.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/render/sensor/sensor_model.h"

namespace lensim::test::dng {

using render::SensorConfig;

inline std::string run(const std::string& cmd, int* status = nullptr) {
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
inline std::vector<uint16_t> parsePgm(const std::string& s, int& w, int& h) {
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

inline std::string tmpDir(const std::string& name) {
  const std::string d = ::testing::TempDir() + "/sensor_dng_" + name;
  std::filesystem::create_directories(d);
  return d;
}

// A raw film's image of w x h pixels with varied electrons per channel.
inline io::Image electronImage(int w, int h, const SensorConfig& cfg) {
  io::Image im(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = float(200 + ((x * 131 + y * 71 + c * 977) % 9000));
  im.metadata[render::kRawSensorKey] = cfg.toText();
  return im;
}

inline std::vector<uint16_t> expectedDn(const io::Image& im, const SensorConfig& cfg, int x0, int y0) {
  std::vector<float> rgb(im.pixels.begin(), im.pixels.end());
  return render::digitizeImage(render::SensorModel(cfg), rgb, im.width, im.height, x0, y0);
}

// The filter letter of pixel (x, y) of a pattern written as rows joined by '/' (the test's own
// reading of the pattern, not parseCfa's).
inline char patternLetter(const std::string& rows_text, int x, int y) {
  std::vector<std::string> rows;
  std::stringstream ss(rows_text);
  for (std::string r; std::getline(ss, r, '/');) rows.push_back(r);
  const std::string& row = rows[size_t(y) % rows.size()];
  return row[size_t(x) % row.size()];
}

// Fujifilm's X-Trans 6x6 tile (as dcraw's built-in xtrans table).
inline constexpr const char* kXTrans = "GGRGGB/GGBGGR/BRGRBG/GGBGGR/GGRGGB/RBGBRG";


}  // namespace lensim::test::dng
