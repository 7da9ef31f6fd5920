// The film: accumulates filtered spectral samples as RGB in the output colour space (linear
// sRGB) through the CIE 1931 matching functions (pbrt-v4's "rgb" film with the "cie1931"
// sensor), over the pixel bounds being rendered.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/spectrum.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::render {

/// A half-open rectangle of pixels [x0, x1) x [y0, y1) in the full image's raster.
struct PixelBounds {
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
  long long area() const { return (long long)width() * height(); }
  bool operator==(const PixelBounds&) const = default;
};

/// Chromaticity (x, y) of CIE daylight of correlated colour temperature T (the CIE daylight
/// locus, 4000-25000 K); below 4000 K, of a blackbody at T.
Vec2 daylightChromaticity(double temperature_k);

/// The pixel bounds of a crop window (fractions of the full image, pbrt's rounding: ceil).
PixelBounds cropWindowBounds(int x_res, int y_res, const std::array<double, 4>& crop);

class Film {
 public:
  /// A film over `bounds` for the scene's film settings (exposure from the camera's shutter and
  /// the film's ISO, pbrt-v3 "scale", maxcomponentvalue, whitebalance).
  Film(const scene::Scene& scene, PixelBounds bounds);
  const PixelBounds& bounds() const { return bounds_; }
  /// Adds radiance L (carried by `lambda`) to pixel (x, y) (full-image raster) with filter
  /// weight w. Not thread-safe for the same pixel; different pixels may be added concurrently.
  void addSample(int x, int y, const SampledSpectrum& L, const SampledWavelengths& lambda,
                 double w);
  /// The RGB of a sample as the film would record it (before the filter weight).
  Vec3 toRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const;
  /// The image so far: channels R, G, B, bounds-sized.
  io::Image image() const;

 private:
  struct Pixel {
    double rgb[3] = {0, 0, 0};
    double weight = 0;
  };
  PixelBounds bounds_;
  std::vector<Pixel> pixels_;
  double imaging_ratio_ = 1, max_component_ = 1e300;
  bool white_balance_ = false;
  std::array<double, 9> xyz_balance_{};  ///< von Kries (Bradford) adaptation, row-major
};

}  // namespace lensim::render
