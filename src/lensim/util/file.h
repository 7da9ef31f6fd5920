// Writing files so that a failure never leaves a half-written file behind: everything is written
// to a temporary name in the same directory, then renamed into place.
#pragma once

#include <functional>
#include <string>
#include <string_view>

namespace lensim {

/// Calls `write` with a unique temporary path beside `path` (same extension, so libraries that
/// pick a format by extension still work), then renames it to `path`. If `write` throws or the
/// rename fails, the temporary file is removed and lensim::Error (naming `path`) is thrown.
void writeAtomically(const std::string& path,
                     const std::function<void(const std::string& tmp_path)>& write);

/// Writes `content` to `path` atomically (see writeAtomically).
void writeFileAtomically(const std::string& path, std::string_view content);

}  // namespace lensim
