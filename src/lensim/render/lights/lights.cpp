// Light implementations. Facts from pbrt-v4 (Pharr, Jakob, Humphreys, 4th ed., ch. 12): spot
// falloff is smoothstep(cos(coneangle), cos(coneangle - conedelta), cos theta); a sphere seen
// from outside is sampled uniformly in its cone of directions; light power for "power"
// normalisation is 4 pi I (point), 2 pi I ((1 - cos_start) + (cos_start - cos_end) / 2) (spot),
// pi A L (one-sided area light); the equal-area octahedral sphere mapping is Clarberg's
// ("Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD", JGT 2008).
#include "lensim/render/lights/lights.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <unordered_map>

#include "lensim/io/image.h"
#include "lensim/render/shapes/shapes.h"
#include "lensim/render/textures/textures.h"
#include "lensim/sampling/equal_area.h"
#include "lensim/scene/builder.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::render {

namespace {

/// The factor pbrt-v4 applies to an emission spectrum: 1 / its luminance, except RGB values
/// (their D65 illuminant has unit luminance and the RGB magnitude is kept).
double photometricNorm(const scene::SpectrumValue& v, const Spectrum& s) {
  if (v.kind == scene::SpectrumValue::Kind::Rgb) return 1;
  const double y = luminance(s);
  return y > 0 ? 1 / y : 0;
}

/// Luminance Y of the emitted spectrum times the light's scale (for power computations).
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
    for (int i = 0; i < kSpectrumSamples; ++i) s->L[i] = 2 * m * poly.eval(lambda.lambda(i));
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
    SampledSpectrum s;
    for (int i = 0; i < kSpectrumSamples; ++i) s[i] = sc * poly.eval(lambda.lambda(i));
    return s * illum * scale_;
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

// ---- area lights ---------------------------------------------------------------------------

/// The image of an image area light ("filename"): RGB texels, looked up at the surface's (u, v)
/// with v flipped (row 0 is the top, as pbrt-v4 does), nearest texel, repeat wrap.
struct EmissionImage {
  int w = 0, h = 0;
  std::vector<Vec3> rgb;
  double mean_luminance = 0;

  explicit EmissionImage(const std::string& path) {
    io::Image im = io::readImage(path);
    w = im.width;
    h = im.height;
    const int nc = im.channelCount();
    auto ch = [&](const char* n, int f) {
      auto c = im.channelIndex(n);
      return c ? *c : std::min(f, nc - 1);
    };
    const int cr = ch("R", 0), cg = ch("G", 1), cb = ch("B", 2);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Vec3 c{std::max(0.0f, im.at(x, y, cr)), std::max(0.0f, im.at(x, y, cg)),
                     std::max(0.0f, im.at(x, y, cb))};
        rgb.push_back(c);
        mean_luminance += RGBColorSpace::sRGB().toXyz(c).y / (double(w) * h);
      }
  }
  SampledSpectrum lookup(Vec2 uv, const SampledWavelengths& lambda) const {
    int x = int(std::floor(uv.x * w)), y = int(std::floor((1 - uv.y) * h));
    x = ((x % w) + w) % w;
    y = ((y % h) + h) % h;
    const Vec3 c = rgb[size_t(y) * size_t(w) + size_t(x)];
    const double m = std::max({c.x, c.y, c.z});
    if (m <= 0) return {};
    const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(c / (2 * m));
    SampledSpectrum s;
    for (int i = 0; i < kSpectrumSamples; ++i) s[i] = 2 * m * poly.eval(lambda.lambda(i));
    return s * RGBColorSpace::sRGB().illuminant()->sample(lambda);
  }
};

