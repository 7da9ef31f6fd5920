#include "lensim/render/materials/measured_rgl.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "lensim/render/materials/tensor_file.h"
#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"
#include "lensim/util/path_cache.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

// Unit-square coordinates of the parameterisation (pbrt-v4 MeasuredBxDF::theta2u etc.).
inline double theta2u(double theta) {
  return std::sqrt(std::max(0.0, theta) * (2 / kPi));
}
inline double phi2u(double phi) {
  return (phi + kPi) / (2 * kPi);
}
inline double u2theta(double u) {
  return u * u * (kPi / 2);
}
inline double u2phi(double u) {
  return (2 * u - 1) * kPi;
}

// Elevation of a unit vector, accurate near the pole (2 asin(|w - z| / 2)).
inline double elevation(const Vec3& w) {
  const double d = std::sqrt(w.x * w.x + w.y * w.y + (w.z - 1) * (w.z - 1));
  return 2 * std::asin(std::min(1.0, 0.5 * d));
}

inline Vec3 normalized(const Vec3& v) {
  const double l = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return l > 0 ? v / l : Vec3{};
}

// Reading and checking the fields of the tensor file.
class Fields {
 public:
  explicit Fields(const TensorFile& tf) : tf_(tf) {}

  // A field of `dtype` whose shape has `ndim` extents, each at least `min_extent`.
  const TensorField& get(std::string_view name, TensorField::DType dtype, std::size_t ndim,
                         uint64_t min_extent, std::string_view what) const {
    const TensorField& f = tf_.require(name, what);
    check(f, dtype, ndim, min_extent);
    return f;
  }
  void check(const TensorField& f, TensorField::DType dtype, std::size_t ndim,
             uint64_t min_extent) const {
    if (f.dtype != dtype)
      tf_.fail(f.header_offset, fmt::format("field \"{}\" has type {}; expected {}", f.name,
                                            tensorTypeName(f.dtype), tensorTypeName(dtype)));
    if (f.shape.size() != ndim)
      tf_.fail(f.header_offset, fmt::format("field \"{}\" has {} dimensions; expected {}", f.name,
                                            f.shape.size(), ndim));
    for (std::size_t d = 0; d < ndim; ++d)
      if (f.shape[d] < min_extent || f.shape[d] > (uint64_t{1} << 30))
        tf_.fail(f.header_offset,
                 fmt::format("field \"{}\" has {} entries along dimension {}; expected {} to "
                             "2^30",
                             f.name, f.shape[d], d + 1, min_extent));
  }
  void expectExtent(const TensorField& f, std::size_t d, uint64_t n, std::string_view why) const {
    if (f.shape[d] != n)
      tf_.fail(f.header_offset, fmt::format("field \"{}\" has {} entries along dimension {}; "
                                            "expected {} ({})",
                                            f.name, f.shape[d], d + 1, n, why));
  }
  // The float32 values, each finite and within [lo, hi], or a located error.
  std::vector<float> floats(const TensorField& f, double lo, double hi,
                            std::string_view expected) const {
    std::vector<float> v(f.count);
    for (uint64_t i = 0; i < f.count; ++i) {
      const double x = tf_.float32At(f, i);
      if (!(x >= lo && x <= hi))
        tf_.fail(
            tf_.byteOffset(f, i),
            fmt::format("value {} of field \"{}\" is {}; expected {}", i, f.name,
                        std::isnan(x) ? std::string("nan") : fmt::format("{:g}", x), expected));
      v[i] = float(x);
    }
    return v;
  }
  // Strictly increasing values (a parameter axis).
  void increasing(const TensorField& f, const std::vector<float>& v) const {
    for (std::size_t i = 1; i < v.size(); ++i)
      if (!(v[i] > v[i - 1]))
        tf_.fail(tf_.byteOffset(f, i),
                 fmt::format("value {} of field \"{}\" is {:g} after {:g}; expected increasing "
                             "values",
                             i, f.name, v[i], v[i - 1]));
  }
  // Every 2D slice of a density table integrates to a positive number.
  void positiveSlices(const TensorField& f, const std::vector<float>& v, int nx, int ny) const {
    const std::size_t per = std::size_t(nx) * std::size_t(ny);
    for (std::size_t s = 0; s * per < v.size(); ++s)
      if (!(PiecewiseLinear2D::sliceIntegral(v, nx, ny, s) > 0))
        tf_.fail(tf_.byteOffset(f, s * per),
                 fmt::format("slice {} of field \"{}\" is zero everywhere; expected a density "
                             "with a positive integral",
                             s, f.name));
  }

