// Minimal logging to stderr for the command-line tools. Library code that produces messages
// about user input returns Diagnostics instead, so callers and tests can inspect them.
#pragma once

#include <string_view>
#include <vector>

#include "lensim/util/error.h"

namespace lensim {

/// Prints `warning: message` (or a located diagnostic) to stderr unless warnings are muted.
void logWarning(std::string_view message);
void logDiagnostic(const Diagnostic& d);
void logDiagnostics(const std::vector<Diagnostic>& ds);
/// Prints an informational line to stderr unless quiet mode is on.
void logInfo(std::string_view message);

/// Quiet mode silences logInfo (not warnings or errors).
void setQuiet(bool quiet);
bool quiet();

}  // namespace lensim
