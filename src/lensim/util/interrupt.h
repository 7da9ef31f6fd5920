// SIGINT and SIGTERM: whenever they arrive, the user is left with either the previous output file
// or a complete new one, never a temporary, and lensim exits 130 (SIGINT) or 143 (SIGTERM).
//
// main installs the handlers once. Outside any of the states below a signal ends lensim at once
// (nothing is half-written then). A long computation that can stop early and still write a
// useful result (a render) declares itself with CancellableScope and polls interrupted(); a
// second signal then ends lensim at once. While a file is written and renamed into place
// (writeAtomically holds a CriticalScope) signals are only recorded; when the last
// CriticalScope ends and nothing is cancellable, lensim exits with the recorded signal's status.
#pragma once

#include <atomic>

namespace lensim {

/// Installs the SIGINT and SIGTERM handlers (idempotent).
void installInterruptHandlers();

/// The flag a cancellable computation polls (true once a signal arrived).
const std::atomic<bool>& interruptFlag();
inline bool interrupted() {
  return interruptFlag().load(std::memory_order_relaxed);
}

/// The first signal received (SIGINT or SIGTERM), 0 if none.
int interruptSignal();

/// 128 + the signal (130 for SIGINT, 143 for SIGTERM), or 0 if no signal arrived.
int interruptExitStatus();

/// While alive, the first signal only sets interrupted() (the computation stops and writes what
/// it has); a second one exits at once.
class CancellableScope {
 public:
  CancellableScope();
  ~CancellableScope();
  CancellableScope(const CancellableScope&) = delete;
  CancellableScope& operator=(const CancellableScope&) = delete;
};

/// While alive, signals are recorded but never end the process (a file is being written).
class CriticalScope {
 public:
  CriticalScope();
  ~CriticalScope();
  CriticalScope(const CriticalScope&) = delete;
  CriticalScope& operator=(const CriticalScope&) = delete;
};

/// For tests: forgets a recorded signal.
void resetInterruptForTesting();

}  // namespace lensim
