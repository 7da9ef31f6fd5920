// Errors and diagnostics with source locations.
//
// Every error that comes from a user's file (lens prescription, scene) carries a FileLoc and is
// printed compiler style: `path:line:col: error: message`. Errors are thrown as lensim::Error and
// caught in main, which prints them and exits with status 1.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace lensim {

/// A position in a text file; line and column count from 1, 0 means "unknown".
struct FileLoc {
  std::string file;
  int line = 0;
  int column = 0;

  /// "path:line:col", "path:line" or "path"; empty when no file is known.
  std::string str() const;
  bool valid() const { return !file.empty(); }
};

/// Severity of a Diagnostic.
enum class Severity { Note, Warning, Error };

/// A message about user input, with where it comes from.
struct Diagnostic {
  Severity severity = Severity::Warning;
  FileLoc loc;
  std::string message;

  /// Formats as `path:line:col: warning: message` (or without a location prefix).
  std::string str() const;
};

/// The exception every lensim module throws for bad input or failed operations.
class Error : public std::runtime_error {
 public:
  explicit Error(std::string message);
  Error(FileLoc loc, std::string message);

  const FileLoc& loc() const { return loc_; }
  /// The message without the location prefix.
  const std::string& message() const { return message_; }

 private:
  FileLoc loc_;
  std::string message_;
};

/// The message of `e` after its location ("bad.png: cannot read PNG: ..."), without the
/// "error:" of its printed form: for wrapping it in an Error about what referenced the file, so
/// that the wrapped error says "error:" once.
std::string nestedMessage(const Error& e);

/// Formats a list of diagnostics, one per line.
std::string formatDiagnostics(const std::vector<Diagnostic>& diagnostics);

}  // namespace lensim
