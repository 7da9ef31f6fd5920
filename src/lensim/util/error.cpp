#include "lensim/util/error.h"

#include <fmt/format.h>

#include "lensim/util/text.h"

namespace lensim {

std::string FileLoc::str() const {
  if (file.empty()) return {};
  if (line <= 0) return file;
  if (column <= 0) return fmt::format("{}:{}", file, line);
  return fmt::format("{}:{}:{}", file, line, column);
}

static const char* severityName(Severity s) {
  switch (s) {
    case Severity::Note:
      return "note";
    case Severity::Warning:
      return "warning";
    case Severity::Error:
      return "error";
  }
  return "error";
}

std::string Diagnostic::str() const {
  // Messages quote bytes from users' files: escape what is unprintable, shorten long tokens.
  const std::string safe = sanitizeMessage(message);
  if (loc.valid())
    return fmt::format("{}: {}: {}", sanitizeMessage(loc.str()), severityName(severity), safe);
  return fmt::format("{}: {}", severityName(severity), safe);
}

static std::string formatError(const FileLoc& loc, const std::string& message) {
  return Diagnostic{Severity::Error, loc, message}.str();
}

Error::Error(std::string message)
    : std::runtime_error(formatError({}, message)), message_(sanitizeMessage(message)) {}

Error::Error(FileLoc loc, std::string message)
    : std::runtime_error(formatError(loc, message)),
      loc_(std::move(loc)),
      message_(sanitizeMessage(message)) {}

std::string formatDiagnostics(const std::vector<Diagnostic>& diagnostics) {
  std::string out;
  for (const Diagnostic& d : diagnostics) {
    out += d.str();
    out += '\n';
  }
  return out;
}

std::string nestedMessage(const Error& e) {
  if (!e.loc().valid()) return e.message();
  return fmt::format("{}: {}", e.loc().str(), e.message());
}

}  // namespace lensim
