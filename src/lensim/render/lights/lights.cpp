// Light implementations. Facts from pbrt-v4 (Pharr, Jakob, Humphreys, 4th ed., ch. 12): spot
// falloff is smoothstep(cos(coneangle), cos(coneangle - conedelta), cos theta); a sphere seen
// from outside is sampled uniformly in its cone of directions; light power for "power"
// normalisation is 4 pi I (point), 2 pi I ((1 - cos_start) + (cos_start - cos_end) / 2) (spot),
// pi A L (one-sided area light); the equal-area octahedral sphere mapping is Clarberg's
// ("Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD", JGT 2008).
#include "lensim/render/lights/light_util.h"
#include "lensim/render/lights/lights.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <unordered_map>

#include "lensim/io/image.h"
#include "lensim/render/shapes/shapes.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/equal_area.h"
#include "lensim/scene/description.h"
#include "lensim/util/check.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::render {

using namespace lensim::sampling;

// The helpers declared in light_util.h.

double photometricNorm(const scene::SpectrumValue& v, const Spectrum& s) {
  if (v.kind == scene::SpectrumValue::Kind::Rgb) return 1;
  const double y = luminance(s);
  return y > 0 ? 1 / y : 0;
}

double luminanceOf(const Spectrum& s) {
  return std::max(0.0, luminance(s));
}

double uniformScale(const Transform& t) {
  const auto& m = t.matrix();
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  return std::cbrt(std::abs(det));
}

