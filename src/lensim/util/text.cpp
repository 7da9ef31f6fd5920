#include "lensim/util/text.h"

#include <fmt/format.h>

namespace lensim {

namespace {

// Length of the valid UTF-8 sequence of 2 to 4 bytes starting at s[i], or 0.
size_t utf8Length(std::string_view s, size_t i) {
  const auto b = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(i);
  size_t n = 0;
  if (c >= 0xC2 && c <= 0xDF)
    n = 2;
  else if (c >= 0xE0 && c <= 0xEF)
    n = 3;
  else if (c >= 0xF0 && c <= 0xF4)
    n = 4;
  else
    return 0;
  if (i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k)
    if ((b(i + k) & 0xC0) != 0x80) return 0;
  // Overlong forms, surrogates and code points above U+10FFFF.
  if (c == 0xE0 && b(i + 1) < 0xA0) return 0;
  if (c == 0xED && b(i + 1) > 0x9F) return 0;
  if (c == 0xF0 && b(i + 1) < 0x90) return 0;
  if (c == 0xF4 && b(i + 1) > 0x8F) return 0;
  return n;
}

void appendEscaped(std::string& out, std::string_view s, bool keep_newlines) {
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7F) {
      out += static_cast<char>(c);
      ++i;
    } else if (c == '\n' || c == '\t') {
      if (keep_newlines)
        out += static_cast<char>(c);
      else
        out += c == '\n' ? "\\n" : "\\t";
      ++i;
    } else if (size_t n = c >= 0x80 ? utf8Length(s, i) : 0) {
      out.append(s.substr(i, n));
      i += n;
    } else {
      out += fmt::format("\\x{:02x}", c);
      ++i;
    }
  }
}

// Cuts `s` to at most `n` bytes without splitting a UTF-8 sequence.
std::string_view cut(std::string_view s, size_t n) {
  if (s.size() <= n) return s;
  while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;
  return s.substr(0, n);
}

}  // namespace

std::string escapeText(std::string_view s, bool keep_newlines) {
  std::string out;
  out.reserve(s.size());
  appendEscaped(out, s, keep_newlines);
  return out;
}

std::string shortToken(std::string_view s, size_t max_bytes) {
  if (s.size() <= max_bytes) return escapeText(s);
  std::string_view head = cut(s, max_bytes);
  std::string out = escapeText(head);
  out += fmt::format("…(+{} bytes)", s.size() - head.size());
  return out;
}

std::string sanitizeMessage(std::string_view s, size_t max_run) {
  std::string out;
  out.reserve(std::min(s.size(), size_t{4096}));
  size_t i = 0;
  while (i < s.size()) {
    // A run of non-white-space bytes.
    size_t j = i;
    while (j < s.size() && s[j] != ' ' && s[j] != '\n' && s[j] != '\t') ++j;
    const std::string_view run = s.substr(i, j - i);
    if (run.size() > max_run) {
      appendEscaped(out, cut(run, max_run), true);
      out += fmt::format("…(+{} bytes)", run.size() - cut(run, max_run).size());
    } else {
      appendEscaped(out, run, true);
    }
    i = j;
    while (i < s.size() && (s[i] == ' ' || s[i] == '\n' || s[i] == '\t')) out += s[i++];
  }
  return out;
}

}  // namespace lensim
