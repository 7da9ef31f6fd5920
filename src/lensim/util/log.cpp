#include "lensim/util/log.h"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <string>

namespace lensim {

namespace {
std::atomic<bool> g_quiet{false};
std::mutex g_mutex;

void writeLine(std::string_view line) {
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fwrite(line.data(), 1, line.size(), stderr);
  std::fputc('\n', stderr);
  std::fflush(stderr);
}
}  // namespace

void logWarning(std::string_view message) {
  writeLine(std::string("warning: ") + std::string(message));
}

void logDiagnostic(const Diagnostic& d) {
  writeLine(d.str());
}

void logDiagnostics(const std::vector<Diagnostic>& ds) {
  for (const Diagnostic& d : ds) logDiagnostic(d);
}

void logInfo(std::string_view message) {
  if (!g_quiet) writeLine(message);
}

void setQuiet(bool q) {
  g_quiet = q;
}
bool quiet() {
  return g_quiet;
}

}  // namespace lensim
