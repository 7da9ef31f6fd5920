#include "lensim/optics/glass/agf.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <string_view>

#include "lensim/optics/lens_formats.h"

namespace lensim::optics {

namespace {

struct FormulaInfo {
  const char* name;
  int coefficients;
};

// Zemax's dispersion formulas by number (1-based), from the OpticStudio manual's glass catalogue
// chapter ("Dispersion formulas").
constexpr FormulaInfo kFormulas[] = {
    {"Schott", 6},          {"Sellmeier 1", 6}, {"Herzberger", 6},     {"Sellmeier 2", 5},
    {"Conrady", 3},         {"Sellmeier 3", 8}, {"Handbook of Optics 1", 4},
    {"Handbook of Optics 2", 4},                {"Sellmeier 4", 5},    {"Extended", 8},
    {"Sellmeier 5", 10},    {"Extended 2", 8},  {"Extended 3", 9},
};
constexpr int kFormulaCount = int(sizeof(kFormulas) / sizeof(kFormulas[0]));

// sum_i K_i l^2 / (l^2 - L_i) over `terms` interleaved pairs K1 L1 K2 L2 ...
double sellmeierSum(const ZemaxCoefficients& c, int terms, double l2) {
  double s = 0;
  for (int i = 0; i < terms; ++i) s += c[size_t(2 * i)] * l2 / (l2 - c[size_t(2 * i + 1)]);
  return s;
}

// a0 + a1 l^2 + a2 l^-2 + a3 l^-4 + ... + a_{n-1} l^-2(n-2): the Schott/Extended series.
double schottSeries(const ZemaxCoefficients& c, int n, double l2) {
  double s = c[0] + c[1] * l2, inv = 1;
  for (int i = 2; i < n; ++i) {
    inv /= l2;
    s += c[size_t(i)] * inv;
  }
  return s;
}

// AGF fields are separated by spaces, tabs, form feeds or vertical tabs.
constexpr std::string_view kAgfSeparators = " \t\f\v";

using Token = LineField;

}  // namespace

const char* zemaxFormulaName(int number) {
  return number >= 1 && number <= kFormulaCount ? kFormulas[number - 1].name : "";
}

int zemaxFormulaCoefficients(int number) {
  return number >= 1 && number <= kFormulaCount ? kFormulas[number - 1].coefficients : 0;
}

double zemaxIndex(ZemaxFormula f, const ZemaxCoefficients& c, double l) {
  const double l2 = l * l, l4 = l2 * l2;
  switch (f) {
    case ZemaxFormula::Schott:
      return std::sqrt(schottSeries(c, 6, l2));
    case ZemaxFormula::Sellmeier1:
      return std::sqrt(1 + sellmeierSum(c, 3, l2));
    case ZemaxFormula::Herzberger: {
      const double L = 1 / (l2 - 0.028);
      return c[0] + c[1] * L + c[2] * L * L + c[3] * l2 + c[4] * l4 + c[5] * l4 * l2;
    }
    case ZemaxFormula::Sellmeier2:
      return std::sqrt(1 + c[0] + c[1] * l2 / (l2 - c[2] * c[2]) + c[3] / (l2 - c[4] * c[4]));
    case ZemaxFormula::Conrady:
      return c[0] + c[1] / l + c[2] / std::pow(l, 3.5);
    case ZemaxFormula::Sellmeier3:
      return std::sqrt(1 + sellmeierSum(c, 4, l2));
    case ZemaxFormula::HandbookOfOptics1:
      return std::sqrt(c[0] + c[1] / (l2 - c[2]) - c[3] * l2);
    case ZemaxFormula::HandbookOfOptics2:
      return std::sqrt(c[0] + c[1] * l2 / (l2 - c[2]) - c[3] * l2);
    case ZemaxFormula::Sellmeier4:
      return std::sqrt(c[0] + c[1] * l2 / (l2 - c[2]) + c[3] * l2 / (l2 - c[4]));
    case ZemaxFormula::Extended1:
      return std::sqrt(schottSeries(c, 8, l2));
    case ZemaxFormula::Sellmeier5:
      return std::sqrt(1 + sellmeierSum(c, 5, l2));
    case ZemaxFormula::Extended2:
      return std::sqrt(schottSeries(c, 6, l2) + c[6] * l4 + c[7] * l4 * l2);
    case ZemaxFormula::Extended3: {
      // a0 + a1 l^2 + a2 l^4 + a3 l^-2 + ... + a8 l^-12
      double s = c[0] + c[1] * l2 + c[2] * l4, inv = 1;
      for (size_t i = 3; i < 9; ++i) {
        inv /= l2;
        s += c[i] * inv;
      }
      return std::sqrt(s);
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::string agfStatusName(int status) {
  static const char* names[] = {"standard", "preferred", "obsolete", "special", "melt"};
  return status >= 0 && status <= 4 ? names[status] : fmt::format("status {}", status);
}

std::vector<AgfGlass> parseAgf(std::string_view bytes, const std::string& path) {
  const std::string text = decodeTextFile(bytes, path);
  std::vector<AgfGlass> out;
  // Split into lines at CRLF, LF or CR; a line that starts with a number continues the line
  // before it (long CD lines are wrapped so in some catalogues).
  struct Line {
    int no;
    std::vector<Token> tokens;
  };
  std::vector<Line> lines;
  int line_no = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string::npos) end = text.size();
    const std::string_view line(text.data() + pos, end - pos);
    ++line_no;
    pos = end + (end < text.size() && text[end] == '\r' && end + 1 < text.size() &&
                         text[end + 1] == '\n'
                     ? 2
                     : 1);
    std::vector<Token> t = splitFields(line, kAgfSeparators);
    if (t.empty()) continue;
    const char c0 = t[0].text[0];
    const bool continuation = (c0 >= '0' && c0 <= '9') || c0 == '-' || c0 == '+' || c0 == '.';
    if (continuation && !lines.empty() && lines.back().tokens[0].text == "CD") {
      // Columns of a continuation are on its own line; errors there point at its first token.
      for (Token& tk : t) lines.back().tokens.push_back(tk);
      continue;
    }
    lines.push_back({line_no, std::move(t)});
  }

  for (const Line& ln : lines) {
    const std::vector<Token>& t = ln.tokens;
    auto loc = [&](size_t i) { return FileLoc{path, ln.no, t[std::min(i, t.size() - 1)].col}; };
    auto number = [&](size_t i, const char* what) {
      double v = 0;
      const std::string_view s = t[i].text;
      auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
      if (ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v))
        throw Error(loc(i), fmt::format("{}: expected a number, found '{}'", what, s));
      return v;
    };
    const std::string_view key = t[0].text;
    if (key == "NM") {
      if (t.size() < 6)
        throw Error(loc(0), fmt::format("NM line: expected NM name formula MIL n_d V_d "
                                        "[exclude status melt], found {} fields",
                                        t.size() - 1));
      AgfGlass g;
      g.name = std::string(t[1].text);
      g.loc = loc(0);
      const double f = number(2, "NM dispersion formula number");
      if (f != std::floor(f) || zemaxFormulaCoefficients(int(f)) == 0)
        throw Error(loc(2), fmt::format("glass '{}': dispersion formula {} is not one Zemax "
                                        "defines; expected 1 to {}",
                                        g.name, t[2].text, kFormulaCount));
      g.formula = int(f);
      g.listed_n_d = number(4, "NM n_d");
      g.listed_v_d = number(5, "NM V_d");
      if (t.size() > 7) {
        const double st = number(7, "NM status");
        if (st != std::floor(st) || st < 0 || st > 4)
          throw Error(loc(7), fmt::format("glass '{}': status {} is not one of 0 (standard), 1 "
                                          "(preferred), 2 (obsolete), 3 (special), 4 (melt)",
                                          g.name, t[7].text));
        g.status = int(st);
      }
      out.push_back(std::move(g));
      continue;
    }
    const bool data = key == "CD" || key == "LD" || key == "IT" || key == "TD" || key == "OD" ||
                      key == "ED";
    if (!data) continue;  // CC, GC, MD, BD and unknown keywords carry nothing lensim uses
    if (out.empty())
      throw Error(loc(0), fmt::format("{} line before any NM (glass name) line", key));
    AgfGlass& g = out.back();
    if (key == "CD") {
      const int need = zemaxFormulaCoefficients(g.formula);
      if (int(t.size()) - 1 < need)
        throw Error(loc(t.size() - 1),
                    fmt::format("glass '{}': formula {} ({}) needs {} CD coefficients, found {}",
                                g.name, g.formula, zemaxFormulaName(g.formula), need,
                                t.size() - 1));
      for (size_t i = 1; i < t.size(); ++i) {
        const double v = number(i, "CD coefficient");
        if (i - 1 < size_t(kMaxZemaxCoefficients)) {
          g.coefficients[i - 1] = v;
        } else if (v != 0) {
          throw Error(loc(i), fmt::format("glass '{}': CD coefficient {} is {}; Zemax formulas "
                                          "have at most {}",
                                          g.name, i, t[i].text, kMaxZemaxCoefficients));
        }
      }
    } else if (key == "LD") {
      if (t.size() < 3)
        throw Error(loc(0), "LD line: expected LD min max (micrometres)");
      g.min_um = number(1, "LD minimum wavelength");
      g.max_um = number(2, "LD maximum wavelength");
      if (!(g.min_um > 0 && g.max_um > g.min_um))
        throw Error(loc(1), fmt::format("glass '{}': wavelength range {}-{} um is empty; "
                                        "expected 0 < min < max",
                                        g.name, t[1].text, t[2].text));
    } else if (key == "IT") {
      // Vendors' files have rows that carry no transmittance: a value missing (Schott), -999 for
      // "not measured" (Hoya), a thickness of 0 (Nikon), a typo above 1 (Hikari). Such rows are
      // skipped and counted; a value that is not a number is an error.
      for (size_t i = 1; i < t.size(); ++i) number(i, "IT value");
      if (t.size() < 4) {
        ++g.skipped_transmittance_rows;
        continue;
      }
      TransmittanceRow r{number(1, "IT wavelength"), number(2, "IT transmittance"),
                         number(3, "IT thickness")};
      if (!(r.lambda_um > 0) || r.tau < 0 || r.tau > 1 || !(r.thickness_mm > 0)) {
        ++g.skipped_transmittance_rows;
        continue;
      }
      g.transmittance.push_back(r);
    } else {
      std::vector<double>& v = key == "TD" ? g.thermal : key == "OD" ? g.other : g.extra;
      v.clear();
      // Thermal and other data are informative: a '-' (not given) reads as NaN.
      for (size_t i = 1; i < t.size(); ++i) {
        double x = std::numeric_limits<double>::quiet_NaN();
        std::from_chars(t[i].text.data(), t[i].text.data() + t[i].text.size(), x);
        v.push_back(x);
      }
    }
  }
  return out;
}

}  // namespace lensim::optics