 private:
  const TensorFile& tf_;
};

}  // namespace

RGLMeasuredBRDF RGLMeasuredBRDF::read(const std::string& path) {
  return parse(readRegularFile(path, "measured BSDF file"), path);
}

RGLMeasuredBRDF RGLMeasuredBRDF::parse(std::string bytes, const std::string& path) {
  using D = TensorField::DType;
  const TensorFile tf(std::move(bytes), path);
  const Fields fields(tf);
  RGLMeasuredBRDF b;

  const TensorField& theta_f = fields.get("theta_i", D::Float32, 1, 1, "incident elevations");
  const TensorField& phi_f = fields.get("phi_i", D::Float32, 1, 1, "incident azimuths");
  const TensorField& ndf_f = fields.get("ndf", D::Float32, 2, 2, "microfacet distribution");
  const TensorField& sigma_f = fields.get("sigma", D::Float32, 2, 2, "projected areas");
  const TensorField& vndf_f = fields.get("vndf", D::Float32, 4, 1, "visible normals");
  const TensorField& lum_f = fields.get("luminance", D::Float32, 4, 1, "luminance");
  const TensorField* wl_f = tf.find("wavelengths");
  const TensorField* spec_f = tf.find("spectra");
  b.rgb_ = !wl_f && !spec_f && tf.find("rgb");
  if (b.rgb_) {
    spec_f = &tf.require("rgb", "RGB values");
    fields.check(*spec_f, D::Float32, 5, 1);
    fields.expectExtent(*spec_f, 2, 3, "the three RGB channels");
  } else {
    wl_f = &fields.get("wavelengths", D::Float32, 1, 1, "wavelengths of the spectra");
    spec_f = &fields.get("spectra", D::Float32, 5, 1, "spectral values");
    fields.expectExtent(*spec_f, 2, wl_f->shape[0], "one per wavelength");
  }
  const uint64_t n_theta = theta_f.shape[0], n_phi = phi_f.shape[0];
  for (const TensorField* f : {&vndf_f, &lum_f, spec_f}) {
    fields.expectExtent(*f, 0, n_phi, "one per incident azimuth phi_i");
    fields.expectExtent(*f, 1, n_theta, "one per incident elevation theta_i");
  }
  const std::size_t ld = lum_f.shape.size();
  for (const TensorField* f : {&vndf_f, &lum_f})
    for (std::size_t d = 2; d < 4; ++d)
      if (f->shape[d] < 2) fields.expectExtent(*f, d, 2, "at least 2 nodes of the unit square");
  fields.expectExtent(*spec_f, 3, lum_f.shape[ld - 2], "as many as the luminance table");
  fields.expectExtent(*spec_f, 4, lum_f.shape[ld - 1], "as many as the luminance table");
  if (const TensorField* j = tf.find("jacobian")) {
    fields.check(*j, D::UInt8, 1, 1);
    fields.expectExtent(*j, 0, 1, "one flag");
    b.jacobian_ = tf.uint8At(*j, 0) != 0;
  }
  if (const TensorField* d = tf.find("description")) {
    fields.check(*d, D::UInt8, 1, 0);
    for (uint64_t i = 0; i < std::min<uint64_t>(d->count, 1000); ++i)
      b.description_.push_back(char(tf.uint8At(*d, i)));
  }

  // The tables built below, before any of them is allocated.
  {
    auto slices = [](const TensorField& f, int params) {
      double s = 1;
      for (int d = 0; d < params; ++d) s *= double(f.shape[std::size_t(d)]);
      return s;
    };
    using M = PiecewiseLinear2D::Mode;
    const double bytes_needed =
        PiecewiseLinear2D::bytesFor(1, int(ndf_f.shape[1]), int(ndf_f.shape[0]), M::Values) +
        PiecewiseLinear2D::bytesFor(1, int(sigma_f.shape[1]), int(sigma_f.shape[0]), M::Values) +
        PiecewiseLinear2D::bytesFor(std::size_t(slices(vndf_f, 2)), int(vndf_f.shape[3]),
                                    int(vndf_f.shape[2]), M::Density) +
        PiecewiseLinear2D::bytesFor(std::size_t(slices(lum_f, 2)), int(lum_f.shape[3]),
                                    int(lum_f.shape[2]), M::Density) +
        2 * PiecewiseLinear2D::bytesFor(std::size_t(slices(*spec_f, 3)), int(spec_f->shape[4]),
                                        int(spec_f->shape[3]), M::Values);
    checkMemory(bytes_needed, FileLoc{path}, "the measured BSDF tables");
  }

  const double kHalfPi = kPi / 2 + 1e-4;
  std::vector<float> theta = fields.floats(theta_f, 0, kHalfPi, "an elevation in [0, pi/2]");
  fields.increasing(theta_f, theta);
  std::vector<float> phi =
      fields.floats(phi_f, -2 * kPi - 1e-3, 2 * kPi + 1e-3, "an azimuth in [-2 pi, 2 pi]");
  fields.increasing(phi_f, phi);
  b.isotropic_ = n_phi <= 2;  // as pbrt-v4 and Mitsuba decide it
  if (!b.isotropic_) {
    // pbrt-v4 refuses anisotropic data that covers only part of the circle (Mitsuba's
    // "reduction" by symmetry); so does lensim.
    const double span = double(phi.back()) - phi.front();
    const long reduction = std::lround(2 * kPi / span);
    if (reduction != 1)
      tf.fail(phi_f.header_offset,
              fmt::format("field \"phi_i\" covers {:g} radians, 1/{} of the circle; expected "
                          "the whole circle (anisotropic data reduced by symmetry is not "
                          "supported, as in pbrt-v4)",
                          span, reduction));
  }
  const std::string nonneg = fmt::format("a finite number in [0, {:g}]", kMaxRGLValue);
  const std::string any = fmt::format("a finite number of magnitude at most {:g}", kMaxRGLValue);
  using M = PiecewiseLinear2D::Mode;
  {
    const std::vector<float> v = fields.floats(ndf_f, 0, kMaxRGLValue, nonneg);
    b.ndf_ = PiecewiseLinear2D(v, int(ndf_f.shape[1]), int(ndf_f.shape[0]), {}, M::Values);
  }
  {
    const std::vector<float> v = fields.floats(sigma_f, 0, kMaxRGLValue, nonneg);
    b.sigma_ = PiecewiseLinear2D(v, int(sigma_f.shape[1]), int(sigma_f.shape[0]), {}, M::Values);
  }
  {
    const std::vector<float> v = fields.floats(vndf_f, 0, kMaxRGLValue, nonneg);
    fields.positiveSlices(vndf_f, v, int(vndf_f.shape[3]), int(vndf_f.shape[2]));
    b.vndf_ =
        PiecewiseLinear2D(v, int(vndf_f.shape[3]), int(vndf_f.shape[2]), {phi, theta}, M::Density);
  }
  {
    const std::vector<float> v = fields.floats(lum_f, 0, kMaxRGLValue, nonneg);
    fields.positiveSlices(lum_f, v, int(lum_f.shape[3]), int(lum_f.shape[2]));
    b.luminance_ =
        PiecewiseLinear2D(v, int(lum_f.shape[3]), int(lum_f.shape[2]), {phi, theta}, M::Density);
  }
  if (b.rgb_) {
    b.wavelengths_ = {0, 1, 2};  // the channel index is the third parameter (as in Mitsuba)
  } else {
    b.wavelengths_ = fields.floats(*wl_f, 1, 1e6, "a wavelength in nm (positive)");
    fields.increasing(*wl_f, b.wavelengths_);
  }
  {
    const std::vector<float> v = fields.floats(*spec_f, -kMaxRGLValue, kMaxRGLValue, any);
    b.spectra_ = PiecewiseLinear2D(v, int(spec_f->shape[4]), int(spec_f->shape[3]),
                                   {phi, theta, b.wavelengths_}, M::Values);
  }
  return b;
}

