// Film accumulation. pbrt-v4's RGBFilm: the sensor RGB of a sample (for the cie1931 sensor,
// XYZ times the imaging ratio = exposure time x ISO / 100) is scaled down to maxcomponentvalue,
// converted to the output colour space and added with its filter weight; a pixel is the
// weighted average.
#include "lensim/render/film/film.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <fmt/format.h>

#include "lensim/render/film/gbuffer.h"
#include "lensim/render/film/pixel_sensor.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/render/sensor/sensor_model.h"
#include "lensim/sampling/filter.h"
#include "lensim/scene/description.h"
#include "lensim/scene/sensor_settings.h"
#include "lensim/util/check.h"

namespace lensim::render {

using namespace lensim::sampling;

PixelBounds cropWindowBounds(int x_res, int y_res, const std::array<double, 4>& c) {
  PixelBounds b;
  b.x0 = int(std::ceil(x_res * std::clamp(std::min(c[0], c[1]), 0.0, 1.0)));
  b.x1 = int(std::ceil(x_res * std::clamp(std::max(c[0], c[1]), 0.0, 1.0)));
  b.y0 = int(std::ceil(y_res * std::clamp(std::min(c[2], c[3]), 0.0, 1.0)));
  b.y1 = int(std::ceil(y_res * std::clamp(std::max(c[2], c[3]), 0.0, 1.0)));
  return b;
}

Vec2 daylightChromaticity(double t) {
  if (t < 4000) {
    const Vec3 xyz = spectrumToXyz(BlackbodySpectrum(t));
    const double sum = xyz.x + xyz.y + xyz.z;
    return {xyz.x / sum, xyz.y / sum};
  }
  // CIE 15:2004, eq. 3.3-3.4 (daylight locus).
  const double t2 = t * t, t3 = t2 * t;
  const double x = t <= 7000 ? -4.6070e9 / t3 + 2.9678e6 / t2 + 0.09911e3 / t + 0.244063
                             : -2.0064e9 / t3 + 1.9018e6 / t2 + 0.24748e3 / t + 0.237040;
  return {x, -3.0 * x * x + 2.870 * x - 0.275};
}

Film::Film(const scene::Scene& scene, PixelBounds bounds)
    : bounds_(bounds), pixels_(size_t(std::max(0LL, bounds.area()))) {
  const double exposure = scene.camera.shutter_close - scene.camera.shutter_open;
  // pbrt-v4's imaging ratio (film.cpp, PixelSensor::Create), times pbrt-v3's film "scale". A
  // camera with no shutter interval (shutteropen == shutterclose) records as if open 1 s.
  const double imaging_ratio =
      scene::sensorImagingRatio(exposure > 0 ? exposure : 1, scene.film.iso) * scene.film.scale;
  max_component_ = scene.film.max_component_value;
  // pbrt-v4's PixelSensor::Create: "cie1931" (XYZ; white balanced only with "whitebalance") or a
  // named camera (balanced for "whitebalance", 6500 K by default).
  sensor_ =
      std::make_shared<PixelSensor>(scene.film.sensor, scene.film.white_balance_k, imaging_ratio);
  if (scene.film.type == "spectral") {
    n_buckets_ = scene.film.spectral_buckets;
    lambda_min_ = scene.film.lambda_min_nm;
    lambda_max_ = scene.film.lambda_max_nm;
    bucket_sums_.assign(pixels_.size() * size_t(n_buckets_), 0.0);
  }
  if (scene.film.type == "gbuffer") gbuf_.assign(pixels_.size(), GBufferPixel{});
  if (scene.film.type == "raw") {
    raw_ = std::make_shared<SensorModel>(rawSensorConfig(scene), scene.film.loc);
    raw_metadata_ = rawMetadata(scene, raw_->config());
  }
}

Vec3 Film::recorded(const Vec3& sensor_rgb, const SampledSpectrum& L,
                    const SampledWavelengths& lambda) const {
  if (!raw_) return outputRgb(sensor_rgb);
  const std::array<double, 3> e = raw_->expectedElectrons(L, lambda);
  return {e[0], e[1], e[2]};
}

Vec3 Film::toSensorRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const {
  // pbrt-v4's RGBFilm::AddSample: the sensor RGB, clamped to "maxcomponentvalue" there.
  Vec3 s = sensor_->toSensorRgb(L, lambda);
  const double m = std::max({s.x, s.y, s.z});
  if (m > max_component_) s = s * (max_component_ / m);
  return s;
}

Vec3 Film::outputRgb(const Vec3& sensor_rgb) const {
  return RGBColorSpace::sRGB().toRgb(mulMat3(sensor_->xyzFromSensorRgb(), sensor_rgb));
}

Vec3 Film::toRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const {
  return outputRgb(toSensorRgb(L, lambda));
}

Int128 Film::toFixed(double v) {
  constexpr double kMax = 0x1p100;  // 2^52 in real units
  const double f = std::rint(v * kFixedScale);
  if (std::abs(f) < 0x1p62) return Int128(int64_t(f));  // the common case: one instruction
  if (!(f == f)) return 0;
  return Int128(std::clamp(f, -kMax, kMax));
}

std::array<float, 3> Film::pixelValue(const PixelSum& p) {
  if (p.weight == 0) return {0.0f, 0.0f, 0.0f};
  const double w = double(p.weight);
  return {float(double(p.rgb[0]) / w), float(double(p.rgb[1]) / w), float(double(p.rgb[2]) / w)};
}

void Film::addSample(int x, int y, const SampledSpectrum& L, const SampledWavelengths& lambda,
                     double w) {
  addSample(x, y, L, lambda, w, nullptr);
}

namespace {

/// A pixel sample lands inside the film's pixels (its tile is inside them).
void checkInBounds(const PixelBounds& b, int x, int y) {
  LENSIM_DCHECK_GE(x, b.x0);
  LENSIM_DCHECK_LT(x, b.x1);
  LENSIM_DCHECK_GE(y, b.y0);
  LENSIM_DCHECK_LT(y, b.y1);
}

}  // namespace

void Film::addSample(int x, int y, const SampledSpectrum& L, const SampledWavelengths& lambda,
                     double w, const VisibleSurface* vs) {
  checkInBounds(bounds_, x, y);
  const Vec3 sensor_rgb = toSensorRgb(L, lambda);
  const Vec3 rgb = recorded(sensor_rgb, L, lambda);
  const size_t i = size_t(y - bounds_.y0) * size_t(bounds_.width()) + size_t(x - bounds_.x0);
  if (!gbuf_.empty()) {
    // pbrt-v4's GBufferFilm::AddSample.
    GBufferPixel& g = gbuf_[i];
    g.weight_all += w;
    if (vs) {
      addAux(g, w, *vs);
      ++g.count;
      const Vec3 delta = sensor_rgb - g.mean;
      g.mean += delta / double(g.count);
      const Vec3 delta2 = sensor_rgb - g.mean;
      g.m2 += Vec3{delta.x * delta2.x, delta.y * delta2.y, delta.z * delta2.z};
    }
  }
  PixelSum& p = pixels_[i];
  p.rgb[0] += toFixed(w * rgb.x);
  p.rgb[1] += toFixed(w * rgb.y);
  p.rgb[2] += toFixed(w * rgb.z);
  p.weight += toFixed(w);
  if (n_buckets_ > 0) addSpectral(x, y, L, lambda, w);
}

void Film::enableGhostLayer() {
  ghost_.assign(pixels_.size(), {0, 0, 0});
  ghost_splats_.assign(pixels_.size(), {0, 0, 0});
}

const std::vector<std::string>& Film::ghostChannels() {
  static const std::vector<std::string> c = {"ghost.R", "ghost.G", "ghost.B"};
  return c;
}

std::array<float, 3> Film::ghostValue(const PixelSum& p, const GhostSum& g) {
  if (p.weight == 0) return {0.0f, 0.0f, 0.0f};
  const double w = double(p.weight);
  return {float(double(g[0]) / w), float(double(g[1]) / w), float(double(g[2]) / w)};
}

void Film::addGhost(int x, int y, const SampledSpectrum& L, const SampledWavelengths& lambda,
                    double w) {
  checkInBounds(bounds_, x, y);
  if (ghost_.empty()) return;
  const Vec3 rgb = recorded(toSensorRgb(L, lambda), L, lambda);
  const size_t i = size_t(y - bounds_.y0) * size_t(bounds_.width()) + size_t(x - bounds_.x0);
  const Int128 v[3] = {toFixed(w * rgb.x), toFixed(w * rgb.y), toFixed(w * rgb.z)};
  for (int c = 0; c < 3; ++c) {
    pixels_[i].rgb[c] += v[c];
    ghost_[i][size_t(c)] += v[c];
  }
}

void Film::addAux(GBufferPixel& g, double w, const VisibleSurface& vs) {
  g.weight += w;
  g.p += vs.p * w;
  g.n += vs.n * w;
  g.ns += vs.ns * w;
  g.u += vs.uv.x * w;
  g.v += vs.uv.y * w;
  g.dzdx += vs.dzdx * w;
  g.dzdy += vs.dzdy * w;
  g.albedo += vs.albedo * w;
}

void Film::addVisibleSurface(int x, int y, double w, const VisibleSurface* vs) {
  if (gbuf_.empty()) return;
  GBufferPixel& g =
      gbuf_[size_t(y - bounds_.y0) * size_t(bounds_.width()) + size_t(x - bounds_.x0)];
  g.weight_all += w;
  if (vs) addAux(g, w, *vs);
}

// pbrt-v4's SpectralFilm::AddSample (src/pbrt/film.h) adds each wavelength's radiance times
// CIE_Y_integral to its bucket and averages per bucket, which relies on its uniform wavelength
// sampling over [lambdamin, lambdamax]. lensim samples wavelengths by visible importance over
// [360, 830] nm, so a bucket gets the unbiased estimate of its mean radiance: for each of the
// sample's wavelengths in it, L / (pdf x N x bucket width), averaged with the pixel's filter
// weight. lensim's emission spectra are normalised to unit luminance Y = (1/CIE_Y_integral)
// integral(L ybar), pbrt-v4's to integral(L ybar) = 1, so lensim's radiance is already
// pbrt-v4's radiance times CIE_Y_integral: the two films record the same values. As in pbrt-v4
// the buckets hold radiance (no sensor, imaging ratio or white balance), clamped to
// "maxcomponentvalue" as a whole spectrum.
void Film::addSpectral(int x, int y, SampledSpectrum L, const SampledWavelengths& lambda,
                       double w) {
  double lm = 0;
  for (int i = 0; i < kSpectrumSamples; ++i) lm = std::max(lm, L[i]);
  if (lm > max_component_) L = L * (max_component_ / lm);
  const double width = (lambda_max_ - lambda_min_) / n_buckets_;
  double* sums = bucket_sums_.data() +
                 (size_t(y - bounds_.y0) * size_t(bounds_.width()) + size_t(x - bounds_.x0)) *
                     size_t(n_buckets_);
  for (int i = 0; i < kSpectrumSamples; ++i) {
    const double l = lambda.lambda(i), pdf = lambda.pdf(i);
    if (!(pdf > 0) || l < lambda_min_ || l >= lambda_max_) continue;
    const int b =
        std::min(n_buckets_ - 1, int(n_buckets_ * (l - lambda_min_) / (lambda_max_ - lambda_min_)));
    sums[b] += w * L[i] / (pdf * kSpectrumSamples * width);
  }
}

void Film::enableSplats(const Filter& filter) {
  splat_filter_ = &filter;
  splats_.assign(pixels_.size(), {0, 0, 0});
  if (n_buckets_ > 0) bucket_splats_.assign(pixels_.size() * size_t(n_buckets_), 0.0);
  splat_locks_ = std::make_unique<std::mutex[]>(kSplatLocks);
}

void Film::addSplat(Vec2 p, const SampledSpectrum& L, const SampledWavelengths& lambda,
                    bool ghost) {
  ghost = ghost && !ghost_splats_.empty();
  if (!splat_filter_) return;
  const Vec3 sensor_rgb = toSensorRgb(L, lambda);
  const Vec3 rgb = recorded(sensor_rgb, L, lambda);
  const Vec2 r = splat_filter_->radius();
  const double norm = 1 / splat_filter_->integral();
  // Pixels whose centre (x + 0.5, y + 0.5) lies within the filter radius of p.
  const int x0 = std::max(bounds_.x0, int(std::ceil(p.x - 0.5 - r.x)));
  const int x1 = std::min(bounds_.x1 - 1, int(std::floor(p.x - 0.5 + r.x)));
  const int y0 = std::max(bounds_.y0, int(std::ceil(p.y - 0.5 - r.y)));
  const int y1 = std::min(bounds_.y1 - 1, int(std::floor(p.y - 0.5 + r.y)));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double w = splat_filter_->eval({p.x - (x + 0.5), p.y - (y + 0.5)}) * norm;
      if (w == 0) continue;
      const size_t i = size_t(y - bounds_.y0) * size_t(bounds_.width()) + size_t(x - bounds_.x0);
      const Int128 v[3] = {toFixed(w * rgb.x), toFixed(w * rgb.y), toFixed(w * rgb.z)};
      std::lock_guard lock(splat_locks_[i % kSplatLocks]);
      for (int c = 0; c < 3; ++c) splats_[i][size_t(c)] += v[c];
      if (ghost)
        for (int c = 0; c < 3; ++c) ghost_splats_[i][size_t(c)] += v[c];
      if (!gbuf_.empty()) {
        const Vec3 y = sensor_rgb * w;
        gbuf_[i].splat_sum += y;
        gbuf_[i].splat_sq += Vec3{y.x * y.x, y.y * y.y, y.z * y.z};
      }
      if (n_buckets_ > 0) {
        // As addSpectral, the bucket estimate of the splat's radiance.
        const double width = (lambda_max_ - lambda_min_) / n_buckets_;
        for (int k = 0; k < kSpectrumSamples; ++k) {
          const double l = lambda.lambda(k), pdf = lambda.pdf(k);
          if (!(pdf > 0) || l < lambda_min_ || l >= lambda_max_) continue;
          const int b = std::min(n_buckets_ - 1,
                                 int(n_buckets_ * (l - lambda_min_) / (lambda_max_ - lambda_min_)));
          bucket_splats_[i * size_t(n_buckets_) + size_t(b)] +=
              w * std::min(L[k], max_component_) / (pdf * kSpectrumSamples * width);
        }
      }
    }
}