namespace {

/// The start of a sample of a light at the point pl (point, spot, goniometric and projection
/// lights): the unit direction from p toward it, pdf 1 (a delta distribution) and the light's
/// position; the caller sets L from r2, the squared distance. nullopt when p is at the light.
std::optional<LightLiSample> towardPoint(const Vec3& p, const Vec3& pl, double& r2) {
  const Vec3 d = pl - p;
  r2 = dot(d, d);
  if (r2 == 0) return std::nullopt;
  LightLiSample s;
  s.wi = d / std::sqrt(r2);
  s.pdf = 1;
  s.p_light = pl;
  return s;
}

/// Light bounds of a point emitting in every direction (pbrt-v4: cos theta_o = cos pi,
/// cos theta_e = cos pi/2).
LightBounds pointBounds(const Vec3& p, double phi) {
  LightBounds b;
  b.bounds.extend(p);
  b.phi = phi;
  b.w = {0, 0, 1};
  b.cos_theta_o = -1;
  b.cos_theta_e = 0;
  return b;
}

double smoothStep(double a, double b, double x) {
  if (a == b) return x < a ? 0 : 1;
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// ---- emission sampling of the lights pbrt-v4 samples with their own SampleLe: goniometric,
// projection (as point lights emitting in all directions), distant and infinite lights ----------

/// A ray from the point light at p, its direction uniform over the sphere; L is the intensity
/// toward d, taken from sampleLi at the point p + d (one unit away: radiance x r^2 = intensity).
std::optional<LightLeSample> uniformPointSampleLe(const Light& light, const Vec3& p, Vec2 u2,
                                                  const SampledWavelengths& lambda) {
  LightLeSample s;
  s.d = sampleUniformSphere(u2);
  s.o = p;
  auto li = light.sampleLi(p + s.d, {0.5, 0.5}, lambda);
  if (!li || li->L.isBlack()) return std::nullopt;
  s.L = li->L;
  s.pdf_pos = 1;
  s.pdf_dir = uniformSpherePdf();
  return s;
}

/// A ray from an infinite or distant light (pbrt-v4's UniformInfiniteLight::SampleLe,
/// DistantLight::SampleLe): the direction toward the light wi from sampleLi (which does not
/// depend on the point for these lights), the origin on the disk of the scene's bounding sphere
/// (centre c, radius r) perpendicular to wi, on the light's side.
std::optional<LightLeSample> infiniteSampleLe(const Light& light, const Vec3& c, double r, Vec2 u1,
                                              Vec2 u2, const SampledWavelengths& lambda) {
  auto li = light.sampleLi(c, u1, lambda);
  if (!li || !(li->pdf > 0) || li->L.isBlack()) return std::nullopt;
  const Vec3 a = std::abs(li->wi.x) > 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  const Vec3 x = normalize(cross(a, li->wi)), y = cross(li->wi, x);
  const Vec2 pd = sampleUniformDiskConcentric(u2);
  LightLeSample s;
  s.L = li->L;
  s.o = c + (li->wi + x * pd.x + y * pd.y) * r;
  s.d = -li->wi;
  s.pdf_pos = 1 / (M_PI * r * r);
  s.pdf_dir = li->pdf;  // 1 for a distant light (a delta direction)
  return s;
}

class PointLight final : public Light {
 public:
  PointLight(Vec3 p, SpectrumPtr I, double scale) : p_(p), I_(std::move(I)), scale_(scale) {}
  bool isDelta() const override { return true; }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2,
                                        const SampledWavelengths& lambda) const override {
    double r2;
    std::optional<LightLiSample> s = towardPoint(p, p_, r2);
    if (s) s->L = I_->sample(lambda) * (scale_ / r2);
    return s;
  }
  double power() const override { return 4 * M_PI * scale_ * luminanceOf(*I_); }
  const char* typeName() const override { return "point"; }
  bool supportsLe() const override { return true; }
  // pbrt-v4's PointLight::SampleLe (src/pbrt/lights.cpp): a uniform direction.
  std::optional<LightLeSample> sampleLe(Vec2, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    LightLeSample s;
    s.o = p_;
    s.d = sampleUniformSphere(u2);
    s.L = I_->sample(lambda) * scale_;
    s.pdf_pos = 1;
    s.pdf_dir = uniformSpherePdf();
    return s;
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3&, const Vec3&) const override {
    return {0, uniformSpherePdf()};
  }
  // pbrt-v4's PointLight::Bounds: the point, emitting in all directions.
  std::optional<LightBounds> bounds() const override { return pointBounds(p_, power()); }

 private:
  Vec3 p_;
  SpectrumPtr I_;
  double scale_;
};

class SpotLight final : public Light {
 public:
  SpotLight(Vec3 p, Vec3 axis, SpectrumPtr I, double scale, double cos_end, double cos_start)
      : p_(p),
        axis_(axis),
        I_(std::move(I)),
        scale_(scale),
        cos_end_(cos_end),
        cos_start_(cos_start) {}
  bool isDelta() const override { return true; }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2,
                                        const SampledWavelengths& lambda) const override {
    double r2;
    std::optional<LightLiSample> s = towardPoint(p, p_, r2);
    if (!s) return std::nullopt;
    const double f = smoothStep(cos_end_, cos_start_, dot(-s->wi, axis_));
    if (f <= 0) return std::nullopt;
    s->L = I_->sample(lambda) * (scale_ * f / r2);
    return s;
  }
  double power() const override {
    return scale_ * luminanceOf(*I_) * 2 * M_PI * ((1 - cos_start_) + (cos_start_ - cos_end_) / 2);
  }
  const char* typeName() const override { return "spot"; }
  bool supportsLe() const override { return true; }
  // A uniform direction in the cone of the falloff's end (pbrt-v4's SpotLight::SampleLe samples
  // the two parts of the cone by their power; uniform is simpler and exact).
  std::optional<LightLeSample> sampleLe(Vec2, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    const Vec3 wl = sampleUniformCone(u2, cos_end_);
    const Vec3 a = std::abs(axis_.x) > 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
    const Vec3 x = normalize(cross(a, axis_)), y = cross(axis_, x);
    LightLeSample s;
    s.o = p_;
    s.d = normalize(x * wl.x + y * wl.y + axis_ * wl.z);
    const double f = smoothStep(cos_end_, cos_start_, dot(s.d, axis_));
    if (f <= 0) return std::nullopt;
    s.L = I_->sample(lambda) * (scale_ * f);
    s.pdf_pos = 1;
    s.pdf_dir = uniformConePdf(cos_end_);
    return s;
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3&, const Vec3& d) const override {
    return {0, dot(d, axis_) >= cos_end_ ? uniformConePdf(cos_end_) : 0.0};
  }
  // pbrt-v4's SpotLight::Bounds: the cone of the full-intensity region widened by the falloff,
  // with phi = 4 pi I scale as pbrt-v4 takes it.
  std::optional<LightBounds> bounds() const override {
    LightBounds b = pointBounds(p_, 4 * M_PI * scale_ * luminanceOf(*I_));
    b.w = axis_;
    b.cos_theta_o = cos_start_;
    b.cos_theta_e = std::cos(std::acos(std::clamp(cos_end_, -1.0, 1.0)) -
                             std::acos(std::clamp(cos_start_, -1.0, 1.0)));
    return b;
  }

