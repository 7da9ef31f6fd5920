// Cost of reading textures and environment maps (issue 12: images through OpenImageIO): a
// 4096 x 2048 RGB image in the formats scenes use (8-bit PNG, 16-bit TIFF, 32-bit float EXR),
// written once into a temporary directory, then read with io::readImage per iteration.
// Run: cmake --build build --target lensim_bench_image && build/bench/lensim_bench_image
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include "lensim/io/image.h"

using namespace lensim;
namespace fs = std::filesystem;

namespace {

constexpr int kWidth = 4096, kHeight = 2048;

// A smooth image with some detail (compressors neither collapse it nor give up on it).
const std::string& imageFile(const std::string& ext) {
  static const fs::path dir =
      fs::temp_directory_path() / ("lensim_bench_image_" + std::to_string(::getpid()));
  static std::map<std::string, std::string> files;
  auto it = files.find(ext);
  if (it != files.end()) return it->second;
  fs::create_directories(dir);
  io::Image im(kWidth, kHeight, {"R", "G", "B"});
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      im.at(x, y, 0) = 0.5f + 0.5f * std::sin(x * 0.01f) * std::cos(y * 0.013f);
      im.at(x, y, 1) = float(x) / kWidth;
      im.at(x, y, 2) = float((x * 7 + y * 13) % 256) / 255.0f;
    }
  const std::string path = (dir / ("texture" + ext)).string();
  io::ImageWriteOptions o;
  o.tiff_format = io::TiffSampleFormat::UInt16;
  io::writeImage(path, im, o);
  return files.emplace(ext, path).first->second;
}

void readFormat(benchmark::State& state, const std::string& ext) {
  const std::string& path = imageFile(ext);
  for (auto _ : state) {
    io::Image im = io::readImage(path);
    benchmark::DoNotOptimize(im.pixels.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t{kWidth} * kHeight);
}

void BM_ReadPng8(benchmark::State& s) {
  readFormat(s, ".png");
}
void BM_ReadTiff16(benchmark::State& s) {
  readFormat(s, ".tif");
}
void BM_ReadExrFloat(benchmark::State& s) {
  readFormat(s, ".exr");
}

BENCHMARK(BM_ReadPng8)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ReadTiff16)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_ReadExrFloat)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
