// The lens and scene folders the explorer serves, and the only way a request names a file:
// an id (a path relative to one configured folder) that must resolve to a regular file inside
// that folder. Nothing a client sends is used as a path without going through resolve().
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

namespace lensim::serve {

/// A request that names a file outside the folders, a file that is not there, or a malformed
/// id. `status` is the HTTP status the server answers with (400, 403 or 404).
struct PathError {
  int status;
  std::string message;
};

/// Resolves `relative` (a client-supplied id, '/'-separated) inside `root`. Refuses empty ids,
/// absolute paths, "..", backslashes and control characters (400), anything whose canonical
/// path (symbolic links followed) leaves the canonical root (403), and anything that is not a
/// regular file with one of `extensions` (lower case, with the dot) (404). Returns the canonical
/// path, or the error.
std::variant<std::filesystem::path, PathError> resolveInside(
    const std::filesystem::path& root, const std::string& relative,
    const std::set<std::string>& extensions);

/// One lens file of the catalogue. `error` is set (and the optical numbers are not) when
/// optics::readLensFile cannot read or focus it; such files are listed so the user sees why.
struct LensEntry {
  std::string id;      ///< what requests name it by
  std::string folder;  ///< the configured folder it is in
  std::string format;  ///< file extension without the dot: dat, zmx, json
  std::string name;    ///< the prescription's name (first comment line or file name)
  std::optional<double> focal_length_mm, f_number, stop_diameter_mm;
  int surface_count = 0;
  std::string error;
};

/// Every .dat, .zmx and .json file under the configured lens folders (recursively, up to
/// kMaxDepth levels and kMaxFiles files), each read through optics::readLensFile. Ids are the
/// path relative to the folder; with several folders the second and later ones prefix "N:".
class LensCatalog {
 public:
  static constexpr int kMaxDepth = 4;
  static constexpr int kMaxFiles = 2000;
  static const std::set<std::string>& extensions();

  /// Throws lensim::Error if a folder does not exist.
  explicit LensCatalog(std::vector<std::string> folders);

  const std::vector<std::filesystem::path>& folders() const { return folders_; }

  /// The listing, read again when a file's size or modification time changed.
  std::vector<LensEntry> list() const;

  /// The file an id names (see resolveInside), or the error.
  std::variant<std::filesystem::path, PathError> resolve(const std::string& id) const;

  /// The id of a file inside one of the folders, if it is inside one.
  std::optional<std::string> idOf(const std::filesystem::path& file) const;

 private:
  std::vector<std::filesystem::path> folders_;  ///< canonical
  struct Cached {
    std::uintmax_t size = 0;
    std::filesystem::file_time_type mtime;
    LensEntry entry;
  };
  mutable std::mutex mutex_;
  mutable std::map<std::string, Cached> cache_;  ///< by canonical path
};

}  // namespace lensim::serve
