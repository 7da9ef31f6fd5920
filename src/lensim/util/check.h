// Runtime checks of invariants (pbrt-v4's CHECK and DCHECK): a condition that holds unless
// lensim itself is wrong, never a check of input (bad input is a lensim::Error naming its
// location). A failed check prints "FILE:LINE: internal error: check failed: CONDITION" to
// stderr, followed for the comparison forms by the values compared ("(a = 1.5, b = 0)"), and
// aborts.
// - LENSIM_CHECK(cond) and the comparisons LENSIM_CHECK_EQ, _NE, _LT, _LE, _GT, _GE (a, b),
//   LENSIM_CHECK_NEAR(a, b, tolerance) and LENSIM_CHECK_FINITE(x) are always on: for cold code
//   (set-up, per tile), where they cost nothing measurable.
// - LENSIM_DCHECK and LENSIM_DCHECK_EQ ... _FINITE are on in builds configured with
//   LENSIM_DCHECKS=ON (the default for Debug and sanitizer builds, off for Release): for hot
//   loops (per sample, per ray). Off, the operands are not evaluated (but still compiled, so
//   they cannot rot).
// CHECK and DCHECK are short names of LENSIM_CHECK and LENSIM_DCHECK.
// A comparison fails when it is false, so a NaN operand fails every form but _NE.
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <string>

namespace lensim {

/// Reports a failed check and aborts; `values` (may be empty) follows the condition.
[[noreturn]] void checkFailed(const char* condition, const char* file, int line,
                              const std::string& values = {});

namespace detail {

/// "(a = 1, b = 2)" for a failed comparison of the expressions a and b.
template <class A, class B>
[[noreturn]] void checkCompareFailed(const char* condition, const char* a_text,
                                     const char* b_text, const A& a, const B& b,
                                     const char* file, int line) {
  checkFailed(condition, file, line, fmt::format("({} = {}, {} = {})", a_text, a, b_text, b));
}

}  // namespace detail

}  // namespace lensim

#define LENSIM_CHECK(cond) \
  ((cond) ? static_cast<void>(0) : ::lensim::checkFailed(#cond, __FILE__, __LINE__))

// The comparison forms evaluate each operand once.
#define LENSIM_CHECK_OP_(a, op, b)                                                         \
  do {                                                                                     \
    const auto& lensim_check_a_ = (a);                                                     \
    const auto& lensim_check_b_ = (b);                                                     \
    if (!(lensim_check_a_ op lensim_check_b_))                                             \
      ::lensim::detail::checkCompareFailed(#a " " #op " " #b, #a, #b, lensim_check_a_,     \
                                           lensim_check_b_, __FILE__, __LINE__);           \
  } while (false)

#define LENSIM_CHECK_EQ(a, b) LENSIM_CHECK_OP_(a, ==, b)
#define LENSIM_CHECK_NE(a, b) LENSIM_CHECK_OP_(a, !=, b)
#define LENSIM_CHECK_LT(a, b) LENSIM_CHECK_OP_(a, <, b)
#define LENSIM_CHECK_LE(a, b) LENSIM_CHECK_OP_(a, <=, b)
#define LENSIM_CHECK_GT(a, b) LENSIM_CHECK_OP_(a, >, b)
#define LENSIM_CHECK_GE(a, b) LENSIM_CHECK_OP_(a, >=, b)

/// |a - b| <= tolerance (false for NaN).
#define LENSIM_CHECK_NEAR(a, b, tolerance)                                                  \
  do {                                                                                      \
    const double lensim_check_a_ = (a);                                                     \
    const double lensim_check_b_ = (b);                                                     \
    if (!(std::abs(lensim_check_a_ - lensim_check_b_) <= (tolerance)))                      \
      ::lensim::detail::checkCompareFailed("|" #a " - " #b "| <= " #tolerance, #a, #b,      \
                                           lensim_check_a_, lensim_check_b_, __FILE__,      \
                                           __LINE__);                                       \
  } while (false)

/// x is a finite number (not NaN or infinite).
#define LENSIM_CHECK_FINITE(x)                                                              \
  do {                                                                                      \
    const double lensim_check_x_ = (x);                                                     \
    if (!std::isfinite(lensim_check_x_))                                                    \
      ::lensim::checkFailed("std::isfinite(" #x ")", __FILE__, __LINE__,                    \
                            fmt::format("({} = {})", #x, lensim_check_x_));                 \
  } while (false)

#ifdef LENSIM_DCHECKS
#define LENSIM_DCHECK(cond) LENSIM_CHECK(cond)
#define LENSIM_DCHECK_EQ(a, b) LENSIM_CHECK_EQ(a, b)
#define LENSIM_DCHECK_NE(a, b) LENSIM_CHECK_NE(a, b)
#define LENSIM_DCHECK_LT(a, b) LENSIM_CHECK_LT(a, b)
#define LENSIM_DCHECK_LE(a, b) LENSIM_CHECK_LE(a, b)
#define LENSIM_DCHECK_GT(a, b) LENSIM_CHECK_GT(a, b)
#define LENSIM_DCHECK_GE(a, b) LENSIM_CHECK_GE(a, b)
#define LENSIM_DCHECK_NEAR(a, b, tolerance) LENSIM_CHECK_NEAR(a, b, tolerance)
#define LENSIM_DCHECK_FINITE(x) LENSIM_CHECK_FINITE(x)
#else
// Compiled (sizeof of an unevaluated operand), never evaluated.
#define LENSIM_DCHECK(cond) static_cast<void>(sizeof(static_cast<bool>(cond)))
#define LENSIM_DCHECK_OFF_(a, op, b) static_cast<void>(sizeof((a)op(b)))
#define LENSIM_DCHECK_EQ(a, b) LENSIM_DCHECK_OFF_(a, ==, b)
#define LENSIM_DCHECK_NE(a, b) LENSIM_DCHECK_OFF_(a, !=, b)
#define LENSIM_DCHECK_LT(a, b) LENSIM_DCHECK_OFF_(a, <, b)
#define LENSIM_DCHECK_LE(a, b) LENSIM_DCHECK_OFF_(a, <=, b)
#define LENSIM_DCHECK_GT(a, b) LENSIM_DCHECK_OFF_(a, >, b)
#define LENSIM_DCHECK_GE(a, b) LENSIM_DCHECK_OFF_(a, >=, b)
#define LENSIM_DCHECK_NEAR(a, b, tolerance) \
  static_cast<void>(sizeof(std::abs(double(a) - double(b)) <= (tolerance)))
#define LENSIM_DCHECK_FINITE(x) static_cast<void>(sizeof(std::isfinite(double(x))))
#endif

#define CHECK(cond) LENSIM_CHECK(cond)
#define DCHECK(cond) LENSIM_DCHECK(cond)
