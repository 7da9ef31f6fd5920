// Helpers shared by the scene tests.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "lensim/scene/description.h"
#include "lensim/scene/parser.h"

namespace lensim::testutil {

/// A fresh empty directory under the system temp directory, removed by the destructor.
class TempDir {
 public:
  explicit TempDir(const std::string& name) {
    // Unique per process: tests run in parallel, possibly from several checkouts.
    path_ = std::filesystem::temp_directory_path() /
            (name + "-" + std::to_string(static_cast<long>(getpid())));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::string p = file(name);
    std::filesystem::create_directories(std::filesystem::path(p).parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Builds scene text (file name "test.pbrt" in the current directory unless given).
inline scene::Scene buildText(const std::string& text, const std::string& name = "test.pbrt") {
  return scene::build(scene::parseString(text, name));
}

/// The errors of a built scene, one per line.
inline std::string errorsOf(const scene::Scene& s) {
  std::string out;
  for (const Diagnostic& d : s.diagnostics)
    if (d.severity == Severity::Error) out += d.str() + "\n";
  return out;
}

}  // namespace lensim::testutil
