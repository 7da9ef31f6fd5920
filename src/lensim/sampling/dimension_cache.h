// A sampler's per-pixel, per-dimension cache: values that depend only on (seed, pixel,
// dimension), such as a dimension's permutation and scrambling keys, computed once per pixel and
// dimension (a pixel's samples follow each other in the render loop) and reused by its samples.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lensim::sampling {

/// Dimensions below this get their per-(pixel, dimension) work cached for the current pixel by
/// the samplers that cache it; from here on it is recomputed at every draw.
inline constexpr int kSamplerCachedDimensions = 256;

/// The values of type `Value` of each dimension for the current pixel. An entry is valid while
/// its stamp equals the cache's, so a new pixel invalidates every entry in O(1); dimensions from
/// kSamplerCachedDimensions on share one scratch entry, remade at every lookup.
template <class Value>
class DimensionCache {
 public:
  /// Invalidates every entry: the next lookup of each dimension remakes its value.
  void newPixel() {
    if (++stamp_ == 0) {  // wrapped: clear the stamps, so that no old entry reads as valid
      for (Entry& e : entries_) e.stamp = 0;
      stamp_ = 1;
    }
  }

  /// The value of dimension `dim` (>= 0) for the current pixel; `make()` returns it where it is
  /// not cached yet.
  template <class Make>
  const Value& get(int dim, Make&& make) {
    const size_t d = static_cast<size_t>(dim);
    Entry* e = &scratch_;
    if (d < kSamplerCachedDimensions) {
      if (d >= entries_.size()) entries_.resize(d + 1);
      e = &entries_[d];
      if (e->stamp == stamp_) return e->value;
      e->stamp = stamp_;
    }
    e->value = make();
    return e->value;
  }

 private:
  struct Entry {
    Value value{};
    uint32_t stamp = 0;  ///< valid for the current pixel where stamp == stamp_ (0: never written)
  };
  std::vector<Entry> entries_;
  Entry scratch_;
  uint32_t stamp_ = 1;
};

}  // namespace lensim::sampling
