// Scratch memory for the BxDFs a material makes at every surface hit: each thread bump-allocates
// them from a block of its own, and the block is reused from its start as soon as every BxDF
// made from it has been released (in practice at every bounce and every sample, since a path
// holds its BSDFs only while it is traced). BxDFs stay std::shared_ptr<const BxDF> (made by
// std::allocate_shared), so holders need not know where they live; one that does not fit in
// the block falls back to the heap. A BxDF must be released on the thread that made it.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <utility>

#include "lensim/render/materials/bsdf.h"

namespace lensim::render {

/// A bump allocator over one fixed block that rewinds when nothing allocated from it is live.
class ScratchArena {
 public:
  static constexpr size_t kBytes = 64 * 1024;
  /// This thread's arena.
  static ScratchArena& local();
  void* allocate(size_t bytes, size_t align);
  void deallocate(void* p, size_t bytes, size_t align) noexcept;
  /// Allocations from the block not yet released (for tests).
  size_t live() const { return live_; }
  /// Whether p lies in the block (for tests).
  bool owns(const void* p) const { return p >= block_ && p < block_ + kBytes; }

 private:
  alignas(std::max_align_t) std::byte block_[kBytes];
  size_t used_ = 0;  ///< bytes of the block in use, counted from its start
  size_t live_ = 0;
};

/// A standard allocator over a ScratchArena, for std::allocate_shared.
template <class T>
struct ScratchAllocator {
  using value_type = T;
  ScratchArena* arena;
  explicit ScratchAllocator(ScratchArena& a) : arena(&a) {}
  template <class U>
  ScratchAllocator(const ScratchAllocator<U>& o) : arena(o.arena) {}  // NOLINT: rebinding
  T* allocate(size_t n) { return static_cast<T*>(arena->allocate(n * sizeof(T), alignof(T))); }
  void deallocate(T* p, size_t n) noexcept { arena->deallocate(p, n * sizeof(T), alignof(T)); }
  template <class U>
  bool operator==(const ScratchAllocator<U>& o) const {
    return arena == o.arena;
  }
};

/// A BxDF of type T made in this thread's scratch arena.
template <class T, class... Args>
std::shared_ptr<const BxDF> makeBxDF(Args&&... args) {
  return std::allocate_shared<T>(ScratchAllocator<T>(ScratchArena::local()),
                                 std::forward<Args>(args)...);
}

}  // namespace lensim::render