std::shared_ptr<const RGLMeasuredBRDF> RGLMeasuredBRDF::loadCached(const std::string& path) {
  // The last file this thread asked for, so that the lock is not taken per shading point.
  thread_local std::string last_path;
  thread_local std::shared_ptr<const RGLMeasuredBRDF> last;
  if (last && last_path == path) return last;
  last = loadOncePerPath<RGLMeasuredBRDF>(path, [](const std::string& p) { return read(p); });
  last_path = path;
  return last;
}

SampledSpectrum RGLMeasuredBRDF::values(Vec2 sample, double phi_o, double theta_o,
                                        const SampledWavelengths& lambda) const {
  SampledSpectrum s;
  if (!rgb_) {
    for (int i = 0; i < kSpectrumSamples; ++i) {
      const double params[3] = {phi_o, theta_o, lambda.lambda(i)};
      s[i] = std::max(0.0, spectra_.eval(sample, params));
    }
    return s;
  }
  // Linear sRGB values turned into a spectrum as pbrt-v4 does for unbounded RGB
  // (RGBUnboundedSpectrum: scale 2 max(rgb), the sigmoid fit of rgb / scale).
  Vec3 rgb;
  for (int c = 0; c < 3; ++c) {
    const double params[3] = {phi_o, theta_o, double(c)};
    const double v = std::max(0.0, spectra_.eval(sample, params));
    (c == 0 ? rgb.x : c == 1 ? rgb.y : rgb.z) = v;
  }
  const double m = std::max({rgb.x, rgb.y, rgb.z});
  if (!(m > 0)) return s;
  const double scale = 2 * m;
  const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(rgb / scale);
  return poly.sample(lambda) * scale;
}

