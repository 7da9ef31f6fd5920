// Where a camera's importance accepts film points: the image enlarged by the pixel filter's
// radius (pbrt-v4's Film::SampleBounds), since a path tracer's samples for the edge pixels reach
// that far and a light tracer's splats there must reach those pixels too.
#pragma once

#include <cmath>

#include "lensim/scene/description.h"
#include "lensim/util/vec.h"

namespace lensim::camera {

struct FilmSampleBounds {
  double x0 = 0, x1 = 0, y0 = 0, y1 = 0;  ///< raster (pixels, full image)
  FilmSampleBounds() = default;
  explicit FilmSampleBounds(const scene::Scene& scene)
      : x0(-scene.filter.x_radius + 0.5),
        x1(scene.film.x_resolution + scene.filter.x_radius - 0.5),
        y0(-scene.filter.y_radius + 0.5),
        y1(scene.film.y_resolution + scene.filter.y_radius - 0.5) {}
  bool inside(Vec2 p) const { return p.x >= x0 && p.x < x1 && p.y >= y0 && p.y < y1; }
};

/// The film's half width and half height (mm) from its diagonal and the image's aspect ratio.
inline Vec2 filmHalfExtent_mm(double diagonal_mm, int x_resolution, int y_resolution) {
  const double aspect = static_cast<double>(y_resolution) / x_resolution;
  const double width = diagonal_mm / std::sqrt(1 + aspect * aspect);
  return {width / 2, aspect * width / 2};
}

}  // namespace lensim::camera
