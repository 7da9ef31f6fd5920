#include "lensim/scene/params.h"

#include <fmt/format.h>

#include <algorithm>

namespace lensim::scene {

size_t valueCount(const Param& p) {
  return p.numbers.size() + p.strings.size() + p.bools.size();
}

ParamSet::ParamSet(const ParamList& params, FileLoc directive_loc, std::string directive)
    : loc_(std::move(directive_loc)), directive_(std::move(directive)) {
  for (const Param& p : params) {
    // A parameter given twice: the last one written is used and the earlier one is ignored,
    // as pbrt-v4 does (its ParameterDictionary reverses the list so lookups find the last one
    // first, and ReportUnused lets a shadowed duplicate of the same type and name pass:
    // src/pbrt/paramdict.cpp) and as pbrt-v3's ParamSet::Add* (which erase the earlier one).
    bool replaced = false;
    for (Entry& e : entries_)
      if (e.param->name == p.name) {
        if (e.param->type != p.type) shadowed_.push_back({e.param, &p});
        e.param = &p;
        replaced = true;
      }
    if (!replaced) entries_.push_back({&p, false, false});
  }
}

void ParamSet::addDefaults(const ParamList& params) {
  for (const Param& p : params) {
    bool present = false;
    for (const Entry& e : entries_) present = present || e.param->name == p.name;
    if (!present) entries_.push_back({&p, false, true});
  }
}

size_t editDistance(std::string_view a, std::string_view b) {
  // The distance is at least the difference in length; callers only look for near misses, so a
  // long word (a 10 MB token) is answered by that bound instead of a quadratic table.
  const size_t diff = a.size() > b.size() ? a.size() - b.size() : b.size() - a.size();
  if (diff > 16) return diff;
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

const Param* ParamSet::peek(Names names) {
  for (std::string_view n : names) queried_.emplace_back(n);
  for (std::string_view n : names)
    for (const Entry& e : entries_)
      if (e.param->name == n) return e.param;
  return nullptr;
}

const Param* ParamSet::find(Names names, std::initializer_list<ParamType> types) {
  for (std::string_view n : names) queried_.emplace_back(n);
  for (std::string_view n : names)
    for (Entry& e : entries_) {
      if (e.param->name != n) continue;
      if (std::find(types.begin(), types.end(), e.param->type) == types.end()) {
        std::string expected;
        for (ParamType t : types) {
          if (!expected.empty()) expected += " or ";
          expected += paramTypeName(t);
        }
        throw Error(e.param->loc,
                    fmt::format("\"{}\": wrong parameter type \"{}\" for {} parameter; expected {}",
                                e.param->name, e.param->type_as_written, directive_, expected));
      }
      e.used = true;
      return e.param;
    }
  return nullptr;
}

void ParamSet::fail(const Param& p, std::string_view message) const {
  throw Error(p.loc, fmt::format("\"{}\": {}", p.name, message));
}

void ParamSet::expectCount(const Param& p, size_t n) const {
  size_t c = valueCount(p);
  if (p.type == ParamType::Point3 || p.type == ParamType::Vector3 || p.type == ParamType::Normal3 ||
      p.type == ParamType::Rgb)
    c /= 3;
  else if (p.type == ParamType::Point2 || p.type == ParamType::Vector2)
    c /= 2;
  if (c != n) fail(p, fmt::format("expected {} value{}, got {}", n, n == 1 ? "" : "s", c));
}

std::optional<double> ParamSet::findFloat(Names names) {
  const Param* p = find(names, {ParamType::Float});
  if (!p) return std::nullopt;
  expectCount(*p, 1);
  return p->numbers[0];
}

double ParamSet::getFloat(Names names, double def) {
  return findFloat(names).value_or(def);
}

int ParamSet::getInt(Names names, int def) {
  const Param* p = find(names, {ParamType::Integer});
  if (!p) return def;
  expectCount(*p, 1);
  return static_cast<int>(p->numbers[0]);
}

bool ParamSet::getBool(Names names, bool def) {
  const Param* p = find(names, {ParamType::Bool});
  if (!p) return def;
  expectCount(*p, 1);
  return p->bools[0];
}

std::optional<std::string> ParamSet::findString(Names names) {
  const Param* p = find(names, {ParamType::String});
  if (!p) return std::nullopt;
  expectCount(*p, 1);
  return p->strings[0];
}

std::string ParamSet::getString(Names names, const std::string& def) {
  return findString(names).value_or(def);
}

std::vector<int> ParamSet::getInts(Names names) {
  const Param* p = find(names, {ParamType::Integer});
  std::vector<int> r;
  if (p)
    for (double v : p->numbers) r.push_back(static_cast<int>(v));
  return r;
}

std::optional<Vec3> ParamSet::findPoint3(Names names) {
  const Param* p = find(names, {ParamType::Point3});
  if (!p) return std::nullopt;
  expectCount(*p, 1);
  return Vec3{p->numbers[0], p->numbers[1], p->numbers[2]};
}

std::vector<Vec3> ParamSet::getVec3s(Names names, std::initializer_list<ParamType> types) {
  const Param* p = find(names, types);
  std::vector<Vec3> r;
  if (p)
    for (size_t i = 0; i + 2 < p->numbers.size(); i += 3)
      r.push_back({p->numbers[i], p->numbers[i + 1], p->numbers[i + 2]});
  return r;
}

void ParamSet::markAllUsed() {
  for (Entry& e : entries_) e.used = true;
}

void ParamSet::reportUnused(std::vector<Diagnostic>& out) const {
  for (const auto& [earlier, later] : shadowed_)
    out.push_back(
        {Severity::Warning, earlier->loc,
         fmt::format("\"{}\": given again as \"{} {}\" at {}; the later one is used", earlier->name,
                     later->type_as_written, later->name, later->loc.str())});
  for (const Entry& e : entries_)
    if (!e.used && !e.is_default) {
      // Suggest the nearest name a getter asked for (a misspelling is at most 2 edits away).
      out.push_back({Severity::Error, e.param->loc,
                     fmt::format("\"{}\": unused parameter{}", e.param->name,
                                 didYouMean(e.param->name, queried_,
                                            std::min<size_t>(3, e.param->name.size() / 2 + 1)))});
    }
}

}  // namespace lensim::scene