SampledSpectrum RGLMeasuredBRDF::f(const Vec3& wo, const Vec3& wi,
                                   const SampledWavelengths& lambda) const {
  if (wo.z <= 0 || wi.z <= 0) return {};
  const Vec3 wm = normalized(wo + wi);
  if (wm.z <= 0) return {};
  const double theta_o = elevation(wo), phi_o = std::atan2(wo.y, wo.x);
  const double theta_m = elevation(wm), phi_m = std::atan2(wm.y, wm.x);
  const Vec2 u_wo{theta2u(theta_o), phi2u(phi_o)};
  Vec2 u_wm{theta2u(theta_m), phi2u(isotropic_ ? phi_m - phi_o : phi_m)};
  u_wm.y -= std::floor(u_wm.y);
  const double params[2] = {phi_o, theta_o};
  const Vec2 sample = vndf_.invert(u_wm, params).p;
  SampledSpectrum s = values(sample, phi_o, theta_o, lambda);
  if (!jacobian_) return s * (1 / wi.z);
  const double sigma = sigma_.eval(u_wo);
  if (!(sigma > 0)) return {};
  return s * (ndf_.eval(u_wm) / (4 * sigma * wi.z));
}

std::optional<BSDFSample> RGLMeasuredBRDF::sample(const Vec3& wo, Vec2 u,
                                                  const SampledWavelengths& lambda) const {
  if (wo.z <= 0) return std::nullopt;
  const double theta_o = elevation(wo), phi_o = std::atan2(wo.y, wo.x);
  const double params[2] = {phi_o, theta_o};
  // The luminance warp first, then the visible normals (pbrt-v4 passes u swapped).
  const PiecewiseLinear2D::Sample lum = luminance_.sample({u.y, u.x}, params);
  const PiecewiseLinear2D::Sample m = vndf_.sample(lum.p, params);
  const Vec2 u_wm = m.p;
  double phi_m = u2phi(u_wm.y);
  const double theta_m = u2theta(u_wm.x);
  if (isotropic_) phi_m += phi_o;
  const double sin_m = std::sin(theta_m);
  const Vec3 wm{sin_m * std::cos(phi_m), sin_m * std::sin(phi_m), std::cos(theta_m)};
  const double wo_wm = dot(wo, wm);
  const Vec3 wi = reflect(wo, wm);
  if (wi.z <= 0 || wo_wm <= 0) return std::nullopt;
  const double jac = 4 * wo_wm * std::max(2 * kPi * kPi * u_wm.x * sin_m, 1e-6);
  const double pdf = lum.pdf * m.pdf / jac;
  if (!(pdf > 0) || !std::isfinite(pdf)) return std::nullopt;

  SampledSpectrum f = values(lum.p, phi_o, theta_o, lambda);
  if (jacobian_) {
    const double sigma = sigma_.eval({theta2u(theta_o), phi2u(phi_o)});
    f = sigma > 0 ? f * (ndf_.eval(u_wm) / (4 * sigma * wi.z)) : SampledSpectrum(0.0);
  } else {
    f = f * (1 / wi.z);
  }
  BSDFSample bs;
  bs.f = f;
  bs.wi = wi;
  bs.pdf = pdf;
  bs.flags = BxDFFlags::Reflection | BxDFFlags::Glossy;
  return bs;
}

