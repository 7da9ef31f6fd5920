#include "lensim/util/limits.h"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>

namespace lensim {

namespace {
std::atomic<uint64_t> g_budget{0};  // 0: not set, use the default
}  // namespace

uint64_t physicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return 0;
  return static_cast<uint64_t>(pages) * static_cast<uint64_t>(page);
}

uint64_t memoryBudgetBytes() {
  if (uint64_t b = g_budget.load()) return b;
  const uint64_t phys = physicalMemoryBytes();
  return phys ? phys / 2 : (uint64_t{8} << 30);
}

void setMemoryBudgetBytes(uint64_t bytes) {
  g_budget.store(bytes);
}

std::optional<uint64_t> parseMemorySize(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
    text.remove_suffix(1);
  double v = 0;
  auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || !std::isfinite(v) || v <= 0) return std::nullopt;
  std::string unit(ptr, text.data() + text.size());
  for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (!unit.empty() && unit.front() == ' ') unit.erase(0, 1);
  double scale = 0;
  if (unit.empty() || unit == "B")
    scale = 1;
  else if (unit == "K" || unit == "KB" || unit == "KIB")
    scale = 1024.0;
  else if (unit == "M" || unit == "MB" || unit == "MIB")
    scale = 1024.0 * 1024;
  else if (unit == "G" || unit == "GB" || unit == "GIB")
    scale = 1024.0 * 1024 * 1024;
  else if (unit == "T" || unit == "TB" || unit == "TIB")
    scale = 1024.0 * 1024 * 1024 * 1024;
  else
    return std::nullopt;
  const double bytes = v * scale;
  if (bytes < 1 || bytes > 1.8e19) return std::nullopt;
  return static_cast<uint64_t>(bytes);
}

std::string formatBytes(double bytes) {
  if (!(bytes < 1e30)) return "an unbounded amount of memory";
  if (bytes >= 1024.0 * 1024 * 1024)
    return fmt::format("{:.1f} GiB", bytes / (1024.0 * 1024 * 1024));
  if (bytes >= 1024.0 * 1024) return fmt::format("{:.1f} MiB", bytes / (1024.0 * 1024));
  if (bytes >= 1024.0) return fmt::format("{:.1f} KiB", bytes / 1024.0);
  return fmt::format("{:.0f} bytes", bytes);
}

void checkMemory(double bytes, const FileLoc& loc, std::string_view what) {
  const uint64_t budget = memoryBudgetBytes();
  if (!(bytes <= static_cast<double>(budget)))
    throw Error(loc,
                fmt::format("{} needs about {}, more than the memory limit of {} "
                            "(--memory-limit)",
                            what, formatBytes(bytes), formatBytes(static_cast<double>(budget))));
}

std::optional<uint64_t> checkedMul(uint64_t a, uint64_t b) {
  uint64_t r = 0;
  if (__builtin_mul_overflow(a, b, &r)) return std::nullopt;
  return r;
}

std::optional<uint64_t> checkedAdd(uint64_t a, uint64_t b) {
  uint64_t r = 0;
  if (__builtin_add_overflow(a, b, &r)) return std::nullopt;
  return r;
}

void requireFinite(double value, const FileLoc& loc, std::string_view what, double max_abs) {
  if (!std::isfinite(value))
    throw Error(loc, fmt::format("expected a finite number{}{}, found {}",
                                 what.empty() ? "" : " for ", what, value));
  if (std::abs(value) > max_abs)
    throw Error(loc,
                fmt::format("{}{:g} is out of range; expected a magnitude <= {:g}",
                            what.empty() ? "number " : fmt::format("{} ", what), value, max_abs));
}

void requireInRange(double value, double lo, double hi, const FileLoc& loc, std::string_view what) {
  if (!(value >= lo && value <= hi))
    throw Error(loc, fmt::format("{} {:g} is out of range; expected a value in [{:g}, {:g}]", what,
                                 value, lo, hi));
}

}  // namespace lensim
