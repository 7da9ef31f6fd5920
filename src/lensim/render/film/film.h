// The film: accumulates filtered spectral samples as RGB in the output colour space (linear
// sRGB) through the film's sensor (pbrt-v4's PixelSensor: the CIE 1931 matching functions, or a
// camera's measured sensitivities; film/pixel_sensor.h), over the pixel bounds being rendered.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/spectra/spectrum.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::sampling {
class Filter;
}

namespace lensim::render {

using namespace lensim::sampling;

class PixelSensor;
class SensorModel;
struct VisibleSurface;

/// A half-open rectangle of pixels [x0, x1) x [y0, y1) in the full image's raster.
struct PixelBounds {
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
  long long area() const { return (long long)width() * height(); }
  bool operator==(const PixelBounds&) const = default;
};

/// A 128-bit signed integer (GCC/Clang extension).
__extension__ typedef __int128 Int128;

/// A pixel's accumulated samples, exactly: the filter-weighted RGB sums and the weight sum as
/// fixed-point integers (Film::kFixedScale units). Integer sums do not depend on the order in
/// which samples are added, so a pixel rendered in any number of sample slices, tiles, threads
/// or resumed runs sums to the very same bits, and dividing only at the end gives the same
/// float pixel (the exact merge that distributed renders need; floating-point sums would differ
/// in the last bits with the summation order).
struct PixelSum {
  Int128 rgb[3] = {0, 0, 0};
  Int128 weight = 0;
  PixelSum& operator+=(const PixelSum& o) {
    for (int c = 0; c < 3; ++c) rgb[c] += o.rgb[c];
    weight += o.weight;
    return *this;
  }
  bool operator==(const PixelSum&) const = default;
};

/// A pixel's ghost-layer sums (lens flare, Film::enableGhostLayer): the filter-weighted RGB of
/// its camera samples' ghost paths, in PixelSum's fixed-point units; the pixel's PixelSum holds
/// their weight. Exact like PixelSum, so parts and checkpoints carry the ghost layer too.
using GhostSum = std::array<Int128, 3>;

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
  /// As addSample, for a gbuffer film with the sample's first visible surface (null: the camera
  /// ray hit nothing, or the integrator gives none).
  void addSample(int x, int y, const SampledSpectrum& L, const SampledWavelengths& lambda, double w,
                 const VisibleSurface* vs);
  /// For a gbuffer film whose radiance is splatted (lighttracer): the auxiliary data of a camera
  /// sample of pixel (x, y) with filter weight w, traced for them alone (vs null: the ray hit
  /// nothing); the pixel's RGB and variance come from the splats.
  void addVisibleSurface(int x, int y, double w, const VisibleSurface* vs);
  /// The RGB of a sample as the film would record it (before the filter weight): the sensor's
  /// RGB (toSensorRgb) in the output colour space (outputRgb).
  Vec3 toRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const;
  /// The sensor RGB of a sample (pbrt-v4's PixelSensor::ToSensorRGB with the imaging ratio),
  /// scaled down to "maxcomponentvalue" in its largest component as pbrt-v4 does.
  Vec3 toSensorRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const;
  /// Output (linear sRGB) from sensor RGB: the sensor's XYZ-from-RGB matrix, then XYZ to sRGB.
  Vec3 outputRgb(const Vec3& sensor_rgb) const;
  /// Film "raw": the camera sensor whose expected photo-electrons per colour channel the film
  /// accumulates (in place of RGB; the noise is applied when the image is written,
  /// render/sensor/raw_output.h); null for other films.
  const SensorModel* rawSensor() const { return raw_.get(); }
  /// Film "raw": adds metadata (raw_output.h's keys) to what the image will carry.
  void addRawMetadata(const std::map<std::string, std::string>& m) {
    for (const auto& [k, v] : m) raw_metadata_[k] = v;
  }
  /// The film's sensor (pbrt-v4's PixelSensor: "cie1931" or a named camera).
  const PixelSensor& sensor() const { return *sensor_; }
  /// The image so far: channels R, G, B, bounds-sized; for the spectral film (pbrt-v4's
  /// SpectralFilm) then one channel per wavelength bucket, named as pbrt-v4 names them after
  /// the OpenEXR spectral layout of Fichet et al. (JCGT 2021): "S0." and the bucket's centre
  /// wavelength as "%.3fnm" with the decimal point written as a comma ("S0.374,688nm"); for the
  /// gbuffer film (pbrt-v4's GBufferFilm) then its auxiliary channels (gbufferChannels()).
  io::Image image() const;