double RGLMeasuredBRDF::pdf(const Vec3& wo, const Vec3& wi) const {
  if (wo.z <= 0 || wi.z <= 0) return 0;
  const Vec3 wm = normalized(wo + wi);
  if (wm.z <= 0) return 0;
  const double theta_o = elevation(wo), phi_o = std::atan2(wo.y, wo.x);
  const double theta_m = elevation(wm), phi_m = std::atan2(wm.y, wm.x);
  Vec2 u_wm{theta2u(theta_m), phi2u(isotropic_ ? phi_m - phi_o : phi_m)};
  u_wm.y -= std::floor(u_wm.y);
  const double params[2] = {phi_o, theta_o};
  const PiecewiseLinear2D::Sample inv = vndf_.invert(u_wm, params);
  const double lum = luminance_.eval(inv.p, params);
  const double sin_m = std::sqrt(wm.x * wm.x + wm.y * wm.y);
  const double jac = 4 * dot(wo, wm) * std::max(2 * kPi * kPi * u_wm.x * sin_m, 1e-6);
  const double p = inv.pdf * lum / jac;
  return std::isfinite(p) && p > 0 ? p : 0;
}

SampledSpectrum RGLMeasuredBxDF::f(const Vec3& wo, const Vec3& wi, TransportMode) const {
  if (wo.z * wi.z <= 0) return {};
  return wo.z < 0 ? brdf_->f(-wo, -wi, lambda_) : brdf_->f(wo, wi, lambda_);
}

std::optional<BSDFSample> RGLMeasuredBxDF::sample_f(const Vec3& wo, double, Vec2 u, TransportMode,
                                                    ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection) || wo.z == 0) return std::nullopt;
  const bool flip = wo.z < 0;
  std::optional<BSDFSample> bs = brdf_->sample(flip ? -wo : wo, u, lambda_);
  if (bs && flip) bs->wi = -bs->wi;
  return bs;
}

double RGLMeasuredBxDF::pdf(const Vec3& wo, const Vec3& wi, TransportMode,
                            ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection) || wo.z * wi.z <= 0) return 0;
  return wo.z < 0 ? brdf_->pdf(-wo, -wi) : brdf_->pdf(wo, wi);
}

bool isRGLMeasuredFile(const std::string& path) {
  return fileStartsWith(path, std::string_view("tensor_file\0", 12));
}

}  // namespace lensim::render