 private:
  Vec3 p_, axis_;
  SpectrumPtr I_;
  double scale_, cos_end_, cos_start_;
};

/// pbrt's goniometric light: a point light whose intensity is I times an image of directions
/// (light space with y and z swapped, so the image's pole is the light's +y axis): square images
/// use pbrt-v4's equal-area octahedral mapping, others pbrt-v2's latitude-longitude one.
class GoniometricLight final : public Light {
 public:
  const char* typeName() const override { return "goniometric"; }
  GoniometricLight(const scene::Light& desc, SpectrumPtr I, double scale)
      : world_from_light_(desc.transform),
        light_from_world_(inverse(desc.transform)),
        p_(desc.transform.applyPoint({0, 0, 0})),
        I_(std::move(I)),
        scale_(scale) {
    if (!desc.filename.empty()) {
      io::Image im = io::readImage(desc.filename);
      w_ = im.width;
      h_ = im.height;
      const int nc = im.channelCount();
      for (int y = 0; y < h_; ++y)
        for (int x = 0; x < w_; ++x) {
          double v = 0;
          for (int c = 0; c < std::min(nc, 3); ++c) v += im.at(x, y, c);
          values_.push_back(std::max(0.0, v / std::min(nc, 3)));
        }
      // Mean intensity factor over the sphere (lat-long texels weighted by their solid angle).
      double sum = 0, wsum = 0;
      for (int y = 0; y < h_; ++y)
        for (int x = 0; x < w_; ++x) {
          const double wt = w_ == h_ ? 1 : std::sin(M_PI * (y + 0.5) / h_);
          sum += wt * values_[size_t(y) * w_ + x];
          wsum += wt;
        }
      mean_ = wsum > 0 ? sum / wsum : 0;
    }
  }
  /// Mean of the image factor over all directions (1 without an image).
  double meanFactor() const { return mean_; }
  bool isDelta() const override { return true; }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2,
                                        const SampledWavelengths& lambda) const override {
    double r2;
    std::optional<LightLiSample> s = towardPoint(p, p_, r2);
    if (!s) return std::nullopt;
    const double f = factor(-s->wi);
    if (f <= 0) return std::nullopt;
    s->L = I_->sample(lambda) * (scale_ * f / r2);
    return s;
  }
  double power() const override { return 4 * M_PI * scale_ * luminanceOf(*I_) * mean_; }
  std::optional<LightBounds> bounds() const override { return pointBounds(p_, power()); }
  // Directions uniform over the sphere (as pbrt-v4's GoniometricLight::SampleLe).
  bool supportsLe() const override { return true; }
  std::optional<LightLeSample> sampleLe(Vec2, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    return uniformPointSampleLe(*this, p_, u2, lambda);
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3&, const Vec3&) const override {
    return {0, uniformSpherePdf()};
  }
  /// The image factor for world direction w leaving the light.
  double factor(const Vec3& w) const {
    if (values_.empty()) return 1;
    Vec3 wl = normalize(light_from_world_.applyVector(w));
    std::swap(wl.y, wl.z);
    Vec2 uv;
    if (w_ == h_) {
      uv = equalAreaSphereToSquare(wl);
    } else {
      double phi = std::atan2(wl.y, wl.x);
      if (phi < 0) phi += 2 * M_PI;
      uv = {phi / (2 * M_PI), std::acos(std::clamp(wl.z, -1.0, 1.0)) / M_PI};
    }
    const int x = std::clamp(int(uv.x * w_), 0, w_ - 1), y = std::clamp(int(uv.y * h_), 0, h_ - 1);
    return values_[size_t(y) * w_ + x];
  }

 private:
  Transform world_from_light_, light_from_world_;
  Vec3 p_;
  SpectrumPtr I_;
  double scale_;
  int w_ = 0, h_ = 0;
  std::vector<double> values_;
  double mean_ = 1;
};

