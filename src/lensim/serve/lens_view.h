// What the explorer shows of one lens at one aperture and focus: first-order data (the numbers
// `lensim lens info --json` prints), the cross-section with traced bundles (optics/diagram) and
// the aberration plots (optics/plots), as JSON and SVG.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/configurations.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/tilt_shift.h"

namespace lensim::serve {

/// A lens set up as a request asks. Either an f-number or a stop diameter (or neither: wide open).
struct LensSettings {
  std::string path;                            ///< resolved lens file
  std::optional<double> f_number;              ///< wanted f-number at infinity focus
  std::optional<double> aperture_diameter_mm;  ///< wanted stop diameter
  std::optional<double> focus_distance_m;  ///< from the film; infinity allowed; none: the file's
  double film_diagonal_mm = 35;
  std::optional<int> configuration;          ///< 1-based configuration of a zoom lens
  std::optional<double> zoom_focal_length_mm;  ///< a focal length between the configurations
  optics::TiltShift tilt_shift;                ///< the lens against the film
};

/// The focused lens, and the stop diameter chosen for the f-number. The f-number sets the stop
/// diameter in proportion (the entrance pupil scales with the stop paraxially), clamped to the
/// file's stop; the f-number reported is then computed from that lens, as `lens info` does.
struct SetUpLens {
  optics::FocusedLens lens;
  double stop_diameter_mm = 0;      ///< the aperture diameter passed to the lens
  double max_stop_diameter_mm = 0;  ///< the file's stop
  double min_f_number = 0;          ///< wide open, at infinity
  int configuration_count = 1;      ///< the file's configurations
  std::optional<int> configuration;           ///< the configuration shown, if one was asked
  std::optional<optics::ZoomSetting> zoom;    ///< the zoom position, for a requested focal length
  optics::TiltShift tilt_shift;
  /// The extreme configurations' EFLs (the zoom range), for lenses with configurations.
  double zoom_min_efl_mm = 0, zoom_max_efl_mm = 0;
};

/// Throws lensim::Error (a lens that cannot be read or focused as asked).
SetUpLens setUpLens(const LensSettings& settings);

/// First-order data with the key names of `lensim lens info --json`, plus the stop diameter
/// chosen, the f-number range and the closest focus; "zoom" (configurations, the EFL range, the
/// requested and achieved EFL) and "tilt_shift" (with a tilt: the hinge distance and the plane of
/// focus, optics::scheimpflug) as `lens info --tilt --shift --json` names them.
nlohmann::json firstOrderJson(const SetUpLens& s, double film_diagonal_mm);

/// The cross-section with bundles from the film (`lensim lens draw`), as an SVG document.
std::string diagramSvg(const SetUpLens& s, double film_diagonal_mm, int rays, bool from_scene);

/// A plot the page shows: a name for the API (`/api/plot?kind=NAME`), a title, and the optics
/// function that draws it. New plots (e.g. chromatic focal shift) are one more row of plotKinds().
struct PlotKind {
  std::string name;
  std::string title;
  std::function<std::string(const optics::FocusedLens&, double film_diagonal_mm)> svg;
};

/// The plots, in the order the page shows them.
const std::vector<PlotKind>& plotKinds();
const PlotKind* findPlotKind(const std::string& name);

}  // namespace lensim::serve
