// Typed access to a directive's parameters for the builder. Every getter records which
// parameters it consumed, so that parameters nobody asked for (misspelled ones) can be reported
// as errors with their location.
#pragma once

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lensim/scene/parser.h"
#include "lensim/util/vec.h"

namespace lensim::scene {

/// The parameters of one directive (plus any `Attribute` defaults), with use tracking.
/// Getters take the current name first and then older pbrt names accepted for it; a parameter
/// found with a type the getter does not accept is an error at the parameter's location.
class ParamSet {
 public:
  ParamSet(const ParamList& params, FileLoc directive_loc, std::string directive);
  /// Adds defaults (from `Attribute` directives); parameters given directly take precedence.
  void addDefaults(const ParamList& params);

  using Names = std::initializer_list<std::string_view>;

  /// The parameter called by one of `names` (first match wins), if its type is one of `types`;
  /// marks it used. Throws lensim::Error if it exists with another type.
  const Param* find(Names names, std::initializer_list<ParamType> types);
  /// Like find, without marking the parameter used or checking its type.
  const Param* peek(Names names);

  double getFloat(Names names, double def);
  std::optional<double> findFloat(Names names);
  int getInt(Names names, int def);
  bool getBool(Names names, bool def);
  std::string getString(Names names, const std::string& def);
  std::optional<std::string> findString(Names names);
  std::vector<int> getInts(Names names);
  std::optional<Vec3> findPoint3(Names names);
  /// All values of a point3/vector3/normal3 array parameter.
  std::vector<Vec3> getVec3s(Names names, std::initializer_list<ParamType> types);

  /// Throws lensim::Error at `p`'s location with `message` prefixed by the parameter name.
  [[noreturn]] void fail(const Param& p, std::string_view message) const;
  /// Throws lensim::Error at `p`'s location unless it has exactly `n` values.
  void expectCount(const Param& p, size_t n) const;

  /// Marks every parameter used (for types lensim does not interpret).
  void markAllUsed();
  /// An error for every parameter not consumed: `"name": unused parameter`.
  void reportUnused(std::vector<Diagnostic>& out) const;

  const FileLoc& loc() const { return loc_; }
  const std::string& directive() const { return directive_; }

 private:
  struct Entry {
    const Param* param;
    bool used = false;
    bool is_default = false;  // from `Attribute`: not reported when unused
  };
  std::vector<Entry> entries_;
  std::vector<std::string> queried_;  // every name a getter asked for
  // Parameters given twice with different types: (earlier, later); the later one is used.
  std::vector<std::pair<const Param*, const Param*>> shadowed_;
  FileLoc loc_;
  std::string directive_;
};

/// Number of values a parameter has (numbers, strings or bools).
size_t valueCount(const Param& p);

/// Levenshtein distance between two names (for "did you mean" hints).
size_t editDistance(std::string_view a, std::string_view b);

/// The "did you mean" hint for a misspelt name: "; did you mean \"NAME\"?" for the first of
/// `names` (strings, or map entries whose key is the name) nearest to `word` and fewer than
/// `max_edits_exclusive` edits away, or "" if none is.
template <class Names>
std::string didYouMean(std::string_view word, const Names& names, size_t max_edits_exclusive) {
  std::string_view best;
  size_t best_d = max_edits_exclusive;
  for (const auto& entry : names) {
    std::string_view name;
    if constexpr (requires { entry.first; })
      name = entry.first;
    else
      name = entry;
    if (name == word) continue;
    if (const size_t d = editDistance(word, name); d < best_d) best_d = d, best = name;
  }
  std::string hint;
  if (!best.empty()) {
    hint = "; did you mean \"";
    hint += best;
    hint += "\"?";
  }
  return hint;
}

}  // namespace lensim::scene