  /// Lens flare (the realistic camera's "bool flare"): the film also keeps the ghost paths'
  /// part of the image, written after the other channels as the EXR layer "ghost" (channels
  /// ghost.R, ghost.G, ghost.B); R, G, B hold the sum of the direct and ghost paths.
  void enableGhostLayer();
  bool ghostLayer() const { return !ghost_.empty(); }
  /// The channel names of the ghost layer.
  static const std::vector<std::string>& ghostChannels();
  /// The ghost layer's value of a pixel with sums `p` and ghost sums `g` (over p's weight; 0
  /// where the weight is 0), as floats.
  static std::array<float, 3> ghostValue(const PixelSum& p, const GhostSum& g);
  /// The ghost layer's accumulators, row by row over bounds() (empty without the layer), for
  /// parts, checkpoints and resuming. Splats (the light tracer's ghost connections) are not
  /// among them: splatting renders are not written as parts.
  const std::vector<GhostSum>& ghostSums() const { return ghost_; }
  std::vector<GhostSum>& ghostSums() { return ghost_; }
  /// Adds the ghost path of a camera sample whose direct path addSample added (or will add)
  /// with the same filter weight w: to the pixel's RGB sums and the ghost layer, not to its
  /// weight (both paths belong to one sample). Not thread-safe for the same pixel.
  void addGhost(int x, int y, const SampledSpectrum& L, const SampledWavelengths& lambda, double w);

  /// Whether this film records pbrt-v4's gbuffer channels (Film "gbuffer"); such films, like
  /// spectral ones, are not written as parts.
  bool gbuffer() const { return !gbuf_.empty(); }
  /// The gbuffer's channels after R, G, B, in pbrt-v4's order and names (src/pbrt/film.cpp,
  /// GBufferFilm::GetImage): Albedo.R/G/B, P.X/Y/Z, dzdx, dzdy, N.X/Y/Z, Ns.X/Y/Z, u, v,
  /// Variance.R/G/B, RelativeVariance.R/G/B.
  static const std::vector<std::string>& gbufferChannels();

  /// Whether this film records spectral buckets (Film "spectral"); such films are not
  /// written as parts (their bucket sums are floating point, not the exact fixed-point sums).
  bool spectral() const { return n_buckets_ > 0; }
  /// The channel name of spectral bucket b (see image()).
  std::string bucketChannel(int b) const;

  /// Fixed-point units per unit of weighted RGB or filter weight: 2^48, so a sample's
  /// contribution keeps ~15 significant digits down to 1e-6 and the sum of 2^26 samples of up
  /// to 4.5e15 (the clamp) cannot overflow.
  static constexpr double kFixedScale = 0x1p48;
  /// A value in fixed-point units, rounded to nearest, clamped to +-2^52 (NaN counts as 0).
  static Int128 toFixed(double v);
  /// The pixel value of accumulated sums: sum / weight (0 where the weight is 0), as floats.
  static std::array<float, 3> pixelValue(const PixelSum& p);
  /// The accumulators, row by row over bounds() (for parts, checkpoints and resuming).
  const std::vector<PixelSum>& sums() const { return pixels_; }
  std::vector<PixelSum>& sums() { return pixels_; }

