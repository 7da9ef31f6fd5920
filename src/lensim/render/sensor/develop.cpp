// The raw development pipeline (develop.h).
#include "lensim/render/sensor/develop.h"

#include <algorithm>
#include <cmath>

#include "lensim/render/film/pixel_sensor.h"
#include "lensim/render/sensor/cfa_interpolate.h"

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

// Luminance from the W pixels (docs/sensor.md, "lensim develop"). A W pixel's response is
// proportional to R + G + B (Film "raw" writes W = R + G + B, AsShotNeutral's W entry the sum of
// the others), so W, scaled by (n_R + n_G + n_B) / n_W, is a further measurement of R + G + B
// (camera values before white balance). The interpolated R, G, B and that measurement are
// combined by generalised least squares (the linear minimum-variance update of (R, G, B) by an
// observation of their sum): each channel moves by v_c / (v_R + v_G + v_B + v_W) times the
// difference W - (R + G + B), with the variances v from a shot-noise model (a pixel's variance
// proportional to its mean, the same gain for every channel) and the interpolation's weights.
// For given weights this is unbiased (the weights come from the noisy values themselves, a
// small second-order bias: docs/sensor.md) and lowers the variance of every channel and of any
// colour made of them. A
// W estimate that took in a W pixel within 0.1 % of the image's brightest W pixel is taken as
// clipped (a W pixel, collecting all three channels' light, saturates first), and there the
// colour pixels alone are used. `t` and `tw` are white balanced (divided by n and n_w); `v`
// receives the white-balanced R, G and B.
void fuseW(const TentMean (&t)[3], const TentMean& tw, const std::array<double, 3>& n, double n_w,
           double w_top, double (&v)[3]) {
  if (tw.top >= 0.999 * w_top) return;
  const double floor = 1e-9;  // keeps the weights finite in the dark
  double y = 0, var[3], var_sum = 0;
  for (int c = 0; c < 3; ++c) {
    const double u = t[c].value * n[size_t(c)];
    y += u;
    var[c] = floor + t[c].variance_factor * std::max(u, 0.0);
    var_sum += var[c];
  }
  const double s = (n[0] + n[1] + n[2]) / n_w;  // W's scale to R + G + B
  const double uw = tw.value * n_w;
  const double var_w = floor + tw.variance_factor * std::max(uw, 0.0) * s * s;
  const double innovation = uw * s - y;
  for (int c = 0; c < 3; ++c)
    v[c] += var[c] / (var_sum + var_w) * innovation / n[size_t(c)];
}

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

io::Image developRaw(const io::DngImage& raw, double exposure_ev, WPixels w_pixels) {
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
  const bool bayer = isBayerTile(cw, ch, p);
  if (!bayer) {
    // Another pattern: each missing channel is the tent-weighted mean of that channel's pixels
    // around (normalised convolution), over a window that holds at least one of them. W pixels
    // (no colour filter) hold no R, G or B value of their own: all three come from around.
    const int r0 = tentRadius(cw, ch);
    auto mean = [&](int c, int x, int y) { return tentMean(m, w, h, channel, c, x, y, r0); };
    const bool fuse = w_pixels == WPixels::kLuminance && raw.w_neutral > 0 &&
                      std::find(p.begin(), p.end(), uint8_t(kWhite)) != p.end();
    double w_top = 0;  // the brightest W pixel (white balanced)
    if (fuse)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          if (channel(x, y) == kWhite) w_top = std::max(w_top, m[size_t(y) * size_t(w) + size_t(x)]);
    const std::array<double, 3> n = {raw.as_shot_neutral[0] > 0 ? raw.as_shot_neutral[0] : 1,
                                     raw.as_shot_neutral[1] > 0 ? raw.as_shot_neutral[1] : 1,
                                     raw.as_shot_neutral[2] > 0 ? raw.as_shot_neutral[2] : 1};
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int own = channel(x, y);
        const double here = m[size_t(y) * size_t(w) + size_t(x)];
        TentMean t[3];
        for (int c = 0; c < 3; ++c) t[c] = c == own ? TentMean{here, 1, here} : mean(c, x, y);
        double v[3] = {t[0].value, t[1].value, t[2].value};
        if (fuse) {
          const TentMean tw = own == kWhite ? TentMean{here, 1, here} : mean(kWhite, x, y);
          fuseW(t, tw, n, raw.w_neutral, w_top, v);
        }
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
