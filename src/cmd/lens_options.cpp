#include "lens_options.h"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <limits>

#include "lensim/optics/configurations.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/glass/library.h"
#include "lensim/optics/paraxial.h"
#include "lensim/util/log.h"

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
  cmd->add_option("--wavelength", args.wavelength_nm,
                  "Wavelength in nm to analyse at (default: the file's primary wavelength, else "
                  "587.56, the d line); focus is solved at the primary wavelength");
  cmd->add_flag("--glass-match", args.glass_match,
                "Give each element the catalogue glass nearest its index and Abbe number (prints "
                "the choice)");
  auto* config = cmd->add_option("--config", args.configuration,
                                 "Configuration N (1-based) of a multi-configuration (zoom) lens");
  cmd->add_option("--focal-length", args.zoom_focal_length_mm,
                  "Zoom lens: set the spacings for this focal length (mm), interpolated "
                  "linearly between the two neighbouring configurations")
      ->excludes(config);
  cmd->add_option("--glass-catalog", args.glass_catalogs,
                  "Glass catalogue file (.agf or .csv) searched before the built-in ones; "
                  "repeatable, searched in the order given (docs/glass.md)");
  cmd->add_flag("--model-glass", args.model_glass,
                "A glass in no catalogue becomes a model glass from the n_d and V_d its lens "
                "file gives (reported in lens info); without it such a glass is an error");
  cmd->add_flag("--glass-extrapolate", args.glass_extrapolate,
                "Use a glass formula outside its catalogue's wavelength range (a warning); "
                "without it that is an error");
}

void applyGlassOptions(const LensArgs& args) {
  optics::setModelGlassAllowed(args.model_glass);
  optics::setGlassExtrapolationAllowed(args.glass_extrapolate);
  for (const std::string& f : args.glass_catalogs)
    optics::addGlassCatalogFile(f, FileLoc{f});
}

optics::LensPrescription applyConfigurationArgs(const LensArgs& args,
                                                optics::LensPrescription prescription) {
  if (args.configuration) return optics::selectConfiguration(prescription, *args.configuration);
  if (args.zoom_focal_length_mm) {
    optics::ZoomSetting z = optics::zoomToFocalLength(prescription, *args.zoom_focal_length_mm);
    logInfo(fmt::format("zoom: configurations {} and {} at t = {:.6f} (thicknesses linear in t): "
                        "EFL {:.6f} mm for {:.6f} mm requested",
                        z.config_a, z.config_b, z.t, z.achieved_efl_mm, z.requested_efl_mm));
    return std::move(z.prescription);
  }
  return prescription;
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
  applyGlassOptions(args);
  optics::LensPrescription prescription =
      applyConfigurationArgs(args, optics::readLensFile(args.lens_path));
  if (args.glass_match)
    for (const Diagnostic& d : optics::matchCatalogGlasses(prescription)) logDiagnostic(d);
  // Focus at the primary wavelength, then the indices (and paraxial data) at --wavelength.
  optics::FocusedLens fl = [&] {
    try {
      return optics::focusLens(std::move(prescription), setup);
    } catch (const Error& e) {
      // Focus and tracing errors have no row of their own: name the lens file (issue 16).
      if (e.loc().valid() && e.loc().line > 0) throw;
      throw LensSetupError(e.loc().valid() ? e.loc() : FileLoc{args.lens_path}, e.message());
    }
  }();
  if (args.wavelength_nm) {
    const double l = *args.wavelength_nm;
    optics::checkWavelength(l, "--wavelength");
    for (size_t i = 0; i < fl.lens->glasses().size(); ++i) {
      const optics::Glass& g = fl.lens->glasses()[i];
      if (g.dispersive() && !g.inRange(l)) {
        const auto& row = fl.lens->prescription().surfaces[i];
        std::vector<Diagnostic> warnings;
        optics::checkGlassRange(g, l, row.glass.loc.valid() ? row.glass.loc : row.loc,
                                "--wavelength", &warnings);
        for (const Diagnostic& d : warnings) logDiagnostic(d);
        break;  // once
      }
    }
    fl.lens->setWavelength(l);
    fl.paraxial = optics::computeParaxial(*fl.lens);
  }
  return fl;
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
