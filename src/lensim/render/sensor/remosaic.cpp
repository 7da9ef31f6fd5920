// The Bayer remosaic of a raw mosaic (remosaic.h).
#include "lensim/render/sensor/remosaic.h"

#include <algorithm>
#include <cmath>

#include "lensim/render/sensor/cfa_interpolate.h"

namespace lensim::render {

std::vector<uint16_t> remosaicToBayer(const std::vector<uint16_t>& dn, int w, int h,
                                      const scene::CfaPattern& cfa, int x0, int y0, int black,
                                      int white) {
  std::vector<double> m(dn.size());
  for (size_t i = 0; i < dn.size(); ++i) m[i] = double(dn[i]) - black;
  auto channel = [&](int x, int y) { return cfa.channel(x0 + x, y0 + y); };
  const int r0 = tentRadius(cfa.width, cfa.height);
  std::vector<uint16_t> out(dn.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      const int want = bayerChannel(x0 + x, y0 + y);
      if (channel(x, y) == want) {
        out[i] = dn[i];
        continue;
      }
      const double v = tentMean(m, w, h, channel, want, x, y, r0).value + black;
      out[i] = uint16_t(std::clamp(std::lround(v), 0L, long(white)));
    }
  return out;
}

}  // namespace lensim::render
