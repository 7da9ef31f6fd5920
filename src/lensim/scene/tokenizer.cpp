#include "lensim/scene/tokenizer.h"

namespace lensim::scene {

char Tokenizer::get() {
  char c = text_[pos_++];
  if (c == '\n') {
    ++line_;
    column_ = 1;
  } else {
    ++column_;
  }
  return c;
}

static bool isSpace(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
}

Token Tokenizer::next() {
  while (pos_ < text_.size()) {
    char c = text_[pos_];
    if (isSpace(c)) {
      get();
      continue;
    }
    if (c == '#') {
      while (pos_ < text_.size() && text_[pos_] != '\n') get();
      continue;
    }
    Token t;
    t.line = line_;
    t.column = column_;
    t.file = &file_;
    if (c == '[' || c == ']') {
      get();
      t.kind = c == '[' ? Token::Kind::LBracket : Token::Kind::RBracket;
      t.text = std::string(1, c);
      return t;
    }
    if (c == '"') {
      get();
      t.kind = Token::Kind::String;
      for (;;) {
        if (pos_ >= text_.size() || text_[pos_] == '\n') throw Error(loc(t), "unterminated string");
        char d = get();
        if (d == '"') break;
        if (d == '\\') {
          if (pos_ >= text_.size()) throw Error(loc(t), "unterminated string");
          char e = get();
          switch (e) {
            case 'n':
              t.text += '\n';
              break;
            case 't':
              t.text += '\t';
              break;
            case 'r':
              t.text += '\r';
              break;
            case 'b':
              t.text += '\b';
              break;
            case 'f':
              t.text += '\f';
              break;
            default:
              t.text += e;
              break;  // \\, \", \' and anything else: the character
          }
          continue;
        }
        t.text += d;
      }
      return t;
    }
    t.kind = Token::Kind::Word;
    while (pos_ < text_.size()) {
      char d = text_[pos_];
      if (isSpace(d) || d == '"' || d == '[' || d == ']' || d == '#') break;
      t.text += get();
    }
    return t;
  }
  Token end;
  end.line = line_;
  end.column = column_;
  end.file = &file_;
  return end;
}

}  // namespace lensim::scene
