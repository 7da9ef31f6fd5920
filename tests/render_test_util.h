// Helpers shared by the renderer tests: render scene text, block statistics of images.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/renderer.h"
#include "scene_test_util.h"

namespace lensim::testutil {

/// Renders scene text (written as test.pbrt in a fresh directory so relative paths work).
inline render::RenderResult renderText(const std::string& text,
                                       const render::RenderOptions& options = {}) {
  scene::Scene s = buildText(text, "render-test.pbrt");
  if (s.hasErrors()) throw Error(formatDiagnostics(s.diagnostics));
  return render::render(s, options);
}

/// Mean of channel c over the pixel rectangle [x0, x1) x [y0, y1).
inline double regionMean(const io::Image& im, int c, int x0, int x1, int y0, int y1) {
  double s = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) s += im.at(x, y, c);
  return s / double((x1 - x0) * (y1 - y0));
}

/// Mean of channel c over a pixel rectangle and the standard error of that mean (from the
/// pixels' spread: each pixel an independent estimate).
struct RegionStats {
  double mean = 0, sem = 0;
};
inline RegionStats regionStats(const io::Image& im, int c, int x0, int x1, int y0, int y1) {
  double s = 0, s2 = 0;
  int n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const double v = im.at(x, y, c);
      s += v, s2 += v * v, ++n;
    }
  RegionStats r;
  r.mean = s / n;
  r.sem = std::sqrt(std::max(0.0, s2 / n - r.mean * r.mean) / (n - 1));
  return r;
}

/// Luminance (Rec. 709 weights) of pixel (x, y) of an RGB image.
inline double luminanceAt(const io::Image& im, int x, int y) {
  return 0.2126 * im.at(x, y, 0) + 0.7152 * im.at(x, y, 1) + 0.0722 * im.at(x, y, 2);
}

}  // namespace lensim::testutil