/// pbrt-v4's projection light: a point light at the light-space origin projecting an image
/// through a pinhole looking down +z. The shorter image axis spans `fov`; a direction's screen
/// position (x/z, y/z) / tan(fov/2) is mapped to the image with the screen's (min x, min y) at
/// (u, v) = (0, 0) and v indexing rows from the top, as pbrt-v4 looks the image up. The texel's
/// RGB becomes an illuminant spectrum (RGB (1,1,1) is D65 of unit luminance) times "scale".
class ProjectionLight final : public Light {
 public:
  const char* typeName() const override { return "projection"; }
  ProjectionLight(const scene::Light& desc, double scale)
      : light_from_world_(inverse(desc.transform)),
        p_(desc.transform.applyPoint({0, 0, 0})),
        scale_(scale),
        tan_half_(std::tan(desc.fov_deg * M_PI / 360)) {
    io::Image im = io::readImage(desc.filename);
    w_ = im.width;
    h_ = im.height;
    const int nc = im.channelCount();
    auto ch = [&](const char* n, int f) {
      auto c = im.channelIndex(n);
      return c ? *c : std::min(f, nc - 1);
    };
    const int cr = ch("R", 0), cg = ch("G", 1), cb = ch("B", 2);
    double lum = 0;
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) {
        const Vec3 c{std::max(0.0f, im.at(x, y, cr)), std::max(0.0f, im.at(x, y, cg)),
                     std::max(0.0f, im.at(x, y, cb))};
        rgb_.push_back(c);
        lum += RGBColorSpace::sRGB().toXyz(c).y;
      }
    mean_lum_ = lum / (double(w_) * h_);
    const double aspect = double(w_) / h_;
    if (aspect > 1)
      bounds_ = {-aspect, aspect, -1, 1};
    else
      bounds_ = {-1, 1, -1 / aspect, 1 / aspect};
  }
  bool isDelta() const override { return true; }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2,
                                        const SampledWavelengths& lambda) const override {
    double r2;
    std::optional<LightLiSample> s = towardPoint(p, p_, r2);
    if (!s) return std::nullopt;
    const Vec3 wl = light_from_world_.applyVector(-s->wi);
    if (wl.z <= 0) return std::nullopt;
    const double sx = wl.x / wl.z / tan_half_, sy = wl.y / wl.z / tan_half_;
    if (sx < bounds_[0] || sx > bounds_[1] || sy < bounds_[2] || sy > bounds_[3])
      return std::nullopt;
    const double u = (sx - bounds_[0]) / (bounds_[1] - bounds_[0]);
    const double v = (sy - bounds_[2]) / (bounds_[3] - bounds_[2]);
    const int x = std::clamp(int(u * w_), 0, w_ - 1), y = std::clamp(int(v * h_), 0, h_ - 1);
    const Vec3 c = rgb_[size_t(y) * w_ + x];
    const double m = std::max({c.x, c.y, c.z});
    if (m <= 0) return std::nullopt;
    const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(c / (2 * m));
    const SampledSpectrum illum = RGBColorSpace::sRGB().illuminant()->sample(lambda);
    s->L = poly.sample(lambda) * (2 * m);
    s->L *= illum * (scale_ / r2);
    return s;
  }
  double power() const override {
    // The projected image's mean luminance over the solid angle of the frustum (approximate).
    const double area =
        (bounds_[1] - bounds_[0]) * (bounds_[3] - bounds_[2]) * tan_half_ * tan_half_;
    return scale_ * mean_lum_ * area;
  }
  // Conservatively all directions (pbrt-v4 bounds the frustum; this only costs noise).
  std::optional<LightBounds> bounds() const override { return pointBounds(p_, power()); }
  // Directions uniform over the sphere (pbrt-v4 samples the projected image; this only costs
  // noise: directions outside the frustum carry nothing).
  bool supportsLe() const override { return true; }
  std::optional<LightLeSample> sampleLe(Vec2, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    return uniformPointSampleLe(*this, p_, u2, lambda);
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3&, const Vec3&) const override {
    return {0, uniformSpherePdf()};
  }

 private:
  Transform light_from_world_;
  Vec3 p_;
  double scale_, tan_half_;
  int w_ = 0, h_ = 0;
  std::vector<Vec3> rgb_;
  double mean_lum_ = 0;
  std::array<double, 4> bounds_{};
};