std::string Film::bucketChannel(int b) const {
  std::string l =
      fmt::format("{:.3f}nm", lambda_min_ + (b + 0.5) / n_buckets_ * (lambda_max_ - lambda_min_));
  std::replace(l.begin(), l.end(), '.', ',');
  return "S0." + l;
}

const std::vector<std::string>& Film::gbufferChannels() {
  static const std::vector<std::string> c = {"Albedo.R",
                                             "Albedo.G",
                                             "Albedo.B",
                                             "P.X",
                                             "P.Y",
                                             "P.Z",
                                             "dzdx",
                                             "dzdy",
                                             "N.X",
                                             "N.Y",
                                             "N.Z",
                                             "Ns.X",
                                             "Ns.Y",
                                             "Ns.Z",
                                             "u",
                                             "v",
                                             "Variance.R",
                                             "Variance.G",
                                             "Variance.B",
                                             "RelativeVariance.R",
                                             "RelativeVariance.G",
                                             "RelativeVariance.B"};
  return c;
}

io::Image Film::image() const {
  std::vector<std::string> channels = {"R", "G", "B"};
  for (int b = 0; b < n_buckets_; ++b) channels.push_back(bucketChannel(b));
  if (!gbuf_.empty())
    for (const std::string& c : gbufferChannels()) channels.push_back(c);
  const int ghost_c0 = int(channels.size());
  if (!ghost_.empty())
    for (const std::string& c : ghostChannels()) channels.push_back(c);
  io::Image im(bounds_.width(), bounds_.height(), std::move(channels));
  for (int y = 0; y < bounds_.height(); ++y)
    for (int x = 0; x < bounds_.width(); ++x) {
      const size_t i = size_t(y) * size_t(bounds_.width()) + size_t(x);
      const auto v = pixelValue(pixels_[i]);
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = v[c];
      if (n_buckets_ > 0 && pixels_[i].weight != 0) {
        const double w = double(pixels_[i].weight) / kFixedScale;
        for (int b = 0; b < n_buckets_; ++b)
          im.at(x, y, 3 + b) = float(bucket_sums_[i * size_t(n_buckets_) + size_t(b)] / w);
      }
      if (!ghost_.empty()) {
        const auto g = ghostValue(pixels_[i], ghost_[i]);
        for (int c = 0; c < 3; ++c) im.at(x, y, ghost_c0 + c) = g[c];
      }
      if (!splats_.empty()) {
        for (int c = 0; c < 3; ++c)
          im.at(x, y, c) += float(double(splats_[i][size_t(c)]) / kFixedScale * splat_scale_);
        if (!ghost_.empty())
          for (int c = 0; c < 3; ++c)
            im.at(x, y, ghost_c0 + c) +=
                float(double(ghost_splats_[i][size_t(c)]) / kFixedScale * splat_scale_);
        for (int b = 0; b < n_buckets_; ++b)
          im.at(x, y, 3 + b) +=
              float(bucket_splats_[i * size_t(n_buckets_) + size_t(b)] * splat_scale_);
      }
    }
  if (!gbuf_.empty()) {
    // pbrt-v4's GBufferFilm::GetImage: albedo over the pixel's whole weight; position, (u, v) and
    // depth slopes over the weight of the samples that saw a surface; the normals' sums
    // normalised; |dzdx|, |dzdy|; the sample variance of the sensor RGB and that over its mean.
    const int c0 = 3 + n_buckets_;
    for (int y = 0; y < bounds_.height(); ++y)
      for (int x = 0; x < bounds_.width(); ++x) {
        const size_t i = size_t(y) * size_t(bounds_.width()) + size_t(x);
        const GBufferPixel& g = gbuf_[i];
        const Vec3 albedo = g.weight_all != 0 ? g.albedo / g.weight_all : Vec3{};
        const double w = g.weight != 0 ? g.weight : 1;
        const Vec3 pos = g.p / w;
        const auto unit = [](const Vec3& v) {
          const double l = length(v);
          return l > 0 ? v / l : Vec3{};
        };
        const Vec3 n = unit(g.n), ns = unit(g.ns);
        Vec3 var = g.count > 1 ? g.m2 / double(g.count - 1) : Vec3{};
        Vec3 mean = g.count > 0 ? g.mean : Vec3{};
        if (!splats_.empty()) {
          // The splatted part of the pixel (lighttracer; bdpt's t = 1 strategies), as a
          // variance per light path of the pixel's estimate so that, as for the sampled part,
          // Variance / spp is the variance of the pixel value. The pixel's splatted value is
          // V = s sum_j Y_j over the M = spp A light paths started in the A pixels rendered
          // (s: the splat scale), Y_j path j's filtered splats on this pixel. Its estimated
          // variance is s^2 sum Y_j^2 - V^2 / M; times spp that is spp s^2 sum Y_j^2 - V^2 / A.
          // sum Y_j^2 is taken over the splats (a path splatting twice on one pixel counts as
          // two paths, which underestimates slightly). The two parts are added (their
          // covariance is ignored: a sample's splats land elsewhere than its own pixel).
          const double s = splat_scale_, spp = std::max(splat_spp_, 1);
          const double area = double(bounds_.area());
          const Vec3 v = g.splat_sum * s;
          const auto part = [&](double sq, double val) {
            return std::max(0.0, spp * s * s * sq - val * val / area);
          };
          var += Vec3{part(g.splat_sq.x, v.x), part(g.splat_sq.y, v.y), part(g.splat_sq.z, v.z)};
          mean += v;
        }
        const auto rel = [&](double v, double m) { return m == 0 ? 0.0 : v / m; };
        const double values[22] = {albedo.x,
                                   albedo.y,
                                   albedo.z,
                                   pos.x,
                                   pos.y,
                                   pos.z,
                                   std::abs(g.dzdx / w),
                                   std::abs(g.dzdy / w),
                                   n.x,
                                   n.y,
                                   n.z,
                                   ns.x,
                                   ns.y,
                                   ns.z,
                                   g.u / w,
                                   g.v / w,
                                   var.x,
                                   var.y,
                                   var.z,
                                   rel(var.x, mean.x),
                                   rel(var.y, mean.y),
                                   rel(var.z, mean.z)};
        for (int c = 0; c < 22; ++c) im.at(x, y, c0 + c) = float(values[c]);
      }
  }
  for (const auto& [key, value] : raw_metadata_) im.metadata[key] = value;
  if (n_buckets_ > 0) {
    // The OpenEXR spectral layout's attributes (Fichet et al., JCGT 2021), as pbrt-v4's
    // SpectralFilm::GetImage writes them.
    im.metadata["spectralLayoutVersion"] = "1.0";
    im.metadata["emissiveUnits"] = "W.m^-2.sr^-1";
    im.metadata["lensim:spectral"] =
        fmt::format("{} buckets over [{}, {}] nm: radiance (as pbrt-v4's spectral film)",
                    n_buckets_, lambda_min_, lambda_max_);
  }
  return im;
}

}  // namespace lensim::render
