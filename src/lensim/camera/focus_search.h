// The focus search of autofocus (as in the CS348B assignment): the zones of the image to focus
// on, the sharpness score of a zone's image, and the search for the film distance that maximises
// a score. What renders the zones at each film distance is render/autofocus_scene.h.
//
// Zone files (`af_zones`, `lensim autofocus --zones`): one zone per line, `left right top bottom`
// as fractions of the image width and height (y down). Lines that start with `#`, a space or a tab,
// and empty lines, are skipped (the assignment's reader did the same).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "lensim/util/error.h"

namespace lensim::camera {

/// A rectangle of the image, as fractions of its width and height (y down).
struct AfZone {
  double left = 0, right = 1, top = 0, bottom = 1;
  FileLoc loc;
};

/// Reads a zone file; throws lensim::Error (`path:line:col`) for malformed lines.
std::vector<AfZone> readAfZones(const std::string& path);
/// Parses zone-file text; `path` names it in messages.
std::vector<AfZone> parseAfZones(const std::string& text, const std::string& path);

/// A grey image of a zone, row-major.
struct ZoneImage {
  int width = 0, height = 0;
  std::vector<double> pixels;
};

/// Sharpness of an image: the mean squared response of a Laplacian after a light binomial
/// smoothing (which keeps the score from being dominated by Monte Carlo noise), divided by the
/// squared mean so that exposure does not matter, summed over the image and two 2x-reduced
/// copies (so that the score still rises toward focus when the image is far out of focus).
/// Larger is sharper.
double sharpness(const ZoneImage& image);

struct AutofocusOptions {
  /// The search range (>= 0): film distances, or object vergences for group focusing.
  double film_min_mm = 0, film_max_mm = 0;
  int coarse_steps = 16;                    ///< evenly spaced first look, at least
  /// Largest spacing of the first look (mm): about the depth of focus, so that the scan cannot
  /// step over the peak (0: no limit).
  double max_step_mm = 0;
  int refine_steps = 14;  ///< golden-section steps around the best of them
};

struct AutofocusResult {
  double film_distance_mm = 0;
  double score = 0;
  std::vector<std::pair<double, double>> evaluated;  ///< (film distance, score), in order
};

/// Maximises `score(film_distance_mm)` over the range: a coarse scan, then golden-section search
/// in the bracket around the best sample. The score should be computed with the same random
/// numbers for every film distance (a fixed seed), so that noise does not move the optimum.
AutofocusResult autofocus(const std::function<double(double)>& score,
                          const AutofocusOptions& options);

}  // namespace lensim::camera