class DistantLight final : public Light {
 public:
  const char* typeName() const override { return "distant"; }
  DistantLight(Vec3 w, SpectrumPtr L, double scale, double scene_radius, Vec3 scene_centre)
      : w_(w), L_(std::move(L)), scale_(scale), radius_(scene_radius), centre_(scene_centre) {}
  bool isDelta() const override { return true; }
  bool isDeltaDirection() const override { return true; }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2,
                                        const SampledWavelengths& lambda) const override {
    LightLiSample s;
    s.wi = w_;
    s.L = L_->sample(lambda) * scale_;
    s.pdf = 1;
    s.p_light = p + w_ * (2 * radius_);
    s.infinite = true;
    return s;
  }
  double power() const override { return scale_ * luminanceOf(*L_) * M_PI * radius_ * radius_; }
  bool supportsLe() const override { return true; }
  std::optional<LightLeSample> sampleLe(Vec2 u1, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    return infiniteSampleLe(*this, centre_, radius_, u1, u2, lambda);
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3&, const Vec3&) const override {
    return {1 / (M_PI * radius_ * radius_), 0};
  }

 private:
  Vec3 w_;
  SpectrumPtr L_;
  double scale_, radius_;
  Vec3 centre_;
};

class UniformInfiniteLight final : public Light {
 public:
  const char* typeName() const override { return "infinite (uniform)"; }
  UniformInfiniteLight(SpectrumPtr L, double scale, double scene_radius, Vec3 scene_centre)
      : L_(std::move(L)), scale_(scale), radius_(scene_radius), centre_(scene_centre) {}
  bool isInfinite() const override { return true; }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2 u,
                                        const SampledWavelengths& lambda) const override {
    LightLiSample s;
    s.wi = sampleUniformSphere(u);
    s.L = L_->sample(lambda) * scale_;
    s.pdf = uniformSpherePdf();
    s.p_light = p + s.wi * (2 * radius_);
    s.infinite = true;
    return s;
  }
  double pdfLi(const Vec3&, const Vec3&, const SurfaceHit*) const override {
    return uniformSpherePdf();
  }
  SampledSpectrum Le(const Vec3&, const SampledWavelengths& lambda) const override {
    return L_->sample(lambda) * scale_;
  }
  double power() const override {
    return 4 * M_PI * M_PI * radius_ * radius_ * scale_ * luminanceOf(*L_);
  }
  bool supportsLe() const override { return true; }
  std::optional<LightLeSample> sampleLe(Vec2 u1, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    return infiniteSampleLe(*this, centre_, radius_, u1, u2, lambda);
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3&, const Vec3& d) const override {
    return {1 / (M_PI * radius_ * radius_), pdfLi(centre_, -d, nullptr)};
  }

 private:
  SpectrumPtr L_;
  double scale_, radius_;
  Vec3 centre_;
};