  // Splats: contributions of light paths that reach the film at any point (light tracing,
  // bidirectional methods; camera.h, CameraWiSample, has the measurement convention). A pixel of
  // the image is its filtered estimate (the samples above) plus splat_scale times its splat sum.
  // Splat sums are fixed-point integers like the pixels' sums, so they too do not depend on the
  // order in which threads add them: a splatting render's RGB is deterministic whatever the number
  // of threads (a spectral film's bucket splats are floating point: their last bits may vary).
  // They are not written to parts or checkpoints (the renderer refuses those for a
  // splatting integrator: a light path started in one tile splats anywhere in the image).
  /// Makes the film accept splats (allocates the splat sums), reconstructed with `filter`
  /// (which must outlive the film).
  void enableSplats(const Filter& filter);
  /// Adds the splat L (carried by lambda) at the continuous raster position p (full image): to
  /// each pixel of bounds() whose filter support holds p, with weight f(p - centre) / (integral
  /// of f), so that a splat adds its whole value to the image and the splatted image is filtered
  /// as the sampled one is (pbrt-v4's RGBFilm::AddSplat, src/pbrt/film.cpp, weighs by the raw
  /// filter value, which matches only filters of unit integral). Thread-safe.
  /// `ghost`: a lens-flare ghost path's splat (the light tracer's), also added to the ghost
  /// layer when the film has one.
  void addSplat(Vec2 p, const SampledSpectrum& L, const SampledWavelengths& lambda,
                bool ghost = false);
  /// The factor image() applies to the splat sums: 1 / (light paths per pixel of the full
  /// image), pbrt-v4's 1 / spp for a render of the whole image.
  /// `samples_per_pixel`: the light paths started per pixel rendered, for a gbuffer film's
  /// variance of the splatted estimate.
  void setSplatScale(double scale, int samples_per_pixel = 1) {
    splat_scale_ = scale;
    splat_spp_ = samples_per_pixel;
  }

 private:
  PixelBounds bounds_;
  std::vector<PixelSum> pixels_;
  double max_component_ = 1e300;
  std::shared_ptr<const PixelSensor> sensor_;
  std::shared_ptr<const SensorModel> raw_;
  std::map<std::string, std::string> raw_metadata_;  ///< raw_output.h's keys
  /// What the film accumulates for a sample: output RGB, or a raw film's expected electrons.
  Vec3 recorded(const Vec3& sensor_rgb, const SampledSpectrum& L,
                const SampledWavelengths& lambda) const;
  // Spectral buckets (Film "spectral"): per pixel, n_buckets_ sums of filter-weighted bucket
  // radiance estimates; a bucket's value is its sum over the pixel's weight sum.
  int n_buckets_ = 0;
  double lambda_min_ = 360, lambda_max_ = 830;
  std::vector<double> bucket_sums_;
  void addSpectral(int x, int y, SampledSpectrum L, const SampledWavelengths& lambda, double w);
  // Gbuffer (Film "gbuffer", pbrt-v4's GBufferFilm::Pixel): per pixel, the filter-weighted sums
  // of the visible surfaces' data over the samples that have one (weight), the albedo's sum
  // (divided by the pixel's whole weight, as pbrt-v4), and a running variance (Welford) of the
  // unweighted sensor RGB of those samples.
  // weight_all: the filter weights of all the pixel's camera samples (the albedo's divisor).
  // splat_sum, splat_sq: a splatting integrator's per-pixel sums of the splats' filter-weighted
  // sensor RGB and of its squares (the variance of the splatted estimate; see image()).
  struct GBufferPixel {
    double weight = 0, weight_all = 0;
    Vec3 splat_sum, splat_sq;
    Vec3 p, n, ns, albedo;
    double u = 0, v = 0, dzdx = 0, dzdy = 0;
    long long count = 0;
    Vec3 mean, m2;
  };
  std::vector<GBufferPixel> gbuf_;
  // Splats (see enableSplats).
  const Filter* splat_filter_ = nullptr;
  double splat_scale_ = 1;
  int splat_spp_ = 1;
  void addAux(GBufferPixel& g, double w, const VisibleSurface& vs);
  std::vector<std::array<Int128, 3>> splats_;
  std::vector<GhostSum> ghost_;                      ///< per pixel: the ghost paths' RGB sums
  std::vector<std::array<Int128, 3>> ghost_splats_;  ///< per pixel: the ghost splats' sums
  std::vector<double> bucket_splats_;          ///< spectral films: per pixel, n_buckets_ splat sums
  static constexpr size_t kSplatLocks = 1024;  ///< lock stripes (by pixel index)
  std::unique_ptr<std::mutex[]> splat_locks_;
};

}  // namespace lensim::render
