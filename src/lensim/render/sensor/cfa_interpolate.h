// Interpolation of one colour of a CFA mosaic (lensim develop's demosaic for tiles other than
// Bayer, and the Bayer remosaic of a DNG): the tent-weighted mean of that colour's pixels about a
// pixel (normalised convolution), weights (r + 1 - |dx|)(r + 1 - |dy|) over the (2r + 1)^2 window
// clipped to the image, r doubled until the window holds one of them.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace lensim::render {

/// Whether a tile of w x h colour codes (0 red, 1 green, 2 blue), row-major, is a 2x2 Bayer one
/// (RGGB, BGGR, GRBG, GBRG: the greens on a diagonal).
inline bool isBayerTile(int w, int h, const std::vector<uint8_t>& c) {
  return w == 2 && h == 2 && c.size() == 4 &&
         ((c[0] == 1 && c[3] == 1 && c[1] + c[2] == 2 && c[1] != c[2]) ||
          (c[1] == 1 && c[2] == 1 && c[0] + c[3] == 2 && c[0] != c[3]));
}

/// A colour's tent-weighted mean about a pixel: its value, the factor sum(k^2) / sum(k)^2 by which
/// the mean's variance is below one pixel's (for independent pixels of equal variance), and the
/// largest pixel value it took in.
struct TentMean {
  double value = 0, variance_factor = 1, top = 0;
};

/// The first window radius for a tile of tile_w x tile_h: half its larger side, rounded up.
inline int tentRadius(int tile_w, int tile_h) { return std::max(1, (std::max(tile_w, tile_h) + 1) / 2); }

/// The mean of colour `c` about (x, y) of the w x h mosaic `m` (row-major), whose pixel (xx, yy)
/// has the colour channel(xx, yy); value 0 if the image has no pixel of colour c.
template <class Channel>
TentMean tentMean(const std::vector<double>& m, int w, int h, const Channel& channel, int c,
                  int x, int y, int r0) {
  for (int r = r0;; r *= 2) {
    double s = 0, sw = 0, sw2 = 0, top = 0;
    for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy)
      for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx)
        if (channel(xx, yy) == c) {
          const double k = double(r + 1 - std::abs(xx - x)) * double(r + 1 - std::abs(yy - y));
          const double v = m[size_t(yy) * size_t(w) + size_t(xx)];
          s += k * v;
          sw += k;
          sw2 += k * k;
          top = std::max(top, v);
        }
    if (sw > 0) return {s / sw, sw2 / (sw * sw), top};
    if (r > std::max(w, h)) return {};
  }
}

}  // namespace lensim::render
