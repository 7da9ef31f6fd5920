// Diffuse area lights (pbrt-v4's DiffuseAreaLight): one light per triangle or bilinear patch of a
// mesh, one per quadric, each sampled uniformly by area; optional RGB image emission.
#include <array>
#include <memory>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/lights/light_util.h"
#include "lensim/render/lights/lights.h"
#include "lensim/render/shapes/shapes.h"
#include "lensim/render/textures/textures.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

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
    return poly.sample(lambda) * (2 * m) * RGBColorSpace::sRGB().illuminant()->sample(lambda);
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
    Vec3 pl, n;
    Vec2 uv;
    if (!samplePoint(u, pl, n, uv)) return std::nullopt;
    return finish(p, pl, n, uv, 1 / area_, lambda);
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

/// The emission shared by the lights of one shape: its spectrum or image and the factors of
/// "scale" and "power" (pbrt-v4 divides power by k_e sides area pi).
struct AreaEmission {
  const scene::Light& l;
  SpectrumPtr spec;
  std::shared_ptr<const EmissionImage> image;
  double base_scale, k_e, sides;
};

/// Appends one FaceLight per face of the mesh m: a triangle, or a bilinear patch as two triangles.
void addFaceLights(const WorldMesh* m, const AreaEmission& e,
                   std::vector<std::unique_ptr<Light>>& lights) {
  const scene::Light& l = e.l;
  const SpectrumPtr& spec = e.spec;
  const std::shared_ptr<const EmissionImage>& image = e.image;
  const double base_scale = e.base_scale, k_e = e.k_e, sides = e.sides;
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
      lights.push_back(std::move(light));
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
}

}  // namespace

/// Adds the lights of the shapes with an area light (one per face of a mesh, one per quadric)
/// and records each such shape's first light in shape_first_light_.
void LightSet::addAreaLights(const scene::Scene& scene, const Accel& accel,
                             const Textures& textures) {
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
      addFaceLights(m, {l, spec, image, base_scale, k_e, sides}, lights_);
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
}

}  // namespace lensim::render