// ---- environment maps ----------------------------------------------------------------------

class ImageInfiniteLight final : public Light {
 public:
  const char* typeName() const override { return "infinite (image)"; }
  ImageInfiniteLight(const scene::Light& desc, double scale, double scene_radius, Vec3 scene_centre)
      : world_from_light_(desc.transform),
        light_from_world_(inverse(desc.transform)),
        scale_(scale),
        radius_(scene_radius),
        centre_(scene_centre) {
    io::Image im = io::readImage(desc.filename);
    w_ = im.width;
    h_ = im.height;
    equal_area_ = w_ == h_;
    const int nc = im.channelCount();
    auto ch = [&](const char* n, int f) {
      auto c = im.channelIndex(n);
      return c ? *c : std::min(f, nc - 1);
    };
    const int cr = ch("R", 0), cg = ch("G", 1), cb = ch("B", 2);
    rgb_.resize(size_t(w_) * h_);
    std::vector<double> weight(size_t(w_) * h_);
    const RGBColorSpace& cs = RGBColorSpace::sRGB();
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) {
        const Vec3 c{std::max(0.0f, im.at(x, y, cr)), std::max(0.0f, im.at(x, y, cg)),
                     std::max(0.0f, im.at(x, y, cb))};
        rgb_[size_t(y) * w_ + x] = c;
        double lum = cs.toXyz(c).y;
        // Latitude-longitude texels shrink toward the poles: weight by sin(theta).
        if (!equal_area_) lum *= std::sin(M_PI * (y + 0.5) / h_);
        weight[size_t(y) * w_ + x] = lum + 1e-3 * (lum == 0);
        avg_lum_ += cs.toXyz(c).y / (double(w_) * h_);
      }
    dist_ = PiecewiseConstant2D(weight, w_, h_);
  }
  bool isInfinite() const override { return true; }

  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2 u,
                                        const SampledWavelengths& lambda) const override {
    const auto s = dist_.sample(u);
    if (s.pdf == 0) return std::nullopt;
    Vec3 wl;
    double pdf;
    if (equal_area_) {
      wl = equalAreaSquareToSphere(s.p);
      pdf = s.pdf / (4 * M_PI);
    } else {
      const double theta = s.p.y * M_PI, phi = s.p.x * 2 * M_PI;
      const double st = std::sin(theta);
      if (st == 0) return std::nullopt;
      wl = {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
      pdf = s.pdf / (2 * M_PI * M_PI * st);
    }
    LightLiSample ls;
    ls.wi = normalize(world_from_light_.applyVector(wl));
    ls.L = lookup(s.p, lambda);
    ls.pdf = pdf;
    ls.p_light = p + ls.wi * (2 * radius_);
    ls.infinite = true;
    return ls;
  }
  double pdfLi(const Vec3&, const Vec3& wi, const SurfaceHit*) const override {
    const Vec3 wl = normalize(light_from_world_.applyVector(wi));
    if (equal_area_) return dist_.pdf(equalAreaSphereToSquare(wl)) / (4 * M_PI);
    const double theta = std::acos(std::clamp(wl.z, -1.0, 1.0));
    const double st = std::sin(theta);
    if (st == 0) return 0;
    return dist_.pdf(latLong(wl)) / (2 * M_PI * M_PI * st);
  }
  SampledSpectrum Le(const Vec3& dir, const SampledWavelengths& lambda) const override {
    const Vec3 wl = normalize(light_from_world_.applyVector(dir));
    return lookup(equal_area_ ? equalAreaSphereToSquare(wl) : latLong(wl), lambda);
  }
  double power() const override { return 4 * M_PI * M_PI * radius_ * radius_ * scale_ * avg_lum_; }
  bool supportsLe() const override { return true; }
  std::optional<LightLeSample> sampleLe(Vec2 u1, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    return infiniteSampleLe(*this, centre_, radius_, u1, u2, lambda);
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3&, const Vec3& d) const override {
    return {1 / (M_PI * radius_ * radius_), pdfLi(centre_, -d, nullptr)};
  }

 private:
  static Vec2 latLong(const Vec3& wl) {
    double phi = std::atan2(wl.y, wl.x);
    if (phi < 0) phi += 2 * M_PI;
    return {phi / (2 * M_PI), std::acos(std::clamp(wl.z, -1.0, 1.0)) / M_PI};
  }
  SampledSpectrum lookup(Vec2 uv, const SampledWavelengths& lambda) const {
    const int x = std::clamp(int(uv.x * w_), 0, w_ - 1), y = std::clamp(int(uv.y * h_), 0, h_ - 1);
    Vec3 c = rgb_[size_t(y) * w_ + x];
    const double m = std::max({c.x, c.y, c.z});
    if (m <= 0) return {};
    const double sc = 2 * m;
    const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(c / sc);
    const SampledSpectrum illum = RGBColorSpace::sRGB().illuminant()->sample(lambda);
    return poly.sample(lambda) * sc * illum * scale_;
  }
  Transform world_from_light_, light_from_world_;
  double scale_, radius_;
  Vec3 centre_;
  int w_ = 0, h_ = 0;
  bool equal_area_ = true;
  std::vector<Vec3> rgb_;
  PiecewiseConstant2D dist_;
  double avg_lum_ = 0;
};

}  // namespace

