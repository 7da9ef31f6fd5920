// Line and scatter charts drawn into an svg::Document: axes with ticks, labels and units, a
// legend and a title. Used by `lensim lens plot`.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lensim/util/svg.h"

namespace lensim::plot {

/// How a series is drawn.
enum class Style {
  Line,
  Dashed,
  Markers,
  Bars,  ///< a bar per point, from y = 0 (clamped to the y range) to the point
};

/// One data series: points in data units.
struct Series {
  std::string name;  ///< legend entry; empty: not in the legend
  std::string color = "#1f77b4";
  Style style = Style::Line;
  std::vector<std::pair<double, double>> points;
  double marker_radius = 1.6;
  double bar_width = 0.8;  ///< Bars: width in x data units
};

/// A chart: axes, series, labels. Ranges are found from the data unless given.
struct Chart {
  std::string title;
  std::string x_label, y_label;  ///< with units, e.g. "field angle (deg)"
  bool x_log = false;            ///< logarithmic x axis (data must be > 0)
  bool equal_aspect = false;     ///< same scale on both axes (spot diagrams)
  bool include_zero_y = false;   ///< extend the y range to include 0
  std::optional<std::pair<double, double>> x_range, y_range;
  std::vector<Series> series;
  std::vector<std::string> notes;  ///< lines of text in the top-left corner of the plot area

  /// Draws into the rectangle (x, y, w, h) of the document (pixels).
  void render(svg::Document& doc, double x, double y, double w, double h) const;
};

/// "Nice" tick positions (1, 2, 5 x 10^k steps) covering [lo, hi].
std::vector<double> niceTicks(double lo, double hi, int target_count = 6);

/// The colour of series number i in a fixed, colour-blind-friendly palette.
const char* paletteColor(int i);

}  // namespace lensim::plot
