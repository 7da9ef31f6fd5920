// Runtime checks of invariants (pbrt-v4's CHECK and DCHECK): a condition that holds unless
// lensim itself is wrong, never a check of input (bad input is a lensim::Error naming its
// location). A failed check prints "FILE:LINE: internal error: check failed: CONDITION" to
// stderr and aborts.
// - CHECK(cond) is always on: for cold code (set-up, per tile), where it costs nothing measurable.
// - DCHECK(cond) is on in builds configured with LENSIM_DCHECKS=ON (the default for Debug and
//   sanitizer builds, off for Release): for hot loops (per sample, per ray). Off, the condition
//   is not evaluated (but still compiled, so it cannot rot).
#pragma once

namespace lensim {

/// Reports a failed CHECK or DCHECK and aborts.
[[noreturn]] void checkFailed(const char* condition, const char* file, int line);

}  // namespace lensim

#define CHECK(cond) \
  ((cond) ? static_cast<void>(0) : ::lensim::checkFailed(#cond, __FILE__, __LINE__))

#ifdef LENSIM_DCHECKS
#define DCHECK(cond) CHECK(cond)
#else
#define DCHECK(cond) static_cast<void>(sizeof(static_cast<bool>(cond)))
#endif