class AreaLightBase : public Light {
 public:
  AreaLightBase(SpectrumPtr L, double scale, bool two_sided)
      : L_(std::move(L)), scale_(scale), two_sided_(two_sided) {}
  void setImage(std::shared_ptr<const EmissionImage> image) { image_ = std::move(image); }
  SampledSpectrum L(const SurfaceHit& hit, const Vec3& w,
                    const SampledWavelengths& lambda) const override {
    if (!two_sided_ && dot(hit.ng, w) < 0) return {};
    if (image_) return image_->lookup(hit.uv, lambda) * scale_;
    return L_->sample(lambda) * scale_;
  }
  double power() const override {
    const double lum = image_ ? image_->mean_luminance : luminanceOf(*L_);
    return scale_ * lum * area() * M_PI * (two_sided_ ? 2 : 1);
  }
  virtual double area() const = 0;
  bool supportsLe() const override { return true; }
  // pbrt-v4's DiffuseAreaLight::SampleLe: a point by area, a cosine-weighted direction about
  // the emitting side's normal (a two-sided light picks a side with probability 1/2).
  std::optional<LightLeSample> sampleLe(Vec2 u1, Vec2 u2,
                                        const SampledWavelengths& lambda) const override {
    Vec3 pl, nl;
    Vec2 uv;
    if (!samplePoint(u1, pl, nl, uv)) return std::nullopt;
    double side = 1;
    if (two_sided_) {
      side = u2.x < 0.5 ? 1 : -1;
      u2.x = u2.x < 0.5 ? 2 * u2.x : 2 * u2.x - 1;
      u2.x = std::min(u2.x, 1.0 - 1e-12);
    }
    const Vec3 wl = sampleCosineHemisphere(u2);
    if (wl.z <= 0) return std::nullopt;
    const Vec3 n = nl * side;
    const Vec3 a = std::abs(n.x) > 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
    const Vec3 x = normalize(cross(a, n)), y = cross(n, x);
    LightLeSample s;
    s.o = pl;
    s.d = normalize(x * wl.x + y * wl.y + n * wl.z);
    s.n = nl;
    s.uv = uv;
    s.on_surface = true;
    SurfaceHit h;
    h.ng = nl;
    h.uv = uv;
    s.L = L(h, s.d, lambda);
    if (s.L.isBlack()) return std::nullopt;
    s.pdf_pos = 1 / area();
    s.pdf_dir = cosineHemispherePdf(wl.z) * (two_sided_ ? 0.5 : 1.0);
    return s;
  }
  std::pair<double, double> pdfLe(const Vec3&, const Vec3& n, const Vec3& d) const override {
    const double c = dot(n, d);
    if (!two_sided_ && c <= 0) return {1 / area(), 0};
    return {1 / area(), cosineHemispherePdf(std::abs(c)) * (two_sided_ ? 0.5 : 1.0)};
  }
  /// A point drawn uniformly by area (world), its normal (the emitting side) and surface (u, v).
  virtual bool samplePoint(Vec2 u, Vec3& p, Vec3& n, Vec2& uv) const = 0;

 protected:
  /// Converts an area sample (point pl, normal nl, surface (u, v), area pdf) into a solid-angle
  /// sample at p.
  std::optional<LightLiSample> finish(const Vec3& p, const Vec3& pl, const Vec3& nl, Vec2 uv,
                                      double pdf_area, const SampledWavelengths& lambda) const {
    const Vec3 d = pl - p;
    const double r2 = dot(d, d);
    if (r2 == 0) return std::nullopt;
    LightLiSample s;
    s.wi = d / std::sqrt(r2);
    const double cos_l = std::abs(dot(nl, s.wi));
    if (cos_l == 0) return std::nullopt;
    s.pdf = pdf_area * r2 / cos_l;
    s.n_light = nl;
    SurfaceHit h;
    h.ng = nl;
    h.uv = uv;
    s.L = L(h, -s.wi, lambda);
    if (s.L.isBlack()) return std::nullopt;
    s.p_light = pl;
    return s;
  }
  double solidAnglePdf(const Vec3& p, const Vec3& wi, const SurfaceHit& hit) const {
    const Vec3 d = hit.p - p;
    const double cos_l = std::abs(dot(hit.ng, wi));
    if (cos_l == 0) return 0;
    return dot(d, d) / (cos_l * area());
  }
  SpectrumPtr L_;
  double scale_;
  bool two_sided_;
  std::shared_ptr<const EmissionImage> image_;
};

