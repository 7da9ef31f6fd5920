// Coatings and reflection losses in `lensim lens info`, and `lensim lens ghosts` (issue 31).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "commands.h"

namespace lensim::optics {
class LensSystem;
}

namespace lensim::cmd {

struct LensArgs;

/// The lens's coatings and its axial transmittance (reflection losses) for `lens info --json`;
/// {"error": message} when the coatings cannot be resolved (a Zemax coating file not beside the
/// lens file).
nlohmann::json coatingsJson(const optics::LensSystem& lens);
/// The same as text lines for `lens info`.
void printCoatings(const optics::LensSystem& lens);

/// `lensim lens draw LENS --ghost I,J -o OUT`: the lens diagram with the rays of the ghost that
/// reflects at surface I, then at J (`ghost` is the option's text, checked here).
int runGhostDraw(const LensArgs& args, const std::string& ghost, int rays,
                 const std::string& output);

/// `lensim lens plot ghosts LENS -o OUT`: a bar chart of the brightest ghosts' intensities
/// (ghost / direct energy, 400..700 nm, the lens's coatings): the axial paraxial ones, or with
/// `angle_deg` those traced for a light at that angle (`lens ghosts --angle`); `as_json` also
/// prints the plotted numbers.
int runGhostPlot(const LensArgs& args, const std::string& output, bool as_json,
                 std::optional<double> angle_deg = std::nullopt);

/// I,J of `--ghost I,J` (two non-negative integers; the pair itself is checked by the tracer).
std::pair<int, int> parseGhostPair(const std::string& ghost);

/// Wavelengths (nm) from a comma-separated list, each checked; `option` names it in errors.
std::vector<double> parseWavelengthList(const std::string& text, const char* option);

/// Options of `lensim lens plot ghosts --image` (ghost_image.cpp).
struct GhostImageArgs {
  std::string output;       ///< -o: .exr unscaled; other image formats tone-mapped
  std::string exr;          ///< --exr: also the unscaled EXR here (with a tone-mapped -o)
  bool as_json = false;     ///< --json: print the per-path numbers
  double angle_deg = 0;     ///< --angle: the light's angle off axis (x-z plane)
  int size = 600;           ///< --size: raster width in pixels (height: 2/3 of it)
  int grid = 256;           ///< --grid: rays across the entrance (traceSpot's grid)
  std::string wavelengths;  ///< --wavelengths: nm list; empty: 450,550,650
  std::string ghost;        ///< --ghost I,J: that ghost only (with the direct image)
  double decades = 8;       ///< --decades: the tone map's range (log10)
  std::string coating;      ///< --coating: the lens-wide default coating instead of the file's
};

/// `lensim lens plot ghosts LENS --image -o OUT`: a point light's film image, direct and every
/// two-reflection ghost, from traced rays weighted by the coatings (docs/flare.md).
int runGhostImage(const LensArgs& args, const GhostImageArgs& ga);

/// `lensim lens ghosts LENS`: the two-reflection ghosts ranked by intensity.
void registerLensGhostsCommand(CLI::App& lens, Action& action);

}  // namespace lensim::cmd
