// lensim_fuzz_replay [CORPUS_ROOT] [TARGET...]: runs every file of fuzz/corpus/<target>/ through
// its fuzz target (targets.h) in the ordinary build, so that the test suite replays the seed
// corpora and every crash input saved there without clang or libFuzzer. Prints per target the
// number of inputs and the slowest one; exits 1 if a target throws anything but lensim::Error
// (a crash ends the process, which ctest reports).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "targets.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  const fs::path root = argc > 1 ? fs::path(argv[1]) : fs::path(LENSIM_FUZZ_CORPUS);
  std::vector<std::string> only(argv + std::min(argc, 2), argv + argc);
  size_t n = 0;
  const lensim::fuzz::Target* targets = lensim::fuzz::targets(n);
  int failures = 0;
  size_t total = 0;
  for (size_t t = 0; t < n; ++t) {
    const auto& target = targets[t];
    if (!only.empty() &&
        std::find(only.begin(), only.end(), std::string(target.name)) == only.end())
      continue;
    const fs::path dir = root / std::string(target.name);
    if (!fs::is_directory(dir)) {
      std::fprintf(stderr, "%s: no corpus folder %s\n", std::string(target.name).c_str(),
                   dir.c_str());
      ++failures;
      continue;
    }
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    double slowest = 0;
    std::string slowest_name;
    for (const fs::path& f : files) {
      std::ifstream in(f, std::ios::binary);
      const std::string data((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      const auto t0 = std::chrono::steady_clock::now();
      try {
        target.run(reinterpret_cast<const uint8_t*>(data.data()), data.size());
      } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: %s: unexpected exception: %s\n", std::string(target.name).c_str(),
                     f.c_str(), e.what());
        ++failures;
      }
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (s > slowest) slowest = s, slowest_name = f.filename().string();
    }
    total += files.size();
    std::printf("%-14s %5zu inputs, slowest %.3f s (%s)\n", std::string(target.name).c_str(),
                files.size(), slowest, slowest_name.c_str());
  }
  std::printf("%zu inputs replayed, %d failures\n", total, failures);
  return failures ? 1 : 0;
}
