// `lensim lens plot mtf|mtf-focus|fans|field|psf`: the engineer's analyses (optics/mtf.h,
// fans.h, field_curves.h, psf.h) behind the `lens plot` command.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "lensim/optics/focus.h"

namespace CLI {
class App;
}

namespace lensim::cmd {

/// Options of the analyses, added to `lens plot`.
struct AnalysisArgs {
  std::string
      wavelengths;  ///< nm, optionally :weight, comma-separated; empty: the lens's wavelength
  double max_frequency = 0;     ///< mtf: cycles/mm (0: the diffraction cutoff)
  double frequency = 0;         ///< mtf-focus: cycles/mm (0: a quarter of the cutoff)
  double focus_range_mm = 0;    ///< mtf-focus: half-width of the film shift
  int pupil_cells = 0;          ///< 0: automatic
  bool geometric_only = false;  ///< mtf: skip the diffraction MTF
};

/// The kinds handled here.
bool isAnalysisKind(const std::string& kind);

/// Adds --wavelengths, --max-frequency, --frequency, --focus-range, --pupil-cells, --geometric.
void addAnalysisOptions(CLI::App* cmd, AnalysisArgs& args);

/// Computes the analysis `kind` for fields (fractions of the half-diagonal); fills the SVG text
/// and the JSON numbers.
void runAnalysis(const std::string& kind, const optics::FocusedLens& fl, double film_diagonal_mm,
                 const std::vector<double>& fields, const AnalysisArgs& args, std::string& svg,
                 nlohmann::json& j);

}  // namespace lensim::cmd
