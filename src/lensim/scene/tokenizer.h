// Splits pbrt scene text into tokens: quoted strings, brackets and bare words (directive names,
// numbers, true/false). Comments (`#` to the end of the line) are skipped.
#pragma once

#include <string>
#include <string_view>

#include "lensim/util/error.h"

namespace lensim::scene {

/// One token of a pbrt file; `text` is unescaped for strings.
struct Token {
  enum class Kind { End, Word, String, LBracket, RBracket };
  Kind kind = Kind::End;
  std::string text;
  int line = 0;
  int column = 0;
  /// The file the token came from (owned by its Tokenizer); null for a default-made token.
  const std::string* file = nullptr;
};

/// Reads tokens from text that stays alive as long as the tokenizer.
class Tokenizer {
 public:
  Tokenizer(std::string_view text, std::string file) : text_(text), file_(std::move(file)) {}

  /// The next token; Kind::End at the end. Throws lensim::Error for an unterminated string.
  Token next();
  const std::string& file() const { return file_; }
  FileLoc loc(const Token& t) const { return FileLoc{t.file ? *t.file : file_, t.line, t.column}; }

 private:
  char get();
  std::string_view text_;
  std::string file_;
  size_t pos_ = 0;
  int line_ = 1;
  int column_ = 1;
};

}  // namespace lensim::scene
