#include "lensim/optics/glass.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <tuple>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "lensim/optics/lens_formats.h"
#include "lensim/optics/glass/embedded.h"
#include "lensim/optics/glass/library.h"

namespace lensim::embedded {
extern const char* const kGlassCatalogCsv;
}

namespace lensim::optics {

// ---------------------------------------------------------------------------------------------
// Glass

Glass Glass::constant(double n) {
  Glass g;
  g.c_[0] = n;
  return g;
}

Glass Glass::model(double n_d, double v_d, const FileLoc& loc) {
  if (!std::isfinite(n_d) || n_d < 1)
    throw Error(loc,
                fmt::format("model glass: n_d {} is not physical; expected a value >= 1", n_d));
  if (!std::isfinite(v_d) || v_d <= 0)
    throw Error(loc, fmt::format("model glass: Abbe number V_d {} must be > 0", v_d));
  // n(l) = A + B / l^2 (l in micrometres) with n(d) = n_d and n(F) - n(C) = (n_d - 1) / V_d.
  const double lf = kLineF_nm / 1000, lc = kLineC_nm / 1000, ld = kLineD_nm / 1000;
  const double b = (n_d - 1) / v_d / (1 / (lf * lf) - 1 / (lc * lc));
  Glass g;
  g.formula_ = DispersionFormula::Cauchy2;
  g.c_ = {n_d - b / (ld * ld), b, 0, 0, 0, 0, 0, 0, 0};
  g.name_ = fmt::format("model {:.6g}/{:.4g}", n_d, v_d);
  // A two-term Cauchy fit is good through the visible; say so outside it.
  g.min_nm_ = 360, g.max_nm_ = 1000;
  return g;
}

Glass Glass::formula(std::string vendor, std::string name, DispersionFormula f,
                     const std::array<double, 9>& c, double min_nm, double max_nm) {
  Glass g;
  g.formula_ = f;
  std::copy(c.begin(), c.end(), g.c_.begin());
  g.c_[9] = 0;
  g.vendor_ = std::move(vendor);
  g.name_ = std::move(name);
  g.min_nm_ = min_nm, g.max_nm_ = max_nm;
  return g;
}

Glass Glass::zemax(std::string vendor, std::string name, ZemaxFormula f,
                   const ZemaxCoefficients& c, double min_nm, double max_nm,
                   std::vector<TransmittanceRow> transmittance) {
  Glass g;
  g.formula_ = DispersionFormula::Zemax;
  g.zemax_ = f;
  g.c_ = c;
  g.vendor_ = std::move(vendor);
  g.name_ = std::move(name);
  g.min_nm_ = min_nm, g.max_nm_ = max_nm;
  if (!transmittance.empty()) {
    std::stable_sort(transmittance.begin(), transmittance.end(),
                     [](const TransmittanceRow& a, const TransmittanceRow& b) {
                       return a.lambda_um < b.lambda_um;
                     });
    g.transmittance_ =
        std::make_shared<const std::vector<TransmittanceRow>>(std::move(transmittance));
  }
  return g;
}

std::string Glass::formulaName() const {
  switch (formula_) {
    case DispersionFormula::Constant:
      return "constant";
    case DispersionFormula::Sellmeier3:
      return "sellmeier3";
    case DispersionFormula::Schott6:
      return "schott6";
    case DispersionFormula::Hikari9:
      return "hikari9";
    case DispersionFormula::Cauchy2:
      return "Cauchy";
    case DispersionFormula::Zemax:
      return zemaxFormulaName(int(zemax_));
  }
  return "";
}

double Glass::internalTransmittance(double lambda_nm, double thickness_mm) const {
  if (!hasTransmittance() || thickness_mm <= 0) return 1;
  return std::exp(-absorptionCoefficient_per_mm(lambda_nm) * thickness_mm);
}

double Glass::absorptionCoefficient_per_mm(double lambda_nm) const {
  if (!hasTransmittance()) return 0;
  const std::vector<TransmittanceRow>& rows = *transmittance_;
  // Absorption coefficient (1/mm) of a row; a row of transmittance 0 is floored so that it
  // interpolates.
  auto alpha = [](const TransmittanceRow& r) {
    return -std::log(std::max(r.tau, 1e-300)) / r.thickness_mm;
  };
  const double l = lambda_nm * 1e-3;
  if (l <= rows.front().lambda_um) return alpha(rows.front());
  if (l >= rows.back().lambda_um) return alpha(rows.back());
  size_t i = 1;
  while (rows[i].lambda_um < l) ++i;
  const TransmittanceRow &lo = rows[i - 1], &hi = rows[i];
  const double t =
      hi.lambda_um > lo.lambda_um ? (l - lo.lambda_um) / (hi.lambda_um - lo.lambda_um) : 1.0;
  return (1 - t) * alpha(lo) + t * alpha(hi);
}

double Glass::index(double lambda_nm) const {
  const double l = lambda_nm * 1e-3, l2 = l * l;
  const auto& c = c_;
  switch (formula_) {
    case DispersionFormula::Constant:
      return c[0];
    case DispersionFormula::Cauchy2:
      return c[0] + c[1] / l2;
    case DispersionFormula::Sellmeier3:
      return std::sqrt(1 + c[0] * l2 / (l2 - c[3]) + c[1] * l2 / (l2 - c[4]) +
                       c[2] * l2 / (l2 - c[5]));
    case DispersionFormula::Schott6: {
      const double i2 = 1 / l2;
      return std::sqrt(c[0] + c[1] * l2 + i2 * (c[2] + i2 * (c[3] + i2 * (c[4] + i2 * c[5]))));
    }
    case DispersionFormula::Hikari9: {
      const double i2 = 1 / l2;
      return std::sqrt(
          c[0] + l2 * (c[1] + l2 * c[2]) +
          i2 * (c[3] + i2 * (c[4] + i2 * (c[5] + i2 * (c[6] + i2 * (c[7] + i2 * c[8]))))));
    }
    case DispersionFormula::Zemax:
      return zemaxIndex(zemax_, c, l);
  }
  return c[0];
}

double Glass::v_d() const {
  if (!dispersive()) return std::numeric_limits<double>::infinity();
  return (n_d() - 1) / (index(kLineF_nm) - index(kLineC_nm));
}

const char* Glass::kind() const {
  switch (formula_) {
    case DispersionFormula::Constant:
      return "constant";
    case DispersionFormula::Cauchy2:
      return "model";
    default:
      return "catalogue";
  }
}

std::string Glass::describe() const {
  switch (formula_) {
    case DispersionFormula::Constant:
      return isAir() ? "air" : fmt::format("constant {:.6g}", c_[0]);
    case DispersionFormula::Cauchy2:
      return fmt::format("model n_d {:.6g} V_d {:.4g} (Cauchy)", n_d(), v_d());
    default: {
      std::string v = vendor_;
      for (char& ch : v) ch = char(std::tolower(static_cast<unsigned char>(ch)));
      return v + ":" + name_;
    }
  }
}

std::string CatalogGlass::qualifiedName() const {
  return glass.describe();
}

// ---------------------------------------------------------------------------------------------
// Catalogue

namespace {

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = char(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

// Upper-case letters and digits only: "n-bk 7" and "NBK7" compare equal for hints.
std::string folded(std::string_view s) {
  std::string u;
  for (char c : s)
    if (std::isalnum(static_cast<unsigned char>(c)))
      u += char(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

int editDistance(const std::string& a, const std::string& b) {
  std::vector<int> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = int(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = int(i);
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

bool equalNoCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::toupper(static_cast<unsigned char>(a[i])) !=
        std::toupper(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

// "schott:N-BK7" -> ("schott", "N-BK7"); "N-BK7" -> ("", "N-BK7").
std::pair<std::string_view, std::string_view> splitQualified(std::string_view name) {
  if (const size_t colon = name.find(':'); colon != std::string_view::npos)
    return {name.substr(0, colon), name.substr(colon + 1)};
  return {{}, name};
}

std::vector<std::string_view> splitCsv(std::string_view line) {
  std::vector<std::string_view> out;
  size_t pos = 0;
  while (true) {
    const size_t comma = line.find(',', pos);
    out.push_back(line.substr(pos, comma == std::string_view::npos ? line.npos : comma - pos));
    if (comma == std::string_view::npos) break;
    pos = comma + 1;
  }
  return out;
}

}  // namespace

GlassCatalog GlassCatalog::parse(std::string_view csv, const std::string& path) {
  GlassCatalog cat;
  int line_no = 0;
  size_t pos = 0;
  while (pos < csv.size()) {
    size_t end = csv.find('\n', pos);
    if (end == std::string_view::npos) end = csv.size();
    std::string_view line = csv.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty() || line_no == 1) continue;  // the header
    const std::vector<std::string_view> f = splitCsv(line);
    auto column = [&](size_t i) {
      int col = 1;
      for (size_t k = 0; k < i; ++k) col += int(f[k].size()) + 1;
      return FileLoc{path, line_no, col};
    };
    if (f.size() < 6)
      throw Error(column(0), fmt::format("expected vendor,glass,nd,vd,formula,c1..., found {} "
                                         "fields",
                                         f.size()));
    auto number = [&](size_t i) {
      double v = 0;
      const std::string_view t = f[i];
      auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
      if (ec != std::errc() || p != t.data() + t.size() || !std::isfinite(v))
        throw Error(column(i), fmt::format("expected a number, found '{}'", t));
      return v;
    };
    CatalogGlass g;
    g.vendor = std::string(f[0]);
    g.name = std::string(f[1]);
    g.listed_n_d = number(2);
    g.listed_v_d = number(3);
    std::array<double, 9> c{};
    size_t nc = 0;
    for (size_t i = 5; i < f.size() && nc < 9; ++i)
      if (!f[i].empty()) c[nc++] = number(i);
    DispersionFormula formula;
    size_t needed;
    if (f[4] == "sellmeier3") {
      formula = DispersionFormula::Sellmeier3, needed = 6;
      // CDGM's spreadsheet gives B1 C1 B2 C2 B3 C3; only that order reproduces its n_d, V_d.
      if (upper(g.vendor) == "CDGM") c = {c[0], c[2], c[4], c[1], c[3], c[5], 0, 0, 0};
    } else if (f[4] == "schott6") {
      formula = DispersionFormula::Schott6, needed = 6;
    } else if (f[4] == "hikari9") {
      formula = DispersionFormula::Hikari9, needed = 9;
    } else {
      throw Error(column(4), fmt::format("unknown dispersion formula '{}'; expected sellmeier3, "
                                         "schott6 or hikari9",
                                         f[4]));
    }
    if (nc < needed)
      throw Error(column(4),
                  fmt::format("formula {} needs {} coefficients, found {}", f[4], needed, nc));
    g.glass = Glass::formula(g.vendor, g.name, formula, c);
    g.catalog = "csv";
    cat.glasses_.push_back(std::move(g));
  }
  cat.catalogs_ = {"csv"};
  cat.reindex();
  return cat;
}

GlassCatalog GlassCatalog::fromAgf(std::string_view bytes, const std::string& path,
                                   const std::string& catalog, const std::string& vendor) {
  GlassCatalog cat;
  cat.catalogs_ = {catalog};
  for (AgfGlass& a : parseAgf(bytes, path)) {
    CatalogGlass g;
    g.vendor = vendor;
    g.name = a.name;
    g.catalog = catalog;
    g.status = agfStatusName(a.status);
    g.listed_n_d = a.listed_n_d;
    g.listed_v_d = a.listed_v_d;
    // Without an LD line the formula's range is unknown: the visible, as the CSV catalogue's.
    const double lo = a.min_um > 0 ? a.min_um * 1000 : 365, hi = a.max_um > 0 ? a.max_um * 1000 : 1014;
    g.glass = Glass::zemax(vendor, a.name, ZemaxFormula(a.formula), a.coefficients, lo, hi,
                           std::move(a.transmittance));
    // A listed n_d of 1 or less is "not given" (Misc's crystals and plastics).
    const double n_d = g.glass.n_d();
    if (g.listed_n_d > 1 && g.glass.inRange(kLineD_nm) && !(std::abs(n_d - g.listed_n_d) <= 1e-3))
      g.problem = fmt::format("its catalogue's formula ({}) gives n_d {:.6f} but the catalogue "
                              "lists {} ({}:{})",
                              g.glass.formulaName(), n_d, g.listed_n_d, path, a.loc.line);
    cat.glasses_.push_back(std::move(g));
  }
  cat.reindex();
  return cat;
}

GlassCatalog GlassCatalog::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(FileLoc{path}, "cannot open the glass catalogue");
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::filesystem::path p(path);
  std::string ext = p.extension().string(), stem = p.stem().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  std::string key = stem;
  for (char& c : key) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".agf") return fromAgf(ss.str(), path, key, stem);
  if (ext == ".csv") {
    GlassCatalog cat = parse(decodeTextFile(ss.str(), path), path);
    for (CatalogGlass& g : cat.glasses_) g.catalog = key;
    cat.catalogs_ = {key};
    return cat;
  }
  throw Error(FileLoc{path}, fmt::format("glass catalogue '{}': expected a .agf (Zemax) or .csv "
                                         "file",
                                         p.filename().string()));
}

void GlassCatalog::reindex() {
  by_name_.clear();
  for (size_t i = 0; i < glasses_.size(); ++i)
    by_name_[upper(glasses_[i].name)].push_back(static_cast<std::uint32_t>(i));
}

void GlassCatalog::append(const GlassCatalog& other) {
  const size_t first = glasses_.size();
  glasses_.insert(glasses_.end(), other.glasses_.begin(), other.glasses_.end());
  for (size_t i = first; i < glasses_.size(); ++i)
    by_name_[upper(glasses_[i].name)].push_back(static_cast<std::uint32_t>(i));
  for (const std::string& c : other.catalogs_)
    if (!hasCatalog(c)) catalogs_.push_back(c);
}

bool GlassCatalog::hasCatalog(std::string_view name) const {
  for (const std::string& c : catalogs_)
    if (equalNoCase(c, name)) return true;
  return false;
}

int GlassCatalog::rank(const CatalogGlass& g) const {
  for (size_t i = 0; i < catalogs_.size(); ++i)
    if (catalogs_[i] == g.catalog) return int(i);
  return int(catalogs_.size());
}

const GlassCatalog& GlassCatalog::builtin() {
  static const GlassCatalog cat = [] {
    GlassCatalog all;
    for (const embedded::EmbeddedAgf& f : embedded::agfFiles())
      all.append(fromAgf(std::string_view(reinterpret_cast<const char*>(f.begin),
                                          size_t(f.end - f.begin)),
                         fmt::format("<built-in {}.agf>", f.stem), f.stem, f.vendor));
    // The CSV catalogue's glasses that no AGF file has (by vendor and name).
    const GlassCatalog csv = parse(embedded::kGlassCatalogCsv, "<built-in glass catalogue>");
    GlassCatalog extra;
    extra.catalogs_ = {"csv"};
    for (const CatalogGlass& g : csv.glasses_) {
      const CatalogGlass* agf = all.find(g.vendor + ":" + g.name);
      if (!agf) {
        extra.glasses_.push_back(g);
        continue;
      }
      // Some AGF coefficients (CDGM's Schott-formula fits) miss the V_d their own file lists by
      // up to 0.09, where the maker's spreadsheet (the CSV) gives it to 0.002: the spreadsheet's
      // formula is used for those, the AGF's data otherwise.
      const double agf_err = std::abs(agf->glass.v_d() - agf->listed_v_d);
      const double csv_err = std::abs(g.glass.v_d() - g.listed_v_d);
      if (agf_err > 0.02 && csv_err < 0.005 && std::abs(g.listed_n_d - agf->listed_n_d) < 1e-4 &&
          std::abs(g.listed_v_d - agf->listed_v_d) < 0.02)
        const_cast<CatalogGlass*>(agf)->glass = g.glass;
    }
    all.append(extra);
    // Crystals, plastics and tabulated glasses from refractiveindex.info, after the makers'
    // catalogues: a bare name Zemax's MISC or INFRARED catalogue also has (CAF2, PMMA, ...)
    // keeps meaning theirs.
    GlassCatalog crystals;
    crystals.catalogs_ = {"rii"};
    for (const embedded::CrystalGlass& c : embedded::crystalGlasses()) {
      ZemaxCoefficients k{};
      std::copy(std::begin(c.k), std::end(c.k), k.begin());
      std::vector<std::string> names{c.name};
      for (std::string_view rest = c.aliases; !rest.empty();) {
        const size_t sp = rest.find(' ');
        names.emplace_back(rest.substr(0, sp));
        rest = sp == std::string_view::npos ? std::string_view() : rest.substr(sp + 1);
      }
      for (const std::string& name : names) {
        CatalogGlass g;
        g.vendor = "rii";
        g.name = name;
        g.catalog = "rii";
        g.glass = Glass::zemax(g.vendor, name, static_cast<ZemaxFormula>(c.formula), k,
                               c.min_um * 1000, c.max_um * 1000);
        // The database lists no n_d or V_d: the formula's own.
        g.listed_n_d = g.glass.n_d();
        g.listed_v_d = g.glass.v_d();
        crystals.glasses_.push_back(std::move(g));
      }
    }
    all.append(crystals);
    return all;
  }();
  return cat;
}

const std::vector<std::string>& GlassCatalog::builtinCatalogNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const embedded::EmbeddedAgf& f : embedded::agfFiles()) n.push_back(f.stem);
    return n;
  }();
  return names;
}

const CatalogGlass* GlassCatalog::find(std::string_view name) const {
  return find(name, {});
}

const CatalogGlass* GlassCatalog::find(std::string_view name,
                                       const std::vector<std::string>& first) const {
  const auto [prefix, bare] = splitQualified(name);
  auto order = [&](const CatalogGlass& g) {
    for (size_t i = 0; i < first.size(); ++i)
      if (equalNoCase(first[i], g.catalog)) return int(i);
    return int(first.size()) + rank(g);
  };
  const auto it = by_name_.find(upper(bare));
  if (it == by_name_.end()) return nullptr;
  const CatalogGlass* best = nullptr;
  int best_order = 0;
  for (const std::uint32_t i : it->second) {
    const CatalogGlass& g = glasses_[i];
    if (!prefix.empty() && !equalNoCase(prefix, g.catalog) && !equalNoCase(prefix, g.vendor))
      continue;
    const int o = order(g);
    if (!best || o < best_order) best = &g, best_order = o;
  }
  return best;
}

std::vector<std::string> GlassCatalog::suggestions(std::string_view name, int count) const {
  std::string_view bare = name;
  if (const size_t colon = name.find(':'); colon != std::string_view::npos)
    bare = name.substr(colon + 1);
  const std::string key = folded(bare);
  // Ranked by: whether the name contains the key (BK7 in N-BK7, an old name's successor), then
  // edit distance, then vendor order.
  struct Scored {
    int contains, distance, rank;
    const CatalogGlass* g;
  };
  std::vector<Scored> scored;
  for (const CatalogGlass& g : glasses_) {
    if (!g.problem.empty()) continue;  // never suggest a glass lensim refuses
    const std::string f = folded(g.name);
    const bool contains = !key.empty() && f.find(key) != std::string::npos;
    scored.push_back({contains ? 0 : 1, editDistance(key, f), rank(g), &g});
  }
  std::stable_sort(scored.begin(), scored.end(), [](const Scored& a, const Scored& b) {
    return std::tie(a.contains, a.distance, a.rank) < std::tie(b.contains, b.distance, b.rank);
  });
  std::vector<std::string> out;
  const int max_distance = std::max<int>(3, int(key.size()) / 2);
  for (const Scored& s : scored) {
    if (int(out.size()) >= count) break;
    if (s.contains && s.distance > max_distance) continue;
    if (!s.contains && s.distance > max_distance) break;
    out.push_back(s.g->qualifiedName());
  }
  return out;
}

const CatalogGlass& GlassCatalog::nearest(double n_d, double v_d) const {
  const CatalogGlass* best = nullptr;
  double best_d = std::numeric_limits<double>::infinity();
  // Among the six makers' catalogues (and the CSV's glasses), the glasses old lenses used.
  static const char* const kMakers[] = {"schott", "ohara", "hoya", "cdgm", "sumita", "hikari", "csv"};
  for (const CatalogGlass& g : glasses_) {
    if (std::none_of(std::begin(kMakers), std::end(kMakers),
                     [&](const char* m) { return g.catalog == m; }))
      continue;
    double d;
    if (std::isnan(v_d)) {
      if (!equalNoCase(g.vendor, "Schott")) continue;
      d = std::abs(g.listed_n_d - n_d);
    } else {
      d = std::hypot(100 * (g.listed_n_d - n_d), g.listed_v_d - v_d);
    }
    if (d < best_d) best_d = d, best = &g;
  }
  if (!best) throw Error("the glass catalogue is empty");
  return *best;
}

// ---------------------------------------------------------------------------------------------
// Former glass names

namespace {

// Names lens files use that the vendors' current catalogues no longer list, with the catalogue
// glass that replaces them. Only rows with a source.
struct FormerName {
  const char* name;       // as lens files write it
  const char* successor;  // "vendor:name" in the built-in catalogue
};
constexpr FormerName kFormerNames[] = {
    // Hikari E-LAFH3 (lanthanum dense flint, in US 5,331,467's telephoto): ray-optics substitutes
    // Hikari J-LAFH3 for it when it reads that patent's Zemax file (mjhoptics/ray-optics,
    // src/rayoptics/zemax/models/PhotoPrime/US05331467-1.smx: {"E-LAFH3":
    // "HikariGlass('J-LAFH3')"}); with it, that lens's EFL is the patent's 1000 mm (ray-optics:
    // 999.6388 mm).
    {"E-LAFH3", "hikari:J-LAFH3"},
};

// The old names the refractiveindex.info database maps to a successor (glass/embedded.h).
const embedded::FormerGlassName* sourcedFormerName(std::string_view bare) {
  for (const embedded::FormerGlassName& f : embedded::formerGlassNames())
    if (upper(bare) == upper(f.name)) return &f;
  return nullptr;
}

}  // namespace

const CatalogGlass* findGlassOrSuccessor(std::string_view name, bool* successor_of,
                                         const std::vector<std::string>& catalogs) {
  if (successor_of) *successor_of = false;
  const GlassCatalog& cat = glassLibrary();
  if (const CatalogGlass* g = cat.find(name, catalogs)) return g;
  std::string_view bare = name;
  if (const size_t colon = name.find(':'); colon != std::string_view::npos)
    bare = name.substr(colon + 1);
  for (const FormerName& f : kFormerNames) {
    if (upper(bare) != upper(f.name)) continue;
    if (const CatalogGlass* g = cat.find(f.successor)) {
      if (successor_of) *successor_of = true;
      return g;
    }
  }
  if (const embedded::FormerGlassName* f = sourcedFormerName(bare))
    if (const CatalogGlass* g = cat.find(f->successor)) {
      if (successor_of) *successor_of = true;
      return g;
    }
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Resolving a lens file's glass

Glass resolveGlass(const GlassSpec& spec, double constant_ior, std::vector<Diagnostic>* diags) {
  auto note = [&](Severity s, std::string msg) {
    if (diags) diags->push_back({s, spec.loc, std::move(msg)});
  };
  if (!spec.name.empty()) {
    const GlassCatalog& cat = glassLibrary();
    if (const CatalogGlass* g = cat.find(spec.name, spec.catalogs)) {
      if (!g->problem.empty())
        throw Error(spec.loc, fmt::format("glass '{}' ({}): {}; lensim does not use it",
                                          spec.name, g->qualifiedName(), g->problem));
      const double n_d = g->glass.n_d();
      if (spec.n_d && std::abs(*spec.n_d - n_d) > 1e-3)
        note(Severity::Note,
             fmt::format("glass '{}': the file gives n_d {}, the catalogue's {} has {:.6f}; the "
                         "catalogue's formula is used",
                         spec.name, *spec.n_d, g->qualifiedName(), n_d));
      return g->glass;
    }
    bool successor = false;
    if (const CatalogGlass* g = findGlassOrSuccessor(spec.name, &successor, spec.catalogs);
        g && successor) {
      std::string_view bare = spec.name;
      if (const size_t colon = bare.find(':'); colon != std::string_view::npos)
        bare = bare.substr(colon + 1);
      if (const embedded::FormerGlassName* f = sourcedFormerName(bare);
          f && g->qualifiedName() == f->successor) {
        note(Severity::Warning,
             fmt::format("{} is {}'s old name; using {} (n_d {:.6f}, V_d {:.2f}): the glass "
                         "refractiveindex.info lists for it ({}){}",
                         std::string(bare), f->maker, g->qualifiedName(), g->glass.n_d(),
                         g->listed_v_d, f->source,
                         spec.n_d ? fmt::format("; the file's n_d {} is not used", *spec.n_d)
                                  : std::string()));
        return g->glass;
      }
      note(Severity::Warning,
           fmt::format("glass '{}' is not in the catalogue; using {} (n_d {:.6f}, V_d {:.2f}), "
                       "the glass that replaces it{}",
                       spec.name, g->qualifiedName(), g->glass.n_d(), g->listed_v_d,
                       spec.n_d ? fmt::format(" (the file's n_d {} is not used)", *spec.n_d)
                                : std::string()));
      return g->glass;
    }
    if (spec.n_d && spec.v_d && (!spec.model_needs_option || modelGlassAllowed())) {
      Glass m = Glass::model(*spec.n_d, *spec.v_d, spec.loc);
      note(Severity::Warning,
           fmt::format("glass '{}' is not in the catalogue; using a model glass from the file's "
                       "n_d {} and V_d {} (two-term Cauchy)",
                       spec.name, *spec.n_d, *spec.v_d));
      return m;
    }
    const std::vector<std::string> hints = cat.suggestions(spec.name);
    std::string msg = fmt::format("unknown glass '{}'", spec.name);
    if (!hints.empty()) {
      msg += "; did you mean ";
      for (size_t i = 0; i < hints.size(); ++i)
        msg += (i == 0 ? "" : (i + 1 == hints.size() ? " or " : ", ")) + hints[i];
      msg += "?";
    }
    msg += spec.n_d && spec.v_d
               ? fmt::format(" (it is in no glass catalogue; --model-glass uses the file's n_d {} "
                             "and V_d {} as a model glass; --glass-catalog FILE adds a catalogue)",
                             *spec.n_d, *spec.v_d)
               : std::string(" (give n_d and V_d instead for a model glass)");
    throw Error(spec.loc, msg);
  }
  if (spec.v_d) {
    const double n_d = spec.n_d ? *spec.n_d : constant_ior;
    return Glass::model(n_d, *spec.v_d, spec.loc);
  }
  if (spec.n_d) return Glass::constant(*spec.n_d);
  return Glass::constant(constant_ior == 0 ? 1.0 : constant_ior);
}

std::vector<Glass> resolveGlasses(const LensPrescription& p, std::vector<Diagnostic>* diags) {
  std::vector<Glass> out;
  out.reserve(p.surfaces.size());
  for (const LensSurface& s : p.surfaces) {
    GlassSpec spec = s.glass;
    if (!spec.loc.valid()) spec.loc = s.loc;
    out.push_back(resolveGlass(spec, s.ior, diags));
  }
  return out;
}

std::vector<Diagnostic> matchCatalogGlasses(LensPrescription& p) {
  std::vector<Diagnostic> notes;
  const GlassCatalog& cat = GlassCatalog::builtin();
  for (size_t i = 0; i < p.surfaces.size(); ++i) {
    LensSurface& s = p.surfaces[i];
    if (!s.glass.name.empty() || s.ior == 1.0 || s.ior == 0.0) continue;
    const double n = s.glass.n_d.value_or(s.ior);
    const double v = s.glass.v_d.value_or(std::numeric_limits<double>::quiet_NaN());
    const CatalogGlass& g = cat.nearest(n, v);
    notes.push_back(
        {Severity::Note, s.loc,
         fmt::format(
             "glass match: the medium after surface {} (n {:.5g}{}) -> {} (n_d {:.6f}, "
             "V_d {:.2f}){}",
             i + 1, n, std::isnan(v) ? "" : fmt::format(", V_d {:.4g}", v), g.qualifiedName(),
             g.listed_n_d, g.listed_v_d,
             std::isnan(v) ? "; the file gives no V_d: nearest n_d among Schott glasses" : "")});
    s.glass.name = g.qualifiedName();
    s.glass.n_d = g.listed_n_d;
    s.glass.v_d = g.listed_v_d;
    if (!s.glass.loc.valid()) s.glass.loc = s.loc;
    s.ior = g.listed_n_d;
  }
  return notes;
}

double primaryWavelength_nm(const LensPrescription& p) {
  return p.primary_wavelength_nm ? *p.primary_wavelength_nm : kDefaultPrimaryWavelength_nm;
}

void checkWavelength(double lambda_nm, const std::string& what) {
  if (!std::isfinite(lambda_nm) || lambda_nm < 200 || lambda_nm > 2500)
    throw Error(fmt::format("{}: wavelength {} nm is outside 200-2500 nm", what, lambda_nm));
}

}  // namespace lensim::optics
