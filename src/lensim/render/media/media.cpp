// Participating media. See media.h.
#include "lensim/render/media/media.h"

#include <array>
#include <map>

#include "lensim/render/media/media_volumes.h"
#include "lensim/render/media/subsurface.h"
#include "lensim/render/textures/textures.h"
#include "lensim/scene/description.h"

namespace lensim::render {

HomogeneousMedium::HomogeneousMedium(const scene::Medium& m) {
  // pbrt-v4: sigma_a and sigma_s are unbounded spectra; Le an illuminant, divided by its
  // luminance unless given as RGB (whose illuminant already has unit luminance here).
  sigma_a_ = makeSpectrum(m.sigma_a, SpectrumType::Unbounded);
  sigma_s_ = makeSpectrum(m.sigma_s, SpectrumType::Unbounded);
  const bool rgb = m.Le.kind == scene::SpectrumValue::Kind::Rgb;
  Le_ = makeSpectrum(m.Le, rgb ? SpectrumType::Illuminant : SpectrumType::Unbounded);
  scale_ = m.scale;
  Le_scale_ = m.Le_scale;
  if (!rgb) {
    const double y = luminance(*Le_);
    Le_scale_ = y > 0 ? Le_scale_ / y : 0;
  }
  g_ = m.g;
  emissive_ = Le_->maxValue() * Le_scale_ > 0;
}

MediumProperties HomogeneousMedium::at(const Vec3&, const SampledWavelengths& lambda) const {
  MediumProperties mp;
  mp.sigma_a = sigma_a_->sample(lambda) * scale_;
  mp.sigma_s = sigma_s_->sample(lambda) * scale_;
  if (emissive_) mp.Le = Le_->sample(lambda) * Le_scale_;
  return mp;
}

void HomogeneousMedium::majorants(const Vec3&, const Vec3&, double tmax,
                                  const SampledWavelengths& lambda, const SegmentFn& fn) const {
  fn(0, tmax, (sigma_a_->sample(lambda) + sigma_s_->sample(lambda)) * scale_);
}

GridMedium::GridMedium(const scene::Medium& m) {
  rgb_ = m.type == "rgbgrid";
  medium_from_world_ = m.medium_from_world;
  p0_ = m.p0;
  p1_ = m.p1;
  scale_ = m.scale;
  Le_scale_ = m.Le_scale;
  g_ = m.g;
  const RGBColorSpace& cs = RGBColorSpace::sRGB();
  if (!rgb_) {
    sigma_a_ = makeSpectrum(m.sigma_a, SpectrumType::Unbounded);
    sigma_s_ = makeSpectrum(m.sigma_s, SpectrumType::Unbounded);
    const bool rgb = m.Le.kind == scene::SpectrumValue::Kind::Rgb;
    Le_ = makeSpectrum(m.Le, rgb ? SpectrumType::Illuminant : SpectrumType::Unbounded);
    if (!rgb) {
      const double y = luminance(*Le_);
      Le_scale_ = y > 0 ? Le_scale_ / y : 0;
    }
    density_ = SampledGrid<double>(m.density, m.nx, m.ny, m.nz);
    if (!m.Le_scale_grid.empty()) Le_grid_ = SampledGrid<double>(m.Le_scale_grid, m.nx, m.ny, m.nz);
    emissive_ = Le_->maxValue() * Le_scale_ > 0;
  } else {
    // One spectrum per distinct RGB (grids often repeat values).
    std::map<std::array<double, 3>, std::shared_ptr<const Spectrum>> cache[2];
    auto grid = [&](const std::vector<Vec3>& v, bool illuminant) {
      std::vector<std::shared_ptr<const Spectrum>> out;
      out.reserve(v.size());
      for (const Vec3& c : v) {
        auto& slot = cache[illuminant][{c.x, c.y, c.z}];
        if (!slot) {
          if (illuminant)
            slot = std::make_shared<RGBIlluminantSpectrum>(cs, c);
          else
            slot = std::make_shared<RGBUnboundedSpectrum>(cs, c);
        }
        out.push_back(slot);
      }
      return SampledGrid<std::shared_ptr<const Spectrum>>(std::move(out), m.nx, m.ny, m.nz);
    };
    if (!m.sigma_a_grid.empty()) sigma_a_grid_ = grid(m.sigma_a_grid, false);
    if (!m.sigma_s_grid.empty()) sigma_s_grid_ = grid(m.sigma_s_grid, false);
    if (!m.Le_grid.empty()) Le_rgb_grid_ = grid(m.Le_grid, true);
    emissive_ = !Le_rgb_grid_.empty() && Le_scale_ > 0;
  }
  // Majorant grid: the largest value of the voxels that influence each cell.
  majorant_.resize(size_t(kRes) * kRes * kRes);
  auto maxOf = [](const std::shared_ptr<const Spectrum>& s) { return s ? s->maxValue() : 0.0; };
  for (int z = 0; z < kRes; ++z)
    for (int y = 0; y < kRes; ++y)
      for (int x = 0; x < kRes; ++x) {
        const Vec3 lo{double(x) / kRes, double(y) / kRes, double(z) / kRes};
        const Vec3 hi{double(x + 1) / kRes, double(y + 1) / kRes, double(z + 1) / kRes};
        double v;
        if (!rgb_) {
          v = density_.maxValue(lo, hi, [](double d) { return d; });
        } else {
          v = (sigma_a_grid_.empty() ? 1.0 : sigma_a_grid_.maxValue(lo, hi, maxOf)) +
              (sigma_s_grid_.empty() ? 1.0 : sigma_s_grid_.maxValue(lo, hi, maxOf));
        }
        majorant_[(size_t(z) * kRes + y) * kRes + x] = v;
      }
}

Vec3 GridMedium::toGrid(const Vec3& p) const {
  const Vec3 q = medium_from_world_.applyPoint(p);
  return {(q.x - p0_.x) / (p1_.x - p0_.x), (q.y - p0_.y) / (p1_.y - p0_.y),
          (q.z - p0_.z) / (p1_.z - p0_.z)};
}

MediumProperties GridMedium::at(const Vec3& p, const SampledWavelengths& lambda) const {
  const Vec3 g = toGrid(p);
  MediumProperties mp;
  if (!rgb_) {
    const double d = density_.lookup(g, [](double v) { return v; }) * scale_;
    mp.sigma_a = sigma_a_->sample(lambda) * d;
    mp.sigma_s = sigma_s_->sample(lambda) * d;
    if (emissive_) {
      const double s = Le_grid_.empty() ? 1.0 : Le_grid_.lookup(g, [](double v) { return v; });
      if (s > 0) mp.Le = Le_->sample(lambda) * (s * Le_scale_);
    }
    return mp;
  }
  auto conv = [&](const std::shared_ptr<const Spectrum>& s) {
    return s ? s->sample(lambda) : SampledSpectrum(0.0);
  };
  mp.sigma_a =
      (sigma_a_grid_.empty() ? SampledSpectrum(1.0) : sigma_a_grid_.lookup(g, conv)) * scale_;
  mp.sigma_s =
      (sigma_s_grid_.empty() ? SampledSpectrum(1.0) : sigma_s_grid_.lookup(g, conv)) * scale_;
  if (emissive_) mp.Le = Le_rgb_grid_.lookup(g, conv) * Le_scale_;
  return mp;
}

void GridMedium::majorants(const Vec3& o, const Vec3& d, double tmax,
                           const SampledWavelengths& lambda, const SegmentFn& fn) const {
  // The ray in grid space ([0,1]^3 over the bounds); t is unchanged (affine map).
  const Vec3 q = medium_from_world_.applyVector(d);
  const Vec3 dg{q.x / (p1_.x - p0_.x), q.y / (p1_.y - p0_.y), q.z / (p1_.z - p0_.z)};
  const SampledSpectrum sigma_t =
      rgb_ ? SampledSpectrum(scale_)
           : (sigma_a_->sample(lambda) + sigma_s_->sample(lambda)) * scale_;
  walkMajorantGrid(toGrid(o), dg, tmax, kRes, majorant_, sigma_t, fn);
}

void walkMajorantGrid(const Vec3& og, const Vec3& dgv, double tmax, int res,
                      const std::vector<double>& cells, const SampledSpectrum& sigma_t,
                      const Medium::SegmentFn& fn) {
  const double dg[3] = {dgv.x, dgv.y, dgv.z};
  const double ov[3] = {og.x, og.y, og.z};
  // Clip to the unit box.
  double t0 = 0, t1 = tmax;
  for (int a = 0; a < 3; ++a) {
    if (dg[a] == 0) {
      if (ov[a] < 0 || ov[a] > 1) return;
      continue;
    }
    double ta = (0 - ov[a]) / dg[a], tb = (1 - ov[a]) / dg[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (!(t0 < t1)) return;
  // 3-D DDA through the majorant cells (Amanatides & Woo 1987; pbrt-v4's DDAMajorantIterator).
  int voxel[3], step[3], limit[3];
  double next[3], delta[3];
  for (int a = 0; a < 3; ++a) {
    const double pa = ov[a] + dg[a] * t0;
    voxel[a] = std::clamp(int(pa * res), 0, res - 1);
    if (dg[a] == 0) {
      delta[a] = next[a] = INFINITY;
      step[a] = 1, limit[a] = res;
      continue;
    }
    delta[a] = 1 / (std::abs(dg[a]) * res);
    if (dg[a] > 0) {
      next[a] = t0 + (double(voxel[a] + 1) / res - pa) / dg[a];
      step[a] = 1, limit[a] = res;
    } else {
      next[a] = t0 + (double(voxel[a]) / res - pa) / dg[a];
      step[a] = -1, limit[a] = -1;
    }
  }
  double t = t0;
  while (t < t1) {
    const int a = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : (next[1] < next[2] ? 1 : 2);
    const double t_exit = std::min(t1, next[a]);
    const double maj = cells[(size_t(voxel[2]) * res + voxel[1]) * res + voxel[0]];
    if (!fn(t, t_exit, sigma_t * maj)) return;
    t = t_exit;
    voxel[a] += step[a];
    if (voxel[a] == limit[a]) break;
    next[a] += delta[a];
  }
}

Media::Media(const scene::Scene& scene) {
  for (const scene::Medium& m : scene.media) {
    if (m.type == "homogeneous")
      media_.push_back(std::make_unique<HomogeneousMedium>(m));
    else if (m.type == "uniformgrid" || m.type == "rgbgrid")
      media_.push_back(std::make_unique<GridMedium>(m));
    else if (m.type == "cloud")
      media_.push_back(std::make_unique<CloudMedium>(m));
    else if (m.type == "nanovdb")
      media_.push_back(std::make_unique<NanoVDBMedium>(m));
    else
      media_.push_back(nullptr);
    any_ = any_ || media_.back() != nullptr;
  }
  n_scene_ = int(media_.size());
  subsurface_.assign(scene.materials.size(), -1);
  for (size_t i = 0; i < scene.materials.size(); ++i)
    if (scene.materials[i].kind() == scene::MaterialKind::Subsurface) {
      subsurface_[i] = int(media_.size());
      auto ss = std::make_unique<SubsurfaceMedium>(
          scene.materials[i].as<scene::SubsurfaceParams>());
      textured_.push_back(ss->textured() ? ss.get() : nullptr);
      media_.push_back(std::move(ss));
      has_subsurface_ = true;
    }
}

Media::~Media() = default;

}  // namespace lensim::render
