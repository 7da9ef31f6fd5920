#include "lensim/util/interrupt.h"

#include <unistd.h>

#include <csignal>

namespace lensim {

namespace {

std::atomic<bool> g_flag{false};
std::atomic<int> g_signal{0};
std::atomic<int> g_signals_seen{0};
std::atomic<int> g_cancellable{0};
std::atomic<int> g_critical{0};

static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "the signal handler needs lock-free atomics");

extern "C" void onInterrupt(int sig) {
  int expected = 0;
  g_signal.compare_exchange_strong(expected, sig);
  g_flag.store(true);
  const int seen = g_signals_seen.fetch_add(1) + 1;
  if (g_critical.load() > 0) return;                  // finish writing first
  if (g_cancellable.load() > 0 && seen == 1) return;  // stop and write what there is
  ::_exit(128 + g_signal.load());                     // nothing is half-written now
}

}  // namespace

void installInterruptHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onInterrupt;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
}

const std::atomic<bool>& interruptFlag() {
  return g_flag;
}
int interruptSignal() {
  return g_signal.load();
}
int interruptExitStatus() {
  const int s = g_signal.load();
  return s ? 128 + s : 0;
}

CancellableScope::CancellableScope() {
  g_cancellable.fetch_add(1);
}
CancellableScope::~CancellableScope() {
  g_cancellable.fetch_sub(1);
}

CriticalScope::CriticalScope() {
  g_critical.fetch_add(1);
}
CriticalScope::~CriticalScope() {
  if (g_critical.fetch_sub(1) == 1 && g_flag.load() && g_cancellable.load() == 0)
    ::_exit(128 + g_signal.load());
}

void resetInterruptForTesting() {
  g_flag.store(false);
  g_signal.store(0);
  g_signals_seen.store(0);
}

}  // namespace lensim
