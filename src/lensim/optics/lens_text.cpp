// Text lens and catalogue files: decoding (UTF-8, Latin-1, UTF-16) and splitting lines into
// fields (lens_formats.h).
#include <fmt/format.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "lensim/optics/lens_formats.h"
#include "lensim/util/error.h"

namespace lensim::optics {

namespace {

void appendUtf8(std::string& out, std::uint32_t cp) {
  if (cp < 0x80) {
    out += char(cp);
  } else if (cp < 0x800) {
    out += char(0xC0 | (cp >> 6));
    out += char(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += char(0xE0 | (cp >> 12));
    out += char(0x80 | ((cp >> 6) & 0x3F));
    out += char(0x80 | (cp & 0x3F));
  } else {
    out += char(0xF0 | (cp >> 18));
    out += char(0x80 | ((cp >> 12) & 0x3F));
    out += char(0x80 | ((cp >> 6) & 0x3F));
    out += char(0x80 | (cp & 0x3F));
  }
}

bool validUtf8(std::string_view s) {
  size_t i = 0;
  while (i < s.size()) {
    const auto b = static_cast<unsigned char>(s[i]);
    const int extra = b < 0x80 ? 0 : (b >> 5) == 6 ? 1 : (b >> 4) == 14 ? 2 : (b >> 3) == 30 ? 3 : -1;
    if (extra < 0 || i + size_t(extra) >= s.size() + (extra == 0 ? 1 : 0)) return false;
    for (int k = 1; k <= extra; ++k)
      if ((static_cast<unsigned char>(s[i + size_t(k)]) >> 6) != 2) return false;
    i += size_t(extra) + 1;
  }
  return true;
}

}  // namespace

std::string decodeTextFile(std::string_view bytes, const std::string& path) {
  auto u8 = [&](size_t i) { return static_cast<unsigned char>(bytes[i]); };
  const bool le = bytes.size() >= 2 && u8(0) == 0xFF && u8(1) == 0xFE;
  const bool be = bytes.size() >= 2 && u8(0) == 0xFE && u8(1) == 0xFF;
  if (!le && !be) {
    if (bytes.size() >= 3 && u8(0) == 0xEF && u8(1) == 0xBB && u8(2) == 0xBF)
      bytes.remove_prefix(3);
    if (validUtf8(bytes)) return std::string(bytes);
    std::string out;  // Latin-1 (ISO 8859-1): each byte is its code point
    out.reserve(bytes.size() + bytes.size() / 8);
    for (char c : bytes) appendUtf8(out, static_cast<unsigned char>(c));
    return out;
  }
  std::string out;
  out.reserve(bytes.size() / 2);
  int line = 1;
  auto unit = [&](size_t i) -> std::uint32_t {
    return le ? (std::uint32_t(u8(i)) | (std::uint32_t(u8(i + 1)) << 8))
              : ((std::uint32_t(u8(i)) << 8) | std::uint32_t(u8(i + 1)));
  };
  const char* enc = le ? "UTF-16 LE" : "UTF-16 BE";
  const bool odd = bytes.size() % 2 != 0;
  for (size_t i = 2; i + 1 < bytes.size(); i += 2) {
    std::uint32_t cu = unit(i);
    if (cu >= 0xD800 && cu <= 0xDBFF) {
      if (i + 3 >= bytes.size() || unit(i + 2) < 0xDC00 || unit(i + 2) > 0xDFFF)
        throw Error(FileLoc{path, line, 0},
                    fmt::format("malformed {} text: unpaired high surrogate 0x{:04X}", enc, cu));
      cu = 0x10000 + ((cu - 0xD800) << 10) + (unit(i + 2) - 0xDC00);
      i += 2;
    } else if (cu >= 0xDC00 && cu <= 0xDFFF) {
      throw Error(FileLoc{path, line, 0},
                  fmt::format("malformed {} text: unpaired low surrogate 0x{:04X}", enc, cu));
    } else if (cu == 0) {
      throw Error(
          FileLoc{path, line, 0},
          fmt::format("malformed {} text: a NUL character (is the file really {}?)", enc, enc));
    }
    if (cu == '\n') ++line;
    appendUtf8(out, cu);
  }
  if (odd)
    throw Error(FileLoc{path, line, 0},
                fmt::format("malformed {} file: odd number of bytes ({}); the file is truncated "
                            "in the middle of a character or is not UTF-16",
                            enc, bytes.size()));
  return out;
}

std::vector<LineField> splitFields(std::string_view line, std::string_view separators) {
  const auto sep = [&](char c) { return separators.find(c) != std::string_view::npos; };
  std::vector<LineField> t;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && sep(line[i])) ++i;
    if (i >= line.size()) break;
    const size_t s = i;
    while (i < line.size() && !sep(line[i])) ++i;
    t.push_back({line.substr(s, i - s), int(s) + 1});
  }
  return t;
}

}  // namespace lensim::optics
