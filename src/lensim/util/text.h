// Making untrusted text safe to print: bytes from a user's file end up in error messages, SVG and
// JSON, so unprintable bytes and invalid UTF-8 are escaped and long tokens are shortened.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace lensim {

/// Copies `s` with every byte that is not printable escaped as \xNN (NUL, control characters,
/// DEL, bytes that are not part of valid UTF-8). Newlines and tabs are kept when `keep_newlines`,
/// escaped as \n and \t otherwise. The result is valid, printable UTF-8.
std::string escapeText(std::string_view s, bool keep_newlines = false);

/// escapeText, shortened to about `max_bytes` of the input: "abc…(+12345 bytes)".
std::string shortToken(std::string_view s, size_t max_bytes = 64);

/// What Error and Diagnostic do with every message: escapeText (keeping newlines and tabs), and
/// any run of more than `max_run` bytes without white space shortened as by shortToken.
std::string sanitizeMessage(std::string_view s, size_t max_run = 240);

}  // namespace lensim
