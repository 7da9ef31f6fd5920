#include "lensim/util/file.h"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>

#include "lensim/util/error.h"

namespace lensim {

namespace fs = std::filesystem;

void writeAtomically(const std::string& path,
                     const std::function<void(const std::string& tmp_path)>& write) {
  static std::atomic<unsigned> counter{0};
  const fs::path target(path);
  const std::string tmp =
      (target.parent_path() / fmt::format(".{}.tmp-{}-{}{}", target.stem().string(), ::getpid(),
                                          counter++, target.extension().string()))
          .string();
  try {
    write(tmp);
    std::error_code ec;
    fs::rename(tmp, target, ec);
    if (ec)
      throw Error(FileLoc{path},
                  fmt::format("cannot rename the temporary file into place: {}", ec.message()));
  } catch (const std::exception& e) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    // Errors from the writer name the temporary file; report the destination instead.
    if (auto* err = dynamic_cast<const Error*>(&e)) {
      if (err->loc().file == path) throw;
      throw Error(FileLoc{path}, err->message());
    }
    throw Error(FileLoc{path}, fmt::format("cannot write file: {}", e.what()));
  }
}

void writeFileAtomically(const std::string& path, std::string_view content) {
  writeAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(FileLoc{path}, "cannot write file (directory missing or not writable)");
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) throw Error(FileLoc{path}, "writing failed");
  });
}

}  // namespace lensim
