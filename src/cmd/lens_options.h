// Command-line options shared by the `lensim lens ...` commands.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/focus.h"
#include "lensim/util/vec.h"

namespace CLI {
class App;
}

namespace lensim::cmd {

/// The lens and how to set it up, as given on the command line.
struct LensArgs {
  std::string lens_path;
  std::optional<double> aperture_diameter_mm;
  std::string focus_distance;  ///< metres or "inf"; empty when not given
  std::optional<double> film_distance_mm;
  double film_diagonal_mm = 35.0;  ///< pbrt-v4's default film diagonal
  optics::FocusMethod focus_method = optics::FocusMethod::Thick;
  /// `--wavelength` (nm): the wavelength the lens is analysed at (focus stays solved at the
  /// primary wavelength); default the file's primary wavelength, else the d line.
  std::optional<double> wavelength_nm;
  /// `--glass-match`: each element gets the nearest catalogue glass.
  bool glass_match = false;
  /// `--config N`: configuration N (1-based) of a multi-configuration (zoom) lens.
  std::optional<int> configuration;
  /// `--focal-length MM`: a zoom lens set to this paraxial EFL (configurations interpolated).
  std::optional<double> zoom_focal_length_mm;
  /// `lens info --tilt X,Y` (degrees) and `--shift X,Y` (mm): the lens tilted and shifted
  /// against the film (optics/tilt_shift.h); empty when not given.
  std::string tilt, shift;

  /// `--glass-catalog FILE` (repeatable): catalogues searched before the built-in ones.
  std::vector<std::string> glass_catalogs;
  /// `--model-glass`: a glass in no catalogue becomes the model glass of its n_d and V_d.
  bool model_glass = false;
  /// `--glass-extrapolate`: a wavelength outside a glass formula's range is used (a warning).
  bool glass_extrapolate = false;
  /// `lens info --field X,Y` (repeatable): fields of a tilted or decentred lens (degrees, or mm
  /// for a finite object).
  std::vector<std::string> fields;
};

/// Applies --config / --focal-length to a prescription read from args.lens_path (logs the zoom
/// setting found for --focal-length).
optics::LensPrescription applyConfigurationArgs(const LensArgs& args,
                                                optics::LensPrescription prescription);

/// Adds --aperture-diameter, --focus-distance, --film-distance, --film-diagonal and
/// --focus-method (everything but the LENS argument).
void addLensSetupOptions(CLI::App* cmd, LensArgs& args);

/// Adds LENS and --aperture-diameter, --focus-distance, --film-distance, --film-diagonal,
/// --focus-method to a subcommand.
void addLensOptions(CLI::App* cmd, LensArgs& args);

/// Sets the process's glass choices from --glass-catalog, --model-glass, --glass-extrapolate.
void applyGlassOptions(const LensArgs& args);

/// Reads the lens file and focuses it as the arguments say.
optics::FocusedLens setUpLens(const LensArgs& args);

/// What setUpLens throws when the lens was read but cannot be set up (focusLens failed: an
/// afocal lens, no real ray through it, a film inside the lens, a focus it cannot reach).
class LensSetupError : public Error {
 public:
  using Error::Error;
};

/// Parses "X,Y" (two numbers); throws lensim::Error naming the option otherwise.
Vec2 parsePair(const std::string& text, const std::string& option);

/// Parses a distance in metres, accepting "inf"/"infinity".
double parseDistance_m(const std::string& text, const std::string& option);

}  // namespace lensim::cmd