/// Adds the light `l` (a type other than "diffuse", whose lights belong to shapes, see
/// addAreaLights); radius and centre bound the scene (distant and infinite lights emit from a
/// disk of that sphere).
void LightSet::addLight(const scene::Light& l, const Textures& textures, double radius,
                        const Vec3& centre) {
  const bool rgb = l.emission.kind == scene::SpectrumValue::Kind::Rgb;
  SpectrumPtr spec =
      textures.constant(l.emission, rgb ? SpectrumType::Illuminant : SpectrumType::Unbounded);
  double scale = l.scale * photometricNorm(l.emission, *spec);
  if (l.type == "point") {
    if (l.power && *l.power > 0) scale *= *l.power / (4 * M_PI);
    lights_.push_back(std::make_unique<PointLight>(l.transform.applyPoint(l.from), spec, scale));
  } else if (l.type == "spot") {
    const double cos_end = std::cos(l.cone_angle_deg * M_PI / 180);
    const double cos_start = std::cos((l.cone_angle_deg - l.cone_delta_deg) * M_PI / 180);
    if (l.power && *l.power > 0)
      scale *= *l.power / (2 * M_PI * ((1 - cos_start) + (cos_start - cos_end) / 2));
    lights_.push_back(std::make_unique<SpotLight>(
        l.transform.applyPoint(l.from), normalize(l.transform.applyVector(l.to - l.from)), spec,
        scale, cos_end, cos_start));
  } else if (l.type == "projection") {
    if (l.power)
      logWarning(fmt::format("{}: projection light \"power\" is not applied; \"scale\" is",
                             l.loc.str()));
    try {
      lights_.push_back(std::make_unique<ProjectionLight>(l, l.scale));
    } catch (const Error& e) {
      throw Error(l.loc, nestedMessage(e));
    }
  } else if (l.type == "goniometric") {
    std::unique_ptr<GoniometricLight> g;
    try {
      g = std::make_unique<GoniometricLight>(l, spec, scale);
    } catch (const Error& e) {
      throw Error(l.loc, nestedMessage(e));
    }
    if (l.power && *l.power > 0 && g->meanFactor() > 0)
      g = std::make_unique<GoniometricLight>(l, spec,
                                             scale * *l.power / (4 * M_PI * g->meanFactor()));
    lights_.push_back(std::move(g));
  } else if (l.type == "distant") {
    if (l.power && *l.power > 0) scale *= *l.power;
    lights_.push_back(std::make_unique<DistantLight>(
        normalize(l.transform.applyVector(l.from - l.to)), spec, scale, radius, centre));
  } else if (l.type == "infinite") {
    if (!l.filename.empty()) {
      try {
        lights_.push_back(std::make_unique<ImageInfiniteLight>(l, l.scale, radius, centre));
      } catch (const Error& e) {
        throw Error(l.loc, nestedMessage(e));
      }
    } else {
      // pbrt-v4 "illuminance": the irradiance E at an upward-facing point, pi L for a
      // uniform sky.
      if (l.power && *l.power > 0) scale *= *l.power / M_PI;
      lights_.push_back(std::make_unique<UniformInfiniteLight>(spec, scale, radius, centre));
    }
    infinite_.push_back(lights_.back().get());
  }
}

