// Shapes of the aperture stop: round, regular polygons (blades), pbrt-v4's named shapes and
// images.
//
// Normalisation rule: every shape transmits as much light as the round stop of the set diameter.
// In coordinates where that round stop is the unit disc, the integral of the transmission over
// the plane is pi. A shape therefore reaches beyond the unit disc (a pentagon's corners lie at
// 1.149), so the physical stop is opened to the shape's extent and the shape decides. At a given
// f-number the exposure does not depend on the shape; the bokeh does.
#pragma once

#include <string>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::camera {

class ApertureShape {
 public:
  /// The round stop.
  static ApertureShape round();
  /// A regular polygon of `blades` sides, one corner at `rotation_deg` from +x.
  static ApertureShape polygon(int blades, double rotation_deg);
  /// pbrt-v4's built-in shapes: "gaussian", "square", "pentagon", "star".
  static ApertureShape named(const std::string& name);
  /// Whether `name` is one of the built-in shapes (otherwise it names an image file).
  static bool isNamed(const std::string& name);
  /// A transmission image (grey, or the mean of its channels), centred on the axis, filling the
  /// square around the shape's extent. Throws lensim::Error if it cannot be read or is black.
  static ApertureShape image(const std::string& path);

  /// Transmission in [0, 1] at a point in units of the set stop radius.
  double transmission(Vec2 p) const;
  /// The largest radius (units of the set stop radius) where the transmission is not zero.
  double extent() const { return extent_; }
  bool isRound() const { return kind_ == Kind::Round; }
  std::string describe() const;

 private:
  enum class Kind { Round, Polygon, Star, Gaussian, Image };
  Kind kind_ = Kind::Round;
  int sides_ = 0;
  double rotation_rad_ = 0;
  double outer_ = 1, inner_ = 1;  // polygon circumradius; star outer and inner radii
  double sigma_ = 0.5;            // gaussian, in units of the extent
  double extent_ = 1;
  int width_ = 0, height_ = 0;  // image
  std::vector<float> texels_;
  std::string name_;
};

}  // namespace lensim::camera