/// A planar face: one triangle, or a bilinear patch as two triangles, sampled uniformly by area.
class FaceLight final : public AreaLightBase {
 public:
  FaceLight(std::vector<std::array<Vec3, 3>> tris, std::vector<std::array<Vec2, 3>> uvs, Vec3 n,
            SpectrumPtr L, double scale, bool two_sided)
      : AreaLightBase(std::move(L), scale, two_sided),
        tris_(std::move(tris)),
        uvs_(std::move(uvs)),
        n_(n) {
    for (const auto& t : tris_) {
      const Vec3 c = cross(t[1] - t[0], t[2] - t[0]);
      area_ += 0.5 * length(c);
      cum_.push_back(area_);
      Vec3 nt = length(c) > 0 ? normalize(c) : n_;
      normals_.push_back(dot(nt, n_) < 0 ? -nt : nt);
    }
  }
  double area() const override { return area_; }
  const char* typeName() const override { return "area"; }
  bool samplePoint(Vec2 u, Vec3& p, Vec3& n, Vec2& uv) const override {
    if (area_ == 0) return false;
    size_t k = 0;
    if (tris_.size() > 1) {
      const double x = u.x * area_;
      k = x < cum_[0] ? 0 : 1;
      u.x = k == 0 ? x / cum_[0] : (x - cum_[0]) / (area_ - cum_[0]);
      u.x = std::clamp(u.x, 0.0, 1.0 - 1e-12);
    }
    const auto& t = tris_[k];
    const double su = std::sqrt(u.x);
    const double b0 = 1 - su, b1 = u.y * su;
    p = t[0] * b0 + t[1] * b1 + t[2] * (1 - b0 - b1);
    const auto& tuv = uvs_[k];
    uv = tuv[0] * b0 + tuv[1] * b1 + tuv[2] * (1 - b0 - b1);
    n = normals_[k];
    return true;
  }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2 u,
                                        const SampledWavelengths& lambda) const override {
    if (area_ == 0) return std::nullopt;
    size_t k = 0;
    if (tris_.size() > 1) {
      const double x = u.x * area_;
      k = x < cum_[0] ? 0 : 1;
      u.x = k == 0 ? x / cum_[0] : (x - cum_[0]) / (area_ - cum_[0]);
      u.x = std::clamp(u.x, 0.0, 1.0 - 1e-12);
    }
    const auto& t = tris_[k];
    const double su = std::sqrt(u.x);
    const double b0 = 1 - su, b1 = u.y * su;
    const Vec3 pl = t[0] * b0 + t[1] * b1 + t[2] * (1 - b0 - b1);
    const auto& tuv = uvs_[k];
    const Vec2 uv = tuv[0] * b0 + tuv[1] * b1 + tuv[2] * (1 - b0 - b1);
    return finish(p, pl, normals_[k], uv, 1 / area_, lambda);
  }
  double pdfLi(const Vec3& p, const Vec3& wi, const SurfaceHit* hit) const override {
    return hit ? solidAnglePdf(p, wi, *hit) : 0;
  }
  // pbrt-v4's DiffuseAreaLight::Bounds with a triangle's normal bounds: the face's box, its
  // normal (a cone holding both triangles of a non-planar patch), emission to 90 degrees.
  std::optional<LightBounds> bounds() const override {
    LightBounds b;
    for (const auto& t : tris_)
      for (const Vec3& v : t) b.bounds.extend(v);
    b.phi = power();
    b.w = n_;
    b.cos_theta_o = 1;
    for (const Vec3& n : normals_) b.cos_theta_o = std::min(b.cos_theta_o, dot(n, n_));
    b.cos_theta_e = 0;
    b.two_sided = two_sided_;
    return b;
  }

 private:
  std::vector<std::array<Vec3, 3>> tris_;
  std::vector<std::array<Vec2, 3>> uvs_;  ///< per triangle: the surface (u, v) of its vertices
  std::vector<double> cum_;
  std::vector<Vec3> normals_;  ///< per triangle, on the side of n_
  Vec3 n_;
  double area_ = 0;
};

