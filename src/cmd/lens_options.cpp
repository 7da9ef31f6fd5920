#include "lens_options.h"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <limits>

namespace lensim::cmd {

namespace {

std::optional<double> toNumber(std::string s) {
  while (!s.empty() && (s.front() == ' ')) s.erase(s.begin());
  while (!s.empty() && (s.back() == ' ')) s.pop_back();
  if (!s.empty() && s.front() == '+') s.erase(s.begin());
  double v = 0;
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || s.empty()) return std::nullopt;
  return v;
}

}  // namespace

void addLensOptions(CLI::App* cmd, LensArgs& args) {
  cmd->add_option("LENS", args.lens_path, "Lens prescription (.dat, pbrt/ISET/axpos layouts)")
      ->required();
  addLensSetupOptions(cmd, args);
}

void addLensSetupOptions(CLI::App* cmd, LensArgs& args) {
  cmd->add_option("--aperture-diameter", args.aperture_diameter_mm,
                  "Stop diameter in mm (clamped to the stop's size)");
  cmd->add_option("--focus-distance", args.focus_distance,
                  "Distance in focus, metres from the film ('inf' for infinity)");
  cmd->add_option("--film-distance", args.film_distance_mm,
                  "Film distance behind the rear vertex, mm");
  cmd->add_option("--film-diagonal", args.film_diagonal_mm, "Film diagonal, mm (default 35)");
  cmd->add_option("--focus-method", args.focus_method, "thick (pbrt-v4) or exact (real rays)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, optics::FocusMethod>{{"thick", optics::FocusMethod::Thick},
                                                     {"exact", optics::FocusMethod::Exact}},
          CLI::ignore_case));
}

optics::FocusedLens setUpLens(const LensArgs& args) {
  optics::LensSetup setup;
  setup.aperture_diameter_mm = args.aperture_diameter_mm;
  setup.film_distance_mm = args.film_distance_mm;
  setup.focus_method = args.focus_method;
  if (!args.focus_distance.empty())
    setup.focus_distance_m = parseDistance_m(args.focus_distance, "--focus-distance");
  if (!(args.film_diagonal_mm > 0))
    throw Error(fmt::format("--film-diagonal {} mm must be > 0", args.film_diagonal_mm));
  optics::LensPrescription prescription = optics::readLensFile(args.lens_path);
  try {
    return optics::focusLens(std::move(prescription), setup);
  } catch (const Error& e) {
    // Focus and tracing errors have no row of their own: name the lens file (issue 16).
    if (e.loc().valid()) throw;
    throw Error(FileLoc{args.lens_path}, e.message());
  }
}

Vec2 parsePair(const std::string& text, const std::string& option) {
  auto comma = text.find(',');
  if (comma != std::string::npos) {
    auto x = toNumber(text.substr(0, comma));
    auto y = toNumber(text.substr(comma + 1));
    if (x && y && std::isfinite(*x) && std::isfinite(*y)) return {*x, *y};
  }
  throw Error(fmt::format("{} '{}': expected two numbers X,Y (mm)", option, text));
}

double parseDistance_m(const std::string& text, const std::string& option) {
  if (text == "inf" || text == "infinity" || text == "Inf")
    return std::numeric_limits<double>::infinity();
  auto v = toNumber(text);
  if (!v || !(*v > 0) || std::isnan(*v))
    throw Error(fmt::format("{} '{}': expected a distance > 0 in metres, or 'inf'", option, text));
  return *v;
}

}  // namespace lensim::cmd
