// Coatings and reflection losses in `lensim lens info`, and `lensim lens ghosts` (issue 31).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

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

/// `lensim lens ghosts LENS`: the two-reflection ghosts ranked by intensity.
void registerLensGhostsCommand(CLI::App& lens, Action& action);

}  // namespace lensim::cmd