/// A quadric area light: spheres seen from outside are sampled by cone, everything else by area.
class QuadricLight final : public AreaLightBase {
 public:
  QuadricLight(const scene::Shape& shape, SpectrumPtr L, double scale, bool two_sided)
      : AreaLightBase(std::move(L), scale, two_sided),
        shape_(&shape),
        s_(uniformScale(shape.transform)) {
    area_ = quadricArea(shape) * s_ * s_;
    full_sphere_ = shape.type == scene::ShapeType::Sphere && shape.phimax_deg >= 360 &&
                   shape.zmin <= -shape.radius && shape.zmax >= shape.radius;
    center_ = shape.transform.applyPoint({0, 0, 0});
    radius_ = shape.radius * s_;
  }
  double area() const override { return area_; }
  const char* typeName() const override { return "area"; }
  bool samplePoint(Vec2 u, Vec3& p, Vec3& n, Vec2& uv) const override {
    auto g = sampleQuadricArea(*shape_, u);
    if (!g) return false;
    p = shape_->transform.applyPoint(g->p);
    n = normalize(shape_->transform.applyNormal(g->n));
    if (shape_->flipNormals()) n = -n;
    uv = g->uv;
    return true;
  }
  std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2 u,
                                        const SampledWavelengths& lambda) const override {
    if (full_sphere_) {
      const Vec3 dc = center_ - p;
      const double dist2 = dot(dc, dc);
      if (dist2 > radius_ * radius_ * 1.0001) {
        const double dist = std::sqrt(dist2);
        const double sin2 = radius_ * radius_ / dist2;
        const double cos_max = std::sqrt(std::max(0.0, 1 - sin2));
        const Vec3 z = dc / dist;
        const Vec3 a = std::abs(z.x) > 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
        const Vec3 x = normalize(cross(a, z)), y = cross(z, x);
        const Vec3 wl = sampleUniformCone(u, cos_max);
        const Vec3 wi = normalize(x * wl.x + y * wl.y + z * wl.z);
        // Nearest intersection of the ray p + t wi with the sphere (clamped at tangency).
        const double b = dot(wi, dc);
        const double disc = std::max(0.0, b * b - (dist2 - radius_ * radius_));
        const double t = b - std::sqrt(disc);
        const Vec3 pl = p + wi * t;
        LightLiSample s;
        s.wi = wi;
        s.pdf = uniformConePdf(cos_max);
        SurfaceHit h;
        h.ng = normalize(pl - center_);
        if (shape_->flipNormals()) h.ng = -h.ng;
        s.n_light = h.ng;
        if (image_) h.uv = quadricGeometry(*shape_, inverse(shape_->transform).applyPoint(pl)).uv;
        s.L = L(h, -wi, lambda);
        if (s.L.isBlack()) return std::nullopt;
        s.p_light = pl;
        return s;
      }
    }
    auto g = sampleQuadricArea(*shape_, u);
    if (!g) return std::nullopt;
    const Vec3 pl = shape_->transform.applyPoint(g->p);
    Vec3 nl = normalize(shape_->transform.applyNormal(g->n));
    if (shape_->flipNormals()) nl = -nl;
    return finish(p, pl, nl, g->uv, 1 / area_, lambda);
  }
  void setWorldBounds(const Bounds3& b) { world_bounds_ = b; }
  // pbrt-v4's DiffuseAreaLight::Bounds with the shape's normal bounds: a disk's normal, every
  // direction for curved quadrics.
  std::optional<LightBounds> bounds() const override {
    LightBounds b;
    b.bounds = world_bounds_;
    b.phi = power();
    b.cos_theta_o = -1;
    b.cos_theta_e = 0;
    b.two_sided = two_sided_;
    if (shape_->type == scene::ShapeType::Disk) {
      if (auto g = sampleQuadricArea(*shape_, {0.5, 0.5})) {
        Vec3 nl = normalize(shape_->transform.applyNormal(g->n));
        if (shape_->flipNormals()) nl = -nl;
        b.w = nl;
        b.cos_theta_o = 1;
      }
    }
    return b;
  }
  double pdfLi(const Vec3& p, const Vec3& wi, const SurfaceHit* hit) const override {
    if (full_sphere_) {
      const Vec3 dc = center_ - p;
      const double dist2 = dot(dc, dc);
      if (dist2 > radius_ * radius_ * 1.0001) {
        const double cos_max = std::sqrt(std::max(0.0, 1 - radius_ * radius_ / dist2));
        return uniformConePdf(cos_max);
      }
    }
    return hit ? solidAnglePdf(p, wi, *hit) : 0;
  }

 private:
  const scene::Shape* shape_;
  double s_, area_ = 0, radius_ = 0;
  bool full_sphere_ = false;
  Vec3 center_;
  Bounds3 world_bounds_;
};

}  // namespace

