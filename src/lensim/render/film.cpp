// Film accumulation. pbrt-v4's RGBFilm: the sensor RGB of a sample (for the cie1931 sensor,
// XYZ times the imaging ratio = exposure time x ISO / 100) is scaled down to maxcomponentvalue,
// converted to the output colour space and added with its filter weight; a pixel is the
// weighted average.
#include "lensim/render/film.h"

#include <algorithm>
#include <cmath>

#include "lensim/scene/builder.h"

namespace lensim::render {

PixelBounds cropWindowBounds(int x_res, int y_res, const std::array<double, 4>& c) {
  PixelBounds b;
  b.x0 = int(std::ceil(x_res * std::clamp(std::min(c[0], c[1]), 0.0, 1.0)));
  b.x1 = int(std::ceil(x_res * std::clamp(std::max(c[0], c[1]), 0.0, 1.0)));
  b.y0 = int(std::ceil(y_res * std::clamp(std::min(c[2], c[3]), 0.0, 1.0)));
  b.y1 = int(std::ceil(y_res * std::clamp(std::max(c[2], c[3]), 0.0, 1.0)));
  return b;
}

Film::Film(const scene::Scene& scene, PixelBounds bounds)
    : bounds_(bounds), pixels_(size_t(std::max(0LL, bounds.area()))) {
  const double exposure = scene.camera.shutter_close - scene.camera.shutter_open;
  imaging_ratio_ = (exposure > 0 ? exposure : 1) * scene.film.iso / 100 * scene.film.scale;
  max_component_ = scene.film.max_component_value;
}

Vec3 Film::toRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const {
  Vec3 xyz = sampledToXyz(L, lambda) * imaging_ratio_;
  Vec3 rgb = RGBColorSpace::sRGB().toRgb(xyz);
  const double m = std::max({rgb.x, rgb.y, rgb.z});
  if (m > max_component_) rgb = rgb * (max_component_ / m);
  return rgb;
}

void Film::addSample(int x, int y, const SampledSpectrum& L, const SampledWavelengths& lambda,
                     double w) {
  const Vec3 rgb = toRgb(L, lambda);
  Pixel& p = pixels_[size_t(y - bounds_.y0) * size_t(bounds_.width()) + size_t(x - bounds_.x0)];
  p.rgb[0] += w * rgb.x;
  p.rgb[1] += w * rgb.y;
  p.rgb[2] += w * rgb.z;
  p.weight += w;
}

io::Image Film::image() const {
  io::Image im(bounds_.width(), bounds_.height(), {"R", "G", "B"});
  for (int y = 0; y < bounds_.height(); ++y)
    for (int x = 0; x < bounds_.width(); ++x) {
      const Pixel& p = pixels_[size_t(y) * size_t(bounds_.width()) + size_t(x)];
      for (int c = 0; c < 3; ++c)
        im.at(x, y, c) = p.weight != 0 ? float(p.rgb[c] / p.weight) : 0.0f;
    }
  return im;
}

}  // namespace lensim::render
