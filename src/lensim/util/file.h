// Writing files so that a failure never leaves a half-written file behind: everything is written
// to a temporary name in the same directory, then renamed into place.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace lensim {

/// Calls `write` with a unique temporary path beside `path` (same extension, so libraries that
/// pick a format by extension still work), flushes it to disk (fsync), then renames it to `path`
/// (to the target of `path` when it is a symbolic link, see resolveWriteTarget). SIGINT and
/// SIGTERM wait until the rename is done (see util/interrupt.h). If `write` throws or the
/// rename fails, the temporary file is removed and lensim::Error (naming `path`) is thrown.
void writeAtomically(const std::string& path,
                     const std::function<void(const std::string& tmp_path)>& write);

/// Where writing `path` should go: `path` itself, or the final target when `path` is a symbolic
/// link (a chain of links is followed; a dangling link gives the path it points to), so that
/// writing through a link updates its target instead of replacing the link.
std::string resolveWriteTarget(const std::string& path);

/// The largest file a reader accepts unless it says otherwise (1 GiB).
inline constexpr uint64_t kDefaultMaxFileBytes = uint64_t{1} << 30;

/// Throws Error (at FileLoc{path}) unless `path` names a regular file (after symbolic links) of
/// at most `max_bytes`: a directory, FIFO, device (/dev/zero), socket or missing file is refused
/// with the reason ("cannot open lens file: Too many levels of symbolic links"). `what` names the
/// file's role ("lens file"). Returns the size in bytes.
uint64_t requireRegularFile(const std::string& path, std::string_view what,
                            uint64_t max_bytes = kDefaultMaxFileBytes);

/// requireRegularFile, then the whole content. The file is opened without blocking and checked
/// again once open (fstat), so a FIFO swapped in between cannot hang the read.
std::string readRegularFile(const std::string& path, std::string_view what,
                            uint64_t max_bytes = kDefaultMaxFileBytes);

/// True when `path` is a readable regular file whose first bytes are `magic` (never blocks on a
/// FIFO or device; false for anything that cannot be read).
bool fileStartsWith(const std::string& path, std::string_view magic);

/// Writes `content` to `path` atomically (see writeAtomically).
void writeFileAtomically(const std::string& path, std::string_view content);

}  // namespace lensim
