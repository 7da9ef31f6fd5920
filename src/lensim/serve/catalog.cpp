#include "lensim/serve/catalog.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "lensim/optics/focus.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"

namespace lensim::serve {

namespace fs = std::filesystem;

namespace {

std::string lowerExtension(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

bool isInside(const fs::path& root, const fs::path& p) {
  auto r = root.begin(), q = p.begin();
  for (; r != root.end(); ++r, ++q)
    if (q == p.end() || *r != *q) return false;
  return q != p.end();  // strictly below the root
}

LensEntry readEntry(const fs::path& file) {
  LensEntry e;
  e.format = lowerExtension(file).substr(1);
  e.name = file.stem().string();
  try {
    optics::FocusedLens fl = optics::focusLens(optics::readLensFile(file.string()), {});
    e.name = fl.lens->prescription().name;
    e.surface_count = fl.lens->surfaceCount();
    e.focal_length_mm = fl.paraxial.effective_focal_length_mm;
    e.f_number = fl.paraxial.f_number;
    e.stop_diameter_mm = fl.paraxial.aperture_stop_diameter_mm;
  } catch (const std::exception& ex) {
    e.error = ex.what();
  }
  return e;
}

}  // namespace

std::variant<fs::path, PathError> resolveInside(const fs::path& root, const std::string& relative,
                                                const std::set<std::string>& extensions) {
  if (relative.empty()) return PathError{400, "empty file name"};
  if (relative.size() > 1024) return PathError{400, "file name too long"};
  for (unsigned char c : relative)
    if (c < 0x20 || c == 0x7f || c == '\\')
      return PathError{400, "file name with a control character or a backslash"};
  if (relative.front() == '/')
    return PathError{403, fmt::format("'{}': absolute paths are not served", relative)};
  const fs::path rel(relative);
  for (const fs::path& part : rel)
    if (part == "..")
      return PathError{403, fmt::format("'{}': '..' may not leave the folder", relative)};
  std::error_code ec;
  const fs::path full = fs::weakly_canonical(root / rel, ec);
  if (ec) return PathError{404, fmt::format("'{}': no such file", relative)};
  if (!isInside(root, full))
    return PathError{403, fmt::format("'{}' is outside the served folder", relative)};
  if (!fs::is_regular_file(full, ec))
    return PathError{404, fmt::format("'{}': no such file", relative)};
  if (!extensions.count(lowerExtension(full)))
    return PathError{404, fmt::format("'{}': not a served file type", relative)};
  return full;
}

const std::set<std::string>& LensCatalog::extensions() {
  static const std::set<std::string> e{".dat", ".zmx", ".json"};
  return e;
}

LensCatalog::LensCatalog(std::vector<std::string> folders) {
  for (const std::string& f : folders) {
    std::error_code ec;
    fs::path c = fs::canonical(f, ec);
    if (ec || !fs::is_directory(c)) throw Error(fmt::format("lens folder '{}' does not exist", f));
    folders_.push_back(c);
  }
}

std::vector<LensEntry> LensCatalog::list() const {
  std::vector<LensEntry> out;
  for (size_t i = 0; i < folders_.size(); ++i) {
    std::vector<fs::path> files;
    std::error_code ec;
    fs::recursive_directory_iterator it(folders_[i],
                                        fs::directory_options::follow_directory_symlink |
                                            fs::directory_options::skip_permission_denied,
                                        ec);
    for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (it.depth() >= kMaxDepth) it.disable_recursion_pending();
      if (it->is_regular_file(ec) && extensions().count(lowerExtension(it->path())))
        files.push_back(it->path());
      if (files.size() >= size_t(kMaxFiles)) break;
    }
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      const fs::path full = fs::weakly_canonical(f, ec);
      if (ec || !isInside(folders_[i], full)) continue;  // a link that leaves the folder
      const auto size = fs::file_size(full, ec);
      const auto mtime = fs::last_write_time(full, ec);
      if (ec) continue;
      LensEntry e;
      {
        std::lock_guard lock(mutex_);
        auto c = cache_.find(full.string());
        if (c != cache_.end() && c->second.size == size && c->second.mtime == mtime)
          e = c->second.entry;
      }
      if (e.format.empty()) {
        e = readEntry(full);
        std::lock_guard lock(mutex_);
        cache_[full.string()] = {size, mtime, e};
      }
      const std::string rel = f.lexically_relative(folders_[i]).generic_string();
      e.id = i == 0 ? rel : fmt::format("{}:{}", i, rel);
      e.folder = folders_[i].string();
      out.push_back(std::move(e));
    }
  }
  return out;
}

std::variant<fs::path, PathError> LensCatalog::resolve(const std::string& id) const {
  size_t folder = 0;
  std::string rel = id;
  const size_t colon = id.find(':');
  if (colon != std::string::npos && colon > 0 &&
      std::all_of(id.begin(), id.begin() + colon,
                  [](char c) { return std::isdigit(uint8_t(c)); })) {
    folder = std::stoul(id.substr(0, std::min<size_t>(colon, 6)));
    rel = id.substr(colon + 1);
    if (folder == 0 || folder >= folders_.size())
      return PathError{404, fmt::format("lens '{}': no lens folder {}", id, folder)};
  }
  auto r = resolveInside(folders_[folder], rel, extensions());
  if (auto* e = std::get_if<PathError>(&r)) e->message = "lens " + e->message;
  return r;
}

std::optional<std::string> LensCatalog::idOf(const fs::path& file) const {
  std::error_code ec;
  const fs::path full = fs::weakly_canonical(file, ec);
  if (ec) return std::nullopt;
  for (size_t i = 0; i < folders_.size(); ++i)
    if (isInside(folders_[i], full)) {
      const std::string rel = full.lexically_relative(folders_[i]).generic_string();
      return i == 0 ? rel : fmt::format("{}:{}", i, rel);
    }
  return std::nullopt;
}

}  // namespace lensim::serve
