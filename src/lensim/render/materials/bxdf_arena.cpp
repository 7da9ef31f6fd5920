// The per-thread BxDF scratch arena (bxdf_arena.h).
#include "lensim/render/materials/bxdf_arena.h"

namespace lensim::render {

ScratchArena& ScratchArena::local() {
  static thread_local ScratchArena arena;
  return arena;
}

void* ScratchArena::allocate(size_t bytes, size_t align) {
  const size_t start = (used_ + align - 1) / align * align;
  if (align <= alignof(std::max_align_t) && start <= kBytes && bytes <= kBytes - start) {
    used_ = start + bytes;
    ++live_;
    return block_ + start;
  }
  return ::operator new(bytes, std::align_val_t(align));
}

void ScratchArena::deallocate(void* p, size_t bytes, size_t align) noexcept {
  if (!owns(p)) {
    ::operator delete(p, bytes, std::align_val_t(align));
    return;
  }
  if (--live_ == 0) used_ = 0;
}

}  // namespace lensim::render
