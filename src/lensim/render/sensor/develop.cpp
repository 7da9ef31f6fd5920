// The raw development pipeline (develop.h).
#include "lensim/render/sensor/develop.h"

#include <algorithm>
#include <cmath>

#include "lensim/render/film/pixel_sensor.h"

namespace lensim::render {

namespace {

constexpr int kWhite = 6;  // DNG CFAPattern code of a white (W) pixel

int mirror(int i, int n) {
  // Reflection about the first and last pixel keeps a pixel's CFA parity.
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * (n - 1) - i;
  return i;
}

// Malvar-He-Cutler kernels (x8), indexed [dy + 2][dx + 2].
constexpr double kGAtRB[5][5] = {{0, 0, -1, 0, 0}, {0, 0, 2, 0, 0}, {-1, 2, 4, 2, -1},
                                 {0, 0, 2, 0, 0},   {0, 0, -1, 0, 0}};
// At a green pixel: the colour of its horizontal neighbours (kAtGRow), of its vertical ones
// (kAtGCol).
constexpr double kAtGRow[5][5] = {{0, 0, 0.5, 0, 0}, {0, -1, 0, -1, 0}, {-1, 4, 5, 4, -1},
                                  {0, -1, 0, -1, 0}, {0, 0, 0.5, 0, 0}};
constexpr double kAtGCol[5][5] = {{0, 0, -1, 0, 0}, {0, -1, 4, -1, 0}, {0.5, 0, 5, 0, 0.5},
                                  {0, -1, 4, -1, 0}, {0, 0, -1, 0, 0}};
// At a red pixel, blue (and at a blue pixel, red).
constexpr double kRBAtBR[5][5] = {{0, 0, -1.5, 0, 0}, {0, 2, 0, 2, 0}, {-1.5, 0, 6, 0, -1.5},
                                  {0, 2, 0, 2, 0},    {0, 0, -1.5, 0, 0}};

}  // namespace

Mat3d srgbFromCamera(const std::array<double, 9>& color_matrix) {
  // dcraw's cam_xyz_coeff: camera from sRGB, rows normalised to sum 1, inverted.
  const Mat3d xyz_from_srgb = {0.4124564, 0.3575761, 0.1804375, 0.2126729, 0.7151522,
                               0.0721750, 0.0193339, 0.1191920, 0.9503041};
  Mat3d cam_rgb = mulMat3(color_matrix, xyz_from_srgb);
  for (int r = 0; r < 3; ++r) {
    double s = 0;
    for (int c = 0; c < 3; ++c) s += cam_rgb[size_t(3 * r + c)];
    for (int c = 0; c < 3; ++c) cam_rgb[size_t(3 * r + c)] /= s != 0 ? s : 1;
  }
  return invertMat3(cam_rgb);
}

io::Image developRaw(const io::DngImage& raw, double exposure_ev) {
  const int w = raw.width, h = raw.height;
  const double black = raw.black_level, range = double(raw.white_level) - black;
  const int cw = raw.cfa_width, ch = raw.cfa_height;
  auto channel = [&](int x, int y) {
    return raw.mono ? 0 : int(raw.cfa[size_t((y % ch) * cw + x % cw)]);
  };
  // 1-2: linear, white-balanced mosaic.
  std::vector<double> m(size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      double v = (double(raw.data[i]) - black) / range;
      if (!raw.mono) {
        const int c = channel(x, y);
        const double n = c == kWhite ? raw.w_neutral : raw.as_shot_neutral[size_t(c)];
        v /= n > 0 ? n : 1;
      }
      m[i] = v;
    }
  const double gain = std::exp2(exposure_ev);
  io::Image out(w, h, {"R", "G", "B"});
  if (raw.mono) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          out.at(x, y, c) = float(std::max(0.0, m[size_t(y) * size_t(w) + size_t(x)] * gain));
    return out;
  }
  // 4: camera to sRGB.
  const Mat3d rgb_cam = srgbFromCamera(raw.color_matrix2);
  // 3: demosaic.
  auto store = [&](int x, int y, const double (&v)[3]) {
    const Vec3 rgb = mulMat3(rgb_cam, Vec3{v[0], v[1], v[2]});
    out.at(x, y, 0) = float(std::max(0.0, rgb.x * gain));
    out.at(x, y, 1) = float(std::max(0.0, rgb.y * gain));
    out.at(x, y, 2) = float(std::max(0.0, rgb.z * gain));
  };
  const auto& p = raw.cfa;
  const bool bayer = cw == 2 && ch == 2 &&
                     ((p[0] == 1 && p[3] == 1 && p[1] + p[2] == 2 && p[1] != p[2]) ||
                      (p[1] == 1 && p[2] == 1 && p[0] + p[3] == 2 && p[0] != p[3]));
  if (!bayer) {
    // Another pattern: each missing channel is the tent-weighted mean of that channel's pixels
    // around (normalised convolution), over a window that holds at least one of them. W pixels
    // (no colour filter) hold no R, G or B value of their own: all three come from around.
    const int r0 = std::max(1, (std::max(cw, ch) + 1) / 2);
    auto mean = [&](int c, int x, int y) {
      for (int r = r0;; r *= 2) {
        double s = 0, sw = 0;
        for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy)
          for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx)
            if (channel(xx, yy) == c) {
              const double k = double(r + 1 - std::abs(xx - x)) * double(r + 1 - std::abs(yy - y));
              s += k * m[size_t(yy) * size_t(w) + size_t(xx)];
              sw += k;
            }
        if (sw > 0 || r > std::max(w, h)) return sw > 0 ? s / sw : 0.0;
      }
    };
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int own = channel(x, y);
        double v[3];
        for (int c = 0; c < 3; ++c)
          v[c] = c == own ? m[size_t(y) * size_t(w) + size_t(x)] : mean(c, x, y);
        store(x, y, v);
      }
    return out;
  }
  auto conv = [&](const double (&k)[5][5], int x, int y) {
    double s = 0;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx)
        if (k[dy + 2][dx + 2] != 0)
          s += k[dy + 2][dx + 2] *
               m[size_t(mirror(y + dy, h)) * size_t(w) + size_t(mirror(x + dx, w))];
    return s / 8;
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int c = channel(x, y);
      double v[3];
      v[c] = m[size_t(y) * size_t(w) + size_t(x)];
      if (c == 1) {
        const int hc = channel(mirror(x + 1, w), y), vc = 2 - hc;
        v[hc] = conv(kAtGRow, x, y);
        v[vc] = conv(kAtGCol, x, y);
      } else {
        v[1] = conv(kGAtRB, x, y);
        v[2 - c] = conv(kRBAtBR, x, y);
      }
      store(x, y, v);
    }
  return out;
}

}  // namespace lensim::render
