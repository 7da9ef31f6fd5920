#include "lensim/optics/glass/library.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <mutex>

namespace lensim::optics {

namespace {

struct Library {
  std::mutex mutex;
  std::vector<std::string> paths;  // canonical, in the order added
  std::vector<GlassCatalog> catalogs;
  std::vector<std::unique_ptr<const GlassCatalog>> snapshots;  // every library built; kept
  const GlassCatalog* current = nullptr;
};

Library& library() {
  static Library lib;
  return lib;
}

std::atomic<bool> g_model_glass{false};
std::atomic<bool> g_extrapolate{false};

// The catalogue files LENSIM_GLASS_PATH names.
std::vector<std::string> envCatalogFiles() {
  std::vector<std::string> files;
  const char* env = std::getenv("LENSIM_GLASS_PATH");
  if (!env) return files;
  const std::string s(env);
  size_t pos = 0;
  while (pos <= s.size()) {
    size_t end = s.find(':', pos);
    if (end == std::string::npos) end = s.size();
    const std::string entry = s.substr(pos, end - pos);
    pos = end + 1;
    if (entry.empty()) continue;
    std::error_code ec;
    if (std::filesystem::is_directory(entry, ec)) {
      std::vector<std::string> in_dir;
      for (const auto& de : std::filesystem::directory_iterator(entry, ec)) {
        std::string ext = de.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(),
                       [](unsigned char c) { return char(std::tolower(c)); });
        if (ext == ".agf") in_dir.push_back(de.path().string());
      }
      std::sort(in_dir.begin(), in_dir.end());
      files.insert(files.end(), in_dir.begin(), in_dir.end());
    } else if (std::filesystem::exists(entry, ec)) {
      files.push_back(entry);
    } else {
      throw Error(fmt::format("LENSIM_GLASS_PATH: '{}' is neither a glass catalogue file nor a "
                              "folder",
                              entry));
    }
  }
  return files;
}

}  // namespace

void addGlassCatalogFile(const std::string& path, const FileLoc& named_at) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(named_at, fmt::format("glass catalogue '{}': no such file", path));
  const std::string canonical = std::filesystem::weakly_canonical(path, ec).string();
  Library& lib = library();
  {
    std::lock_guard lock(lib.mutex);
    if (std::find(lib.paths.begin(), lib.paths.end(), canonical) != lib.paths.end()) return;
  }
  GlassCatalog cat = GlassCatalog::load(path);  // parse outside the lock
  std::lock_guard lock(lib.mutex);
  if (std::find(lib.paths.begin(), lib.paths.end(), canonical) != lib.paths.end()) return;
  lib.paths.push_back(canonical);
  lib.catalogs.push_back(std::move(cat));
  lib.current = nullptr;
}

const GlassCatalog& glassLibrary() {
  Library& lib = library();
  std::lock_guard lock(lib.mutex);
  if (lib.current) return *lib.current;
  static const std::vector<GlassCatalog> env = [] {
    std::vector<GlassCatalog> v;
    for (const std::string& f : envCatalogFiles()) v.push_back(GlassCatalog::load(f));
    return v;
  }();
  if (lib.catalogs.empty() && env.empty()) {
    lib.current = &GlassCatalog::builtin();
    return *lib.current;
  }
  auto all = std::make_unique<GlassCatalog>();
  for (const GlassCatalog& c : lib.catalogs) all->append(c);
  for (const GlassCatalog& c : env) all->append(c);
  all->append(GlassCatalog::builtin());
  lib.current = all.get();
  lib.snapshots.push_back(std::move(all));
  return *lib.current;
}

void setModelGlassAllowed(bool allowed) { g_model_glass = allowed; }
bool modelGlassAllowed() { return g_model_glass; }
void setGlassExtrapolationAllowed(bool allowed) { g_extrapolate = allowed; }
bool glassExtrapolationAllowed() { return g_extrapolate; }

void checkGlassRange(const Glass& glass, double lambda_nm, const FileLoc& loc,
                     const std::string& what, std::vector<Diagnostic>* diagnostics) {
  if (!glass.dispersive() || glass.inRange(lambda_nm)) return;
  const std::string msg =
      fmt::format("{} {} nm is outside the valid range of {} ({}-{} nm, its catalogue's)", what,
                  lambda_nm, glass.describe(), glass.minWavelength_nm(), glass.maxWavelength_nm());
  if (!glassExtrapolationAllowed())
    throw Error(loc, msg + "; --glass-extrapolate uses the formula there anyway");
  if (diagnostics)
    diagnostics->push_back({Severity::Warning, loc, msg + "; its formula is used there anyway"});
}

void checkRenderGlassRanges(const std::vector<Glass>& glasses, double from_nm, double to_nm,
                            const std::string& lens, std::vector<Diagnostic>* diagnostics) {
  std::vector<std::string> seen, extended;
  for (const Glass& g : glasses) {
    if (!g.dispersive()) continue;
    const double lo = g.minWavelength_nm(), hi = g.maxWavelength_nm();
    if (lo <= from_nm && hi >= to_nm) continue;
    const std::string what = fmt::format("{} ({:g}-{:g} nm)", g.describe(), lo, hi);
    if (std::find(seen.begin(), seen.end(), what) != seen.end()) continue;
    seen.push_back(what);
    // 1e-9 nm: a range given in micrometres (0.7) and scaled may fall short by rounding.
    if (lo <= kRenderGlassFrom_nm + 1e-9 && hi >= kRenderGlassTo_nm - 1e-9) {
      extended.push_back(what);
      continue;
    }
    const std::string msg =
        fmt::format("glass {} is valid for {:g}-{:g} nm only; renders trace {:g}-{:g} nm and need "
                    "a glass valid over {:g}-{:g} nm at least",
                    g.describe(), lo, hi, from_nm, to_nm, kRenderGlassFrom_nm, kRenderGlassTo_nm);
    if (!glassExtrapolationAllowed())
      throw Error(msg + "; --glass-extrapolate uses its formula there anyway");
    if (diagnostics)
      diagnostics->push_back(
          {Severity::Warning, FileLoc{lens}, msg + "; its formula is used there anyway"});
  }
  if (extended.empty() || !diagnostics) return;
  std::string list;
  for (const std::string& e : extended) list += (list.empty() ? "" : ", ") + e;
  diagnostics->push_back(
      {Severity::Note, FileLoc{lens},
       fmt::format("renders trace {:g}-{:g} nm: the formulas of {} are used there beyond "
                   "their valid ranges, which span {:g}-{:g} nm (docs/glass.md)",
                   from_nm, to_nm, list, kRenderGlassFrom_nm, kRenderGlassTo_nm)});
}

}  // namespace lensim::optics
