#include "lensim/scene/parser.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <zlib.h>

#include "lensim/scene/params.h"
#include "lensim/scene/tokenizer.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"

namespace lensim::scene {

std::string_view paramTypeName(ParamType t) {
  switch (t) {
    case ParamType::Float:
      return "float";
    case ParamType::Integer:
      return "integer";
    case ParamType::Bool:
      return "bool";
    case ParamType::String:
      return "string";
    case ParamType::Texture:
      return "texture";
    case ParamType::Point2:
      return "point2";
    case ParamType::Point3:
      return "point3";
    case ParamType::Vector2:
      return "vector2";
    case ParamType::Vector3:
      return "vector3";
    case ParamType::Normal3:
      return "normal";  // pbrt-v4 spells it "normal" (and accepts "normal3")
    case ParamType::Rgb:
      return "rgb";
    case ParamType::Spectrum:
      return "spectrum";
    case ParamType::Blackbody:
      return "blackbody";
  }
  return "?";
}

namespace {

namespace fs = std::filesystem;

// The largest scene file read (pbrt scenes with inline meshes reach gigabytes).
constexpr uint64_t kMaxSceneFileBytes = uint64_t{16} << 30;

// How a directive's positional arguments are written.
enum class Args {
  None,
  Numbers,
  Word,
  OneString,
  TypeAndParams,
  TextureDecl,
  MediumInterface,
  Option
};

struct DirectiveSpec {
  Args args;
  int count = 0;  // numbers expected for Args::Numbers
  enum class Block { Any, Options, World } block = Block::Any;
  bool legacy = false;  // only pbrt v1–v3 write it
};

const std::map<std::string, DirectiveSpec, std::less<>>& directiveSpecs() {
  using B = DirectiveSpec::Block;
  static const std::map<std::string, DirectiveSpec, std::less<>> specs = {
      {"Identity", {Args::None}},
      {"Translate", {Args::Numbers, 3}},
      {"Scale", {Args::Numbers, 3}},
      {"Rotate", {Args::Numbers, 4}},
      {"LookAt", {Args::Numbers, 9}},
      {"CoordinateSystem", {Args::OneString}},
      {"CoordSysTransform", {Args::OneString}},
      {"Transform", {Args::Numbers, 16}},
      {"ConcatTransform", {Args::Numbers, 16}},
      {"TransformTimes", {Args::Numbers, 2, B::Options}},
      {"ActiveTransform", {Args::Word}},
      {"ReverseOrientation", {Args::None}},
      {"Option", {Args::Option, 0, B::Options}},
      {"ColorSpace", {Args::OneString}},
      {"Camera", {Args::TypeAndParams, 0, B::Options}},
      {"Sampler", {Args::TypeAndParams, 0, B::Options}},
      {"Film", {Args::TypeAndParams, 0, B::Options}},
      {"PixelFilter", {Args::TypeAndParams, 0, B::Options}},
      {"Filter", {Args::TypeAndParams, 0, B::Options, true}},
      {"Integrator", {Args::TypeAndParams, 0, B::Options}},
      {"SurfaceIntegrator", {Args::TypeAndParams, 0, B::Options, true}},
      {"VolumeIntegrator", {Args::TypeAndParams, 0, B::Options, true}},
      {"Accelerator", {Args::TypeAndParams, 0, B::Options}},
      {"MakeNamedMedium", {Args::TypeAndParams}},
      {"MediumInterface", {Args::MediumInterface}},
      {"WorldBegin", {Args::None}},
      {"WorldEnd", {Args::None, 0, B::World, true}},
      {"AttributeBegin", {Args::None}},
      {"AttributeEnd", {Args::None}},
      {"TransformBegin", {Args::None}},
      {"TransformEnd", {Args::None}},
      {"Attribute", {Args::TypeAndParams}},
      {"Shape", {Args::TypeAndParams, 0, B::World}},
      {"Material", {Args::TypeAndParams, 0, B::World}},
      {"MakeNamedMaterial", {Args::TypeAndParams, 0, B::World}},
      {"NamedMaterial", {Args::OneString, 0, B::World}},
      {"Texture", {Args::TextureDecl, 0, B::World}},
      {"LightSource", {Args::TypeAndParams, 0, B::World}},
      {"AreaLightSource", {Args::TypeAndParams, 0, B::World}},
      {"ObjectBegin", {Args::OneString, 0, B::World}},
      {"ObjectEnd", {Args::None, 0, B::World}},
      {"ObjectInstance", {Args::OneString, 0, B::World}},
      // pbrt-v2's `Renderer "sampler"|"metropolis"|...`: the builder ignores it with a warning.
      {"Renderer", {Args::TypeAndParams, 0, B::Options, true}},
      {"Include", {Args::OneString}},
      {"Import", {Args::OneString}},
  };
  return specs;
}

std::optional<double> parseNumber(std::string_view s) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  if (s.empty()) return std::nullopt;
  double v = 0;
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

std::optional<ParamType> parseType(std::string_view t, bool& legacy) {
  static const std::map<std::string, std::pair<ParamType, bool>, std::less<>> types = {
      {"float", {ParamType::Float, false}},
      {"integer", {ParamType::Integer, false}},
      {"bool", {ParamType::Bool, false}},
      {"string", {ParamType::String, false}},
      {"texture", {ParamType::Texture, false}},
      {"point2", {ParamType::Point2, false}},
      {"point3", {ParamType::Point3, false}},
      {"point", {ParamType::Point3, true}},
      {"vector2", {ParamType::Vector2, false}},
      {"vector3", {ParamType::Vector3, false}},
      {"vector", {ParamType::Vector3, true}},
      {"normal3", {ParamType::Normal3, false}},
      {"normal", {ParamType::Normal3, false}},
      {"rgb", {ParamType::Rgb, false}},
      {"color", {ParamType::Rgb, true}},
      {"spectrum", {ParamType::Spectrum, false}},
      {"blackbody", {ParamType::Blackbody, false}},
  };
  auto it = types.find(t);
  if (it == types.end()) return std::nullopt;
  legacy = it->second.second;
  return it->second.first;
}

// "; did you mean \"Translate\"?" for a near miss of a directive name, or "".
std::string suggestion(std::string_view word) {
  return didYouMean(word, directiveSpecs(), 3);  // at most two edits
}

// The text of a scene file; `.gz` files are decompressed, as pbrt-v4 does for any file name
// ending in ".gz" (Tokenizer::CreateFromFile in pbrt-v4's src/pbrt/parser.cpp).
std::optional<std::string> readSceneText(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return std::nullopt;
  if (path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0) {
    gzFile f = gzopen(path.c_str(), "rb");
    if (!f) return std::nullopt;
    std::string data;
    char buf[1 << 16];
    for (;;) {
      int n = gzread(f, buf, sizeof buf);
      if (n < 0) {
        int err = 0;
        std::string msg = gzerror(f, &err);
        gzclose(f);
        throw Error(FileLoc{path, 0, 0}, fmt::format("cannot decompress: {}", msg));
      }
      if (n == 0) break;
      data.append(buf, static_cast<size_t>(n));
      // A small .gz can expand without bound: the decompressed text counts against the budget.
      if ((data.size() & ((size_t{1} << 26) - 1)) < sizeof buf ||
          data.size() > kMaxSceneFileBytes) {
        if (data.size() > kMaxSceneFileBytes) {
          gzclose(f);
          throw Error(FileLoc{path, 0, 0},
                      fmt::format("decompressed scene text exceeds {} bytes", kMaxSceneFileBytes));
        }
        try {
          checkMemory(4.0 * static_cast<double>(data.size()), FileLoc{path, 0, 0},
                      "parsing this decompressed scene file");
        } catch (...) {
          gzclose(f);
          throw;
        }
      }
    }
    gzclose(f);
    return data;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// One token stream over the top-level file and the files it includes. As in pbrt-v4's parse()
// (src/pbrt/parser.cpp: `nextToken` pops the file stack at the end of an included file and goes
// on with the including file), an Include pushes its file and the stream continues seamlessly
// where it ends, so a directive's parameter list may run on across the end of an included file.
class TokenStream {
 public:
  void push(std::string text, const std::string& file) {
    if (sources_.size() >= 64)
      throw Error(FileLoc{file, 1, 1}, "Include nested too deeply (a cycle?)");
    auto src = std::make_unique<Source>();
    src->text = std::move(text);
    src->tok = std::make_unique<Tokenizer>(src->text, file);
    sources_.push_back(std::move(src));
  }
  /// The next token; at the end of an included file, the next token of the including file.
  Token next() {
    for (;;) {
      if (sources_.empty()) return end_;
      Token t = sources_.back()->tok->next();
      if (t.kind != Token::Kind::End) return t;
      end_ = t;
      // Keep the tokenizer (tokens point at its file name) but free the text.
      finished_.push_back(std::move(sources_.back()->tok));
      sources_.pop_back();
    }
  }
  FileLoc loc(const Token& t) const {
    return FileLoc{t.file ? *t.file : std::string(), t.line, t.column};
  }

 private:
  struct Source {
    std::string text;
    std::unique_ptr<Tokenizer> tok;
  };
  std::vector<std::unique_ptr<Source>> sources_;
  std::vector<std::unique_ptr<Tokenizer>> finished_;
  Token end_;
};

class Parser {
 public:
  explicit Parser(SceneDesc& desc) : desc_(desc) {}

  void parseFile(const std::string& path, const FileLoc* included_from) {
    if (!pushFile(path, included_from)) return;
    run();
  }

  void parseText(std::string_view text, const std::string& file) {
    stream_.push(std::string(text), file);
    run();
  }

  // Pushes a file onto the token stream; false (after recording an error) if it cannot be read.
  bool pushFile(const std::string& path, const FileLoc* included_from) {
    // Only regular files (a FIFO or /dev/zero would block or never end), of a size the memory
    // budget allows (parsing needs a few times the text).
    if (!included_from) {
      const uint64_t bytes = requireRegularFile(path, "scene file", kMaxSceneFileBytes);
      checkMemory(4.0 * static_cast<double>(bytes), FileLoc{path}, "parsing this scene file");
    }
    std::optional<std::string> text = readSceneText(path);
    if (!text) {
      std::string msg = included_from ? fmt::format("cannot open included file \"{}\"", path)
                                      : fmt::format("cannot open scene file \"{}\"", path);
      if (!included_from) throw Error(msg);
      desc_.diagnostics.push_back({Severity::Error, *included_from, msg});
      return false;
    }
    desc_.files.push_back(path);
    stream_.push(std::move(*text), path);
    return true;
  }

  void run() {
    TokenStream& tok = stream_;
    pending_.reset();
    for (;;) {
      Token t = next(tok);
      if (t.kind == Token::Kind::End) break;
      if (t.kind != Token::Kind::Word) {
        throw Error(tok.loc(t),
                    t.kind == Token::Kind::String
                        ? fmt::format("unexpected string \"{}\"; expected a directive", t.text)
                        : fmt::format("unexpected '{}'; expected a directive", t.text));
      }
      auto it = directiveSpecs().find(t.text);
      if (it == directiveSpecs().end()) {
        if (parseNumber(t.text))
          throw Error(tok.loc(t),
                      fmt::format("unexpected number {}; expected a directive", t.text));
        throw Error(tok.loc(t),
                    fmt::format("unknown directive \"{}\"{}", t.text, suggestion(t.text)));
      }
      const DirectiveSpec& spec = it->second;
      Directive d;
      d.name = t.text;
      d.loc = tok.loc(t);
      if (spec.legacy) desc_.legacy_syntax = true;
      parseArgs(tok, spec, d);
      checkStructure(spec, d);
      if (d.name == "Include" || d.name == "Import") {
        fs::path p(d.strings[0]);
        if (p.is_relative()) p = fs::path(d.loc.file).parent_path() / p;
        std::string resolved = p.lexically_normal().string();
        std::error_code ec;
        if (!fs::is_regular_file(resolved, ec)) {
          desc_.diagnostics.push_back({Severity::Error, d.loc,
                                       fmt::format("included file \"{}\" not found (looked for {})",
                                                   d.strings[0], resolved)});
          continue;
        }
        // No token is pending here (the file name was the last one read): the included file's
        // tokens come next, then the rest of this file's.
        pushFile(resolved, &d.loc);
        continue;
      }
      desc_.directives.push_back(std::move(d));
    }
  }

  void finish() {
    for (const Block& b : stack_)
      throw Error(b.loc, fmt::format("{} without matching {}", b.name,
                                     b.name == "ObjectBegin"      ? "ObjectEnd"
                                     : b.name == "AttributeBegin" ? "AttributeEnd"
                                                                  : "TransformEnd"));
    for (const auto& [name, loc] : instance_uses_)
      if (!objects_.count(name))
        throw Error(loc, fmt::format("ObjectInstance of unknown object \"{}\"", name));
  }

 private:
  struct Block {
    std::string name;
    FileLoc loc;
  };

  Token next(TokenStream& tok) {
    if (pending_) {
      Token t = std::move(*pending_);
      pending_.reset();
      return t;
    }
    return tok.next();
  }
  const Token& peek(TokenStream& tok) {
    if (!pending_) pending_ = tok.next();
    return *pending_;
  }

  void parseArgs(TokenStream& tok, const DirectiveSpec& spec, Directive& d) {
    auto expectString = [&](const char* what) {
      Token s = next(tok);
      if (s.kind != Token::Kind::String)
        throw Error(s.kind == Token::Kind::End ? d.loc : tok.loc(s),
                    fmt::format("{}: expected {} (a quoted string)", d.name, what));
      d.strings.push_back(s.text);
    };
    switch (spec.args) {
      case Args::None:
        break;
      case Args::Numbers: {
        bool bracket = false;
        Token open;
        if (peek(tok).kind == Token::Kind::LBracket) {
          open = next(tok);
          bracket = true;
        }
        for (int i = 0; i < spec.count; ++i) {
          Token n = next(tok);
          std::optional<double> v;
          if (n.kind == Token::Kind::Word) v = parseNumber(n.text);
          if (v) requireFinite(*v, tok.loc(n), "");
          if (!v) {
            if (bracket && (n.kind == Token::Kind::End || n.kind == Token::Kind::Word))
              throw Error(tok.loc(open), "unterminated array");
            throw Error(d.loc,
                        fmt::format("{}: expected {} numbers, got {}", d.name, spec.count, i));
          }
          d.numbers.push_back(*v);
        }
        if (bracket) {
          Token c = next(tok);
          if (c.kind != Token::Kind::RBracket) {
            if (c.kind == Token::Kind::End || c.kind == Token::Kind::Word)
              throw Error(tok.loc(open), "unterminated array");
            throw Error(d.loc, fmt::format("{}: expected {} numbers", d.name, spec.count));
          }
        } else if (peek(tok).kind == Token::Kind::Word && parseNumber(peek(tok).text)) {
          throw Error(d.loc, fmt::format("{}: expected {} numbers, got more", d.name, spec.count));
        }
        break;
      }
      case Args::Word: {
        Token w = next(tok);
        if (w.kind != Token::Kind::Word ||
            (w.text != "StartTime" && w.text != "EndTime" && w.text != "All"))
          throw Error(w.kind == Token::Kind::End ? d.loc : tok.loc(w),
                      "ActiveTransform: expected StartTime, EndTime or All");
        d.word = w.text;
        break;
      }
      case Args::OneString:
        expectString("a name");
        break;
      case Args::TypeAndParams:
        expectString(d.name == "MakeNamedMaterial" || d.name == "MakeNamedMedium" ? "a name"
                                                                                  : "a type");
        d.params = parseParams(tok);
        break;
      case Args::TextureDecl:
        expectString("a texture name");
        expectString("a texture type (\"float\" or \"spectrum\")");
        expectString("a texture class");
        d.params = parseParams(tok);
        break;
      case Args::MediumInterface:
        expectString("a medium name");
        if (peek(tok).kind == Token::Kind::String) expectString("a medium name");
        break;
      case Args::Option: {
        // pbrt-v4 writes `Option "name" value`; `Option "type name" value` is accepted too.
        if (peek(tok).kind != Token::Kind::String)
          throw Error(d.loc, "Option: expected a quoted option name");
        if (peek(tok).text.find(' ') == std::string::npos) {
          Token name = next(tok);
          Token v = next(tok);
          Param p;
          p.loc = tok.loc(name);
          p.name = name.text;
          if (v.kind == Token::Kind::String) {
            p.type = ParamType::String;
            p.strings.push_back(v.text);
          } else if (v.kind == Token::Kind::Word && (v.text == "true" || v.text == "false")) {
            p.type = ParamType::Bool;
            p.bools.push_back(v.text == "true");
          } else if (auto x = v.kind == Token::Kind::Word ? parseNumber(v.text) : std::nullopt) {
            requireFinite(*x, tok.loc(v), "");
            p.type = *x == std::floor(*x) ? ParamType::Integer : ParamType::Float;
            p.numbers.push_back(*x);
          } else {
            throw Error(v.kind == Token::Kind::End ? d.loc : tok.loc(v),
                        fmt::format("Option \"{}\": missing value", name.text));
          }
          p.type_as_written = std::string(paramTypeName(p.type));
          d.params.push_back(std::move(p));
          break;
        }
        d.params = parseParams(tok);
        if (d.params.size() != 1) throw Error(d.loc, "Option: expected one parameter");
        break;
      }
    }
  }

  ParamList parseParams(TokenStream& tok) {
    ParamList list;
    while (peek(tok).kind == Token::Kind::String) {
      Token decl = next(tok);
      Param p;
      p.loc = tok.loc(decl);
      std::istringstream words(decl.text);
      std::string type, name, extra;
      words >> type >> name >> extra;
      if (type.empty() || name.empty() || !extra.empty())
        throw Error(p.loc, fmt::format("bad parameter declaration \"{}\"; expected \"type name\"",
                                       decl.text));
      bool legacy = false;
      auto pt = parseType(type, legacy);
      if (!pt)
        throw Error(p.loc, fmt::format("unknown parameter type \"{}\" in \"{}\"", type, decl.text));
      if (legacy) desc_.legacy_syntax = true;
      p.type = *pt;
      p.type_as_written = type;
      p.name = name;

      // The values: one token, or a bracketed list.
      std::vector<Token> values;
      if (peek(tok).kind == Token::Kind::LBracket) {
        Token open = next(tok);
        for (;;) {
          Token v = next(tok);
          if (v.kind == Token::Kind::RBracket) break;
          if (v.kind == Token::Kind::End || v.kind == Token::Kind::LBracket ||
              (v.kind == Token::Kind::Word && !parseNumber(v.text) && v.text != "true" &&
               v.text != "false"))
            throw Error(tok.loc(open), "unterminated array");
          values.push_back(std::move(v));
        }
      } else {
        Token v = next(tok);
        if (v.kind == Token::Kind::End || v.kind == Token::Kind::RBracket ||
            (v.kind == Token::Kind::Word && !parseNumber(v.text) && v.text != "true" &&
             v.text != "false"))
          throw Error(p.loc, fmt::format("\"{}\": missing value", decl.text));
        values.push_back(std::move(v));
      }
      convertValues(p, values, tok);
      list.push_back(std::move(p));
    }
    return list;
  }

  void convertValues(Param& p, const std::vector<Token>& values, TokenStream& tok) {
    const std::string decl = fmt::format("\"{} {}\"", p.type_as_written, p.name);
    auto wrongKind = [&](const Token& v, const char* expected) {
      throw Error(tok.loc(v),
                  fmt::format("{}: expected {}, got {}", decl, expected,
                              v.kind == Token::Kind::String ? fmt::format("string \"{}\"", v.text)
                                                            : fmt::format("'{}'", v.text)));
    };
    auto numbers = [&]() {
      for (const Token& v : values) {
        std::optional<double> x;
        if (v.kind == Token::Kind::Word) x = parseNumber(v.text);
        if (!x) wrongKind(v, "a number");
        // Every number in a scene is finite and fits a 32-bit float (util/limits.h).
        requireFinite(*x, tok.loc(v), "");
        p.numbers.push_back(*x);
      }
    };
    auto count = [&](size_t multiple, const char* what) {
      if (values.empty() || values.size() % multiple != 0)
        throw Error(p.loc, fmt::format("{}: expected {}, got {} value{}", decl, what, values.size(),
                                       values.size() == 1 ? "" : "s"));
    };
    switch (p.type) {
      case ParamType::Float:
        numbers();
        break;
      case ParamType::Integer:
        numbers();
        for (size_t i = 0; i < p.numbers.size(); ++i)
          if (p.numbers[i] != std::floor(p.numbers[i]) || std::abs(p.numbers[i]) > 2147483647.0)
            wrongKind(values[i], "an integer");
        break;
      case ParamType::Bool:
        for (const Token& v : values) {
          if (v.text == "true")
            p.bools.push_back(true);
          else if (v.text == "false")
            p.bools.push_back(false);
          else
            wrongKind(v, "true or false");
        }
        break;
      case ParamType::String:
      case ParamType::Texture:
        for (const Token& v : values) {
          if (v.kind != Token::Kind::String) wrongKind(v, "a quoted string");
          p.strings.push_back(v.text);
        }
        if (p.type == ParamType::Texture && values.size() != 1)
          throw Error(p.loc, fmt::format("{}: expected one texture name, got {} values", decl,
                                         values.size()));
        break;
      case ParamType::Point2:
      case ParamType::Vector2:
        numbers();
        count(2, "a multiple of 2 values");
        break;
      case ParamType::Point3:
      case ParamType::Vector3:
      case ParamType::Normal3:
      case ParamType::Rgb:
        numbers();
        count(3, "a multiple of 3 values");
        break;
      case ParamType::Spectrum:
        if (!values.empty() && values[0].kind == Token::Kind::String) {
          if (values.size() != 1)
            throw Error(p.loc, fmt::format("{}: expected one spectrum name or file, got {} values",
                                           decl, values.size()));
          p.strings.push_back(values[0].text);
        } else {
          numbers();
          count(2, "wavelength-value pairs (an even number of values)");
        }
        break;
      case ParamType::Blackbody:
        numbers();
        if (values.size() != 1 && values.size() != 2)
          throw Error(p.loc, fmt::format("{}: expected a temperature (and, in pbrt-v3, a scale), "
                                         "got {} values",
                                         decl, values.size()));
        if (values.size() == 2) desc_.legacy_syntax = true;
        break;
    }
  }

  void checkStructure(const DirectiveSpec& spec, const Directive& d) {
    using B = DirectiveSpec::Block;
    if (world_ended_) throw Error(d.loc, fmt::format("{} after WorldEnd", d.name));
    if (spec.block == B::Options && in_world_)
      throw Error(d.loc, fmt::format("{} is only allowed before WorldBegin", d.name));
    if (spec.block == B::World && !in_world_)
      throw Error(d.loc, fmt::format("{} is only allowed after WorldBegin", d.name));
    const std::string& n = d.name;
    if (n == "WorldBegin") {
      if (in_world_) throw Error(d.loc, "WorldBegin after WorldBegin");
      if (!stack_.empty())
        throw Error(d.loc, fmt::format("WorldBegin inside {} at {}", stack_.back().name,
                                       stack_.back().loc.str()));
      in_world_ = true;
    } else if (n == "WorldEnd") {
      if (!stack_.empty())
        throw Error(stack_.back().loc,
                    fmt::format("{} without matching {} before WorldEnd", stack_.back().name,
                                endName(stack_.back().name)));
      world_ended_ = true;
    } else if (n == "AttributeBegin" || n == "TransformBegin") {
      stack_.push_back({n, d.loc});
    } else if (n == "ObjectBegin") {
      for (const Block& b : stack_)
        if (b.name == "ObjectBegin")
          throw Error(d.loc, fmt::format("ObjectBegin inside the definition of object begun at {}",
                                         b.loc.str()));
      if (objects_.count(d.strings[0]))
        throw Error(d.loc, fmt::format("object \"{}\" is defined twice", d.strings[0]));
      stack_.push_back({n, d.loc});
      objects_.insert(d.strings[0]);
    } else if (n == "AttributeEnd" || n == "TransformEnd" || n == "ObjectEnd") {
      std::string begin = n == "AttributeEnd"   ? "AttributeBegin"
                          : n == "TransformEnd" ? "TransformBegin"
                                                : "ObjectBegin";
      if (stack_.empty()) throw Error(d.loc, fmt::format("{} without matching {}", n, begin));
      if (stack_.back().name != begin)
        throw Error(d.loc, fmt::format("{} does not match {} at {}", n, stack_.back().name,
                                       stack_.back().loc.str()));
      stack_.pop_back();
    } else if (n == "ObjectInstance") {
      for (const Block& b : stack_)
        if (b.name == "ObjectBegin")
          throw Error(d.loc, fmt::format("ObjectInstance inside the definition of object begun at "
                                         "{}",
                                         b.loc.str()));
      instance_uses_.push_back({d.strings[0], d.loc});
    }
  }

  static const char* endName(const std::string& begin) {
    return begin == "ObjectBegin"      ? "ObjectEnd"
           : begin == "AttributeBegin" ? "AttributeEnd"
                                       : "TransformEnd";
  }

  SceneDesc& desc_;
  TokenStream stream_;
  std::optional<Token> pending_;
  std::vector<Block> stack_;
  bool in_world_ = false;
  bool world_ended_ = false;
  std::set<std::string> objects_;
  std::vector<std::pair<std::string, FileLoc>> instance_uses_;
};

}  // namespace

SceneDesc parseFile(const std::string& path) {
  SceneDesc desc;
  desc.path = path;
  Parser parser(desc);
  parser.parseFile(path, nullptr);
  parser.finish();
  return desc;
}

SceneDesc parseString(std::string_view text, const std::string& file_name) {
  SceneDesc desc;
  desc.path = file_name;
  desc.files.push_back(file_name);
  Parser parser(desc);
  parser.parseText(text, file_name);
  parser.finish();
  return desc;
}

}  // namespace lensim::scene