LightSet::LightSet(const scene::Scene& scene, const Accel& accel, const Textures& textures) {
  const Bounds3 b = accel.bounds();
  double radius = 1;
  if (!b.empty()) radius = std::max(1e-3, 0.5 * length(b.max - b.min));
  const Vec3 centre = b.empty() ? Vec3{0, 0, 0} : (b.min + b.max) * 0.5;
  for (const scene::Light& l : scene.lights) {
    if (l.type == "diffuse") continue;  // attached to shapes below
    const size_t first_light = lights_.size();
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
    for (size_t i = first_light; i < lights_.size(); ++i) lights_[i]->n_samples = l.n_samples;
    if (lights_.size() > first_light) lights_.back()->medium = l.medium;
  }
  // Area lights: one light per triangle / patch, one per quadric.
  shape_first_light_.assign(scene.shapes.size(), -1);
  for (size_t si = 0; si < scene.shapes.size(); ++si) {
    const scene::Shape& s = scene.shapes[si];
    if (s.area_light < 0 || s.object >= 0) continue;
    const scene::Light& l = scene.lights[size_t(s.area_light)];
    const bool rgb = l.emission.kind == scene::SpectrumValue::Kind::Rgb;
    SpectrumPtr spec =
        textures.constant(l.emission, rgb ? SpectrumType::Illuminant : SpectrumType::Unbounded);
    std::shared_ptr<const EmissionImage> image;
    if (!l.filename.empty()) {
      try {
        image = std::make_shared<EmissionImage>(l.filename);
      } catch (const Error& e) {
        throw Error(l.loc, nestedMessage(e));
      }
    }
    // pbrt-v4: an image light's texels are RGB illuminants (D65 of unit luminance for white).
    const double base_scale = l.scale * (image ? 1.0 : photometricNorm(l.emission, *spec));
    const double k_e = image ? image->mean_luminance : 1.0;
    const double sides = l.two_sided ? 2 : 1;
    shape_first_light_[si] = static_cast<int>(lights_.size());
    if (const WorldMesh* m = accel.worldMesh(static_cast<int>(si))) {
      const size_t fv = size_t(m->vertices_per_face);
      for (size_t f = 0; f < m->indices.size() / fv; ++f) {
        std::vector<Vec3> q;
        for (size_t k = 0; k < fv; ++k) q.push_back(m->p[size_t(m->indices[f * fv + k])]);
        auto normal = [&](Vec3 a, Vec3 bb, Vec3 c, const std::vector<int>& vi) {
          Vec3 n = cross(a - c, bb - c);
          n = length(n) > 0 ? normalize(n) : Vec3{0, 0, 1};
          if (!m->n.empty()) {
            Vec3 ns{0, 0, 0};
            for (int i : vi) ns += m->n[size_t(m->indices[f * fv + size_t(i)])];
            if (dot(n, ns) < 0) n = -n;
          } else if (m->flip) {
            n = -n;
          }
          return n;
        };
        std::vector<Vec2> quv(fv);
        for (size_t k = 0; k < fv; ++k)
          quv[k] = m->uv.empty()
                       ? (fv == 3 ? std::array<Vec2, 3>{Vec2{0, 0}, Vec2{1, 0}, Vec2{1, 1}}[k]
                                  : std::array<Vec2, 4>{Vec2{0, 0}, Vec2{1, 0}, Vec2{0, 1},
                                                        Vec2{1, 1}}[k])
                       : m->uv[size_t(m->indices[f * fv + k])];
        auto add = [&](std::vector<std::array<Vec3, 3>> tris, std::vector<std::array<Vec2, 3>> uvs,
                       Vec3 n) {
          double area = 0;
          for (const auto& t : tris) area += 0.5 * length(cross(t[1] - t[0], t[2] - t[0]));
          double scale = base_scale;
          if (l.power && *l.power > 0 && area > 0 && k_e > 0)
            scale *= *l.power / (k_e * sides * area * M_PI);
          auto light = std::make_unique<FaceLight>(std::move(tris), std::move(uvs), n, spec, scale,
                                                   l.two_sided);
          light->setImage(image);
          lights_.push_back(std::move(light));
        };
        if (fv == 3) {
          add({{q[0], q[1], q[2]}}, {{quv[0], quv[1], quv[2]}},
              normal(q[0], q[1], q[2], {0, 1, 2}));
        } else {
          // A bilinear patch p00 p10 p01 p11 as the two triangles Embree intersects (split along
          // p10-p01), oriented by the patch normal cross(dp/du, dp/dv).
          Vec3 n = cross(q[1] - q[0], q[2] - q[0]);
          n = length(n) > 0 ? normalize(n) : Vec3{0, 0, 1};
          if (m->flip) n = -n;
          add({{q[0], q[1], q[2]}, {q[3], q[2], q[1]}},
              {{quv[0], quv[1], quv[2]}, {quv[3], quv[2], quv[1]}}, n);
        }
      }
    } else if (s.type != scene::ShapeType::TriangleMesh &&
               s.type != scene::ShapeType::BilinearMesh) {
      const double area = quadricArea(s) * std::pow(uniformScale(s.transform), 2);
      double scale = base_scale;
      if (l.power && *l.power > 0 && area > 0 && k_e > 0)
        scale *= *l.power / (k_e * sides * area * M_PI);
      auto light = std::make_unique<QuadricLight>(s, spec, scale, l.two_sided);
      light->setImage(image);
      light->setWorldBounds(s.transform.applyBounds(scene::objectBounds(scene, s)));
      lights_.push_back(std::move(light));
    }
    for (size_t i = size_t(shape_first_light_[si]); i < lights_.size(); ++i)
      lights_[i]->n_samples = l.n_samples;
  }
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
  return Choice{s->light, s->pmf};
}

double LightSet::pmf(const LightSampleContext& ctx, const Light* light) const {
  return sampler_->pmf(ctx, light);
}

}  // namespace lensim::render