LightSet::LightSet(const scene::Scene& scene, const Accel& accel, const Textures& textures) {
  const Bounds3 b = accel.bounds();
  double radius = 1;
  if (!b.empty()) radius = std::max(1e-3, 0.5 * length(b.max - b.min));
  const Vec3 centre = b.empty() ? Vec3{0, 0, 0} : (b.min + b.max) * 0.5;
  for (const scene::Light& l : scene.lights) {
    if (l.type == "diffuse") continue;  // attached to shapes below
    const size_t first_light = lights_.size();
    addLight(l, textures, radius, centre);
    for (size_t i = first_light; i < lights_.size(); ++i) lights_[i]->n_samples = l.n_samples;
    if (lights_.size() > first_light) lights_.back()->medium = l.medium;
  }
  addAreaLights(scene, accel, textures);
  for (size_t si = 0; si < scene.shapes.size(); ++si) {
    const int first = shape_first_light_[si];
    if (first < 0) continue;
    for (size_t i = size_t(first); i < lights_.size() && lights_[i]->shape < 0; ++i)
      lights_[i]->shape = int(si);
  }
  std::vector<const Light*> all;
  for (size_t i = 0; i < lights_.size(); ++i) {
    lights_[i]->index = int(i);
    all.push_back(lights_[i].get());
  }
  sampler_name_ = scene.integrator.light_sampler;
  sampler_ = LightSampler::create(sampler_name_, all);
}

LightSet::~LightSet() = default;

const Light* LightSet::areaLight(int shape, int prim) const {
  if (shape < 0 || size_t(shape) >= shape_first_light_.size()) return nullptr;
  const int first = shape_first_light_[size_t(shape)];
  if (first < 0) return nullptr;
  // Meshes: one light per face, in face order.
  const size_t i = size_t(first) + size_t(prim);
  return i < lights_.size() ? lights_[i].get() : nullptr;
}

std::optional<LightSet::Choice> LightSet::sample(const LightSampleContext& ctx, double u) const {
  auto s = sampler_->sample(ctx, u);
  if (!s || s->pmf <= 0) return std::nullopt;
  // A light of this set, chosen with a probability.
  LENSIM_DCHECK_GE(s->light->index, 0);
  LENSIM_DCHECK_LT(size_t(s->light->index), lights_.size());
  LENSIM_DCHECK_LE(s->pmf, 1 + 1e-9);
  return Choice{s->light, s->pmf};
}

double LightSet::pmf(const LightSampleContext& ctx, const Light* light) const {
  return sampler_->pmf(ctx, light);
}

}  // namespace lensim::render
