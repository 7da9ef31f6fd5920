#include "lensim/util/file.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <atomic>
#include <filesystem>
#include <fstream>

#include "lensim/util/error.h"
#include "lensim/util/interrupt.h"

namespace lensim {

namespace fs = std::filesystem;

std::string resolveWriteTarget(const std::string& path) {
  fs::path p(path);
  for (int hops = 0; hops < 40; ++hops) {
    std::error_code ec;
    if (!fs::is_symlink(fs::symlink_status(p, ec))) return p.string();
    fs::path next = fs::read_symlink(p, ec);
    if (ec) return p.string();
    p = next.is_absolute() ? next : p.parent_path() / next;
  }
  throw Error(FileLoc{path}, "cannot write: too many levels of symbolic links");
}

namespace {

// Flushes a written file's data to disk; a full disk or I/O error shows here at the latest.
void syncFile(const std::string& file, const std::string& report_as) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    throw Error(FileLoc{report_as},
                fmt::format("cannot reopen the written file: {}", std::strerror(errno)));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || st.st_size == 0) {
    ::close(fd);
    throw Error(FileLoc{report_as}, "writing failed: the file is empty (disk full?)");
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    throw Error(FileLoc{report_as}, fmt::format("writing failed: {}", std::strerror(err)));
  }
  ::close(fd);
}

void syncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);  // best effort: some file systems refuse fsync on directories
  ::close(fd);
}

}  // namespace

uint64_t requireRegularFile(const std::string& path, std::string_view what, uint64_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw Error(FileLoc{path}, fmt::format("cannot open {}: {}", what, std::strerror(errno)));
  if (S_ISDIR(st.st_mode))
    throw Error(FileLoc{path}, fmt::format("cannot read {}: it is a directory", what));
  if (!S_ISREG(st.st_mode))
    throw Error(FileLoc{path},
                fmt::format("cannot read {}: not a regular file (a device, FIFO or socket)", what));
  const auto size = static_cast<uint64_t>(st.st_size);
  if (size > max_bytes)
    throw Error(FileLoc{path}, fmt::format("{} is too large: {} bytes, at most {} accepted", what,
                                           size, max_bytes));
  return size;
}

bool fileStartsWith(const std::string& path, std::string_view magic) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  std::string head(magic.size(), '\0');
  std::size_t got = 0;
  while (got < head.size()) {
    const ssize_t n = ::read(fd, head.data() + got, head.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return got == head.size() && head == magic;
}

std::string readRegularFile(const std::string& path, std::string_view what, uint64_t max_bytes) {
  requireRegularFile(path, what, max_bytes);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0)
    throw Error(FileLoc{path}, fmt::format("cannot open {}: {}", what, std::strerror(errno)));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw Error(FileLoc{path}, fmt::format("cannot read {}: not a regular file", what));
  }
  std::string out;
  out.reserve(
      static_cast<size_t>(std::min<uint64_t>(static_cast<uint64_t>(st.st_size), max_bytes)));
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      throw Error(FileLoc{path}, fmt::format("cannot read {}: {}", what, std::strerror(err)));
    }
    if (n == 0) break;
    if (out.size() + static_cast<size_t>(n) > max_bytes) {
      ::close(fd);
      throw Error(FileLoc{path},
                  fmt::format("{} is too large: more than {} bytes", what, max_bytes));
    }
    out.append(buf, static_cast<size_t>(n));
  }
  ::close(fd);
  return out;
}

void writeAtomically(const std::string& requested_path,
                     const std::function<void(const std::string& tmp_path)>& write) {
  static std::atomic<unsigned> counter{0};
  const std::string path = resolveWriteTarget(requested_path);
  const fs::path target(path);
  // Signals wait until the file is complete and in place (or the temporary is removed).
  CriticalScope critical;
  const std::string tmp =
      (target.parent_path() / fmt::format(".{}.tmp-{}-{}{}", target.stem().string(), ::getpid(),
                                          counter++, target.extension().string()))
          .string();
  try {
    write(tmp);
    syncFile(tmp, path);
    std::error_code ec;
    fs::rename(tmp, target, ec);
    if (ec)
      throw Error(FileLoc{path},
                  fmt::format("cannot rename the temporary file into place: {}", ec.message()));
    syncDirectory(target.parent_path());
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
