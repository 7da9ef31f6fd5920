// Materials at render time: normal and bump maps, mix resolution, and the BxDF of each material
// kind (made by the kind's bxdfOf, material_eval.h).
#include "lensim/render/materials/materials.h"
#include "lensim/render/materials/bxdf_arena.h"
#include "lensim/render/materials/fourier.h"
#include "lensim/render/materials/material_eval.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <utility>

#include "lensim/io/image.h"
#include "lensim/sampling/sampling.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::render {

using namespace lensim::sampling;

struct Materials::NormalMap {
  int width = 0, height = 0;
  std::vector<Vec3> n;  ///< tangent-space normals, rows top to bottom
};

Materials::Materials(const scene::Scene& scene, const Textures& textures)
    : scene_(&scene), textures_(&textures) {
  normal_maps_.resize(scene.materials.size());
  fourier_tables_.resize(scene.materials.size());
  std::map<std::string, std::shared_ptr<NormalMap>> loaded;
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const scene::Material& m = scene.materials[i];
    if (m.kind() == scene::MaterialKind::Fourier) {
      try {
        fourier_tables_[i] = FourierBSDFTable::loadCached(m.as<scene::FourierParams>().file);
      } catch (const Error& e) {
        throw Error(m.loc, fmt::format("fourier: {}", nestedMessage(e)));
      }
    }
    if (m.normal_map.empty()) continue;
    auto it = loaded.find(m.normal_map);
    if (it == loaded.end()) {
      io::Image im;
      try {
        im = io::readImage(m.normal_map, {.encoding = "linear"});  // as pbrt-v4 reads them
      } catch (const Error& e) {
        throw Error(m.loc, fmt::format("normal map: {}", nestedMessage(e)));
      }
      auto nm = std::make_shared<NormalMap>();
      nm->width = im.width;
      nm->height = im.height;
      const int nc = im.channelCount();
      for (int y = 0; y < im.height; ++y)
        for (int x = 0; x < im.width; ++x) {
          double c[3];
          for (int k = 0; k < 3; ++k) {
            const float v = im.at(x, y, std::min(k, nc - 1));
            c[k] = 2.0 * v - 1.0;
          }
          Vec3 n{c[0], c[1], c[2]};
          nm->n.push_back(length(n) > 0 ? normalize(n) : Vec3{0, 0, 1});
        }
      it = loaded.emplace(m.normal_map, nm).first;
    }
    normal_maps_[i] = it->second;
  }
}

Materials::~Materials() = default;

int Materials::resolve(int material, const TextureEvalContext& ctx, const Vec3& wo) const {
  for (int guard = 0; guard < 16 && material >= 0; ++guard) {
    const scene::Material& m = scene_->materials[size_t(material)];
    if (m.kind() != scene::MaterialKind::Mix) return material;
    const scene::MixParams& mix = m.as<scene::MixParams>();
    const double a = textures_->evalFloat(mix.amount, ctx);
    int next;
    if (a <= 0) {
      next = mix.materials[0];
    } else if (a >= 1) {
      next = mix.materials[1];
    } else {
      auto bits = [](double v) {
        uint64_t u;
        std::memcpy(&u, &v, sizeof u);
        return u;
      };
      const uint64_t h = hashValues({bits(ctx.p.x), bits(ctx.p.y), bits(ctx.p.z), bits(wo.x),
                                     bits(wo.y), uint64_t(material)});
      next = double(h >> 11) * 0x1.0p-53 < a ? mix.materials[1] : mix.materials[0];
    }
    material = next;
  }
  return material;
}

Vec3 Materials::shadingNormal(int material, const TextureEvalContext& ctx, const Vec3& ns,
                              const Vec3& dpdu) const {
  if (material < 0 || !normal_maps_[size_t(material)]) return ns;
  const NormalMap& nm = *normal_maps_[size_t(material)];
  // Bilinear lookup, repeat wrap, t flipped as for image textures.
  const double x = ctx.uv.x * nm.width - 0.5, y = (1 - ctx.uv.y) * nm.height - 0.5;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int xi, int yi) {
    xi = ((xi % nm.width) + nm.width) % nm.width;
    yi = ((yi % nm.height) + nm.height) % nm.height;
    return nm.n[size_t(yi) * size_t(nm.width) + size_t(xi)];
  };
  const Vec3 t = (at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy) +
                 (at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx) * fy;
  const Frame f = Frame::fromNormalAndTangent(ns, dpdu);
  const Vec3 n = f.fromLocal(t);
  return length(n) > 0 ? normalize(n) : ns;
}

bool Materials::hasBump(int material) const {
  if (material < 0) return false;
  const scene::Material& m = scene_->materials[size_t(material)];
  return m.displacement.has_value() && !normal_maps_[size_t(material)];
}

Vec3 Materials::bumpedNormal(int material, const TextureEvalContext& ctx, const Vec3& ns,
                             const Vec3& dpdu, const Vec3& dpdv, const Vec3& dndu,
                             const Vec3& dndv) const {
  const scene::Material& m = scene_->materials[size_t(material)];
  const scene::Input& disp = *m.displacement;
  const double du = 0.0005, dv = 0.0005;
  TextureEvalContext shifted = ctx;
  shifted.p = ctx.p + dpdu * du;
  shifted.uv = ctx.uv + Vec2(du, 0);
  const double u_displace = textures_->evalFloat(disp, shifted);
  shifted.p = ctx.p + dpdv * dv;
  shifted.uv = ctx.uv + Vec2(0, dv);
  const double v_displace = textures_->evalFloat(disp, shifted);
  const double displace = textures_->evalFloat(disp, ctx);
  const Vec3 bu = dpdu + ns * ((u_displace - displace) / du) + dndu * displace;
  const Vec3 bv = dpdv + ns * ((v_displace - displace) / dv) + dndv * displace;
  Vec3 n = cross(bu, bv);
  if (!(length(n) > 0) || !std::isfinite(n.x)) return ns;
  n = normalize(n);
  return dot(n, ns) < 0 ? -n : n;
}

bool Materials::isInterface(int material) const {
  return material >= 0 &&
         scene_->materials[size_t(material)].kind() == scene::MaterialKind::Interface;
}

namespace {
template <class... F>
struct Overloaded : F... {
  using F::operator()...;
};
}  // namespace

std::shared_ptr<const BxDF> Materials::bxdf(int material, const TextureEvalContext& ctx,
                                            SampledWavelengths& lambda, bool regularize) const {
  if (material < 0) return makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
  const MaterialEvalContext c{*textures_, ctx, lambda, regularize};
  return std::visit(
      Overloaded{
          [&](const scene::FourierParams&) -> std::shared_ptr<const BxDF> {
            return makeBxDF<FourierBxDF>(fourier_tables_[size_t(material)], lambda);
          },
          // mix: resolved before (resolve()); interface: no BSDF, rays pass (isInterface()).
          [&](const scene::MixParams&) { return makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5)); },
          [&](const scene::InterfaceParams&) {
            return makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
          },
          [&](const auto& params) { return bxdfOf(params, c); },
      },
      scene_->materials[size_t(material)].params);
}

}  // namespace lensim::render
