// Limits on what one input may cost: a memory budget checked before large allocations, checked
// arithmetic for sizes derived from file contents, and finite-number rules for values read from
// files. Readers call these before they allocate, so a small file that claims a huge size is
// refused with an estimate instead of exhausting the machine.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "lensim/util/error.h"

namespace lensim {

/// Physical memory of this machine in bytes (0 when unknown).
uint64_t physicalMemoryBytes();

/// The memory budget for one lensim run: by default half the physical memory (8 GiB when that
/// is unknown); `lensim --memory-limit SIZE` changes it.
uint64_t memoryBudgetBytes();
void setMemoryBudgetBytes(uint64_t bytes);

/// Parses "512M", "8G", "1.5GiB", "123456" (bytes) into bytes; nullopt when malformed.
std::optional<uint64_t> parseMemorySize(std::string_view text);

/// "1.5 GiB", "12.0 MiB", "512 bytes".
std::string formatBytes(double bytes);

/// Throws Error (at `loc`) when `bytes` exceeds the memory budget:
/// "<what> needs about 4.7 GiB, more than the memory limit of 2.0 GiB (--memory-limit)".
void checkMemory(double bytes, const FileLoc& loc, std::string_view what);

/// a * b for sizes; nullopt on overflow.
std::optional<uint64_t> checkedMul(uint64_t a, uint64_t b);
/// a + b for sizes; nullopt on overflow.
std::optional<uint64_t> checkedAdd(uint64_t a, uint64_t b);

/// The largest magnitude a number read from a scene may have: numbers become 32-bit floats in
/// the renderer, so anything beyond FLT_MAX would turn into infinity.
inline constexpr double kMaxSceneNumber = 3.4028234663852886e38;

/// The most samples per pixel a render takes (2^24): beyond it sample indices and counts overflow
/// 32-bit integers in the samplers, and such a render would take years anyway.
inline constexpr int64_t kMaxSamplesPerPixel = int64_t{1} << 24;

/// Throws Error at `loc` unless `value` is finite (and |value| <= max_abs):
/// "expected a finite number for <what>, found inf" (what may be empty).
void requireFinite(double value, const FileLoc& loc, std::string_view what,
                   double max_abs = kMaxSceneNumber);

/// Throws Error at `loc` unless lo <= value <= hi (and finite):
/// "<what> 1e+300 is out of range; expected a value in [1e-06, 1e+06]".
void requireInRange(double value, double lo, double hi, const FileLoc& loc, std::string_view what);

}  // namespace lensim
