// BxDFs from material descriptions with pbrt-v4's parameter semantics (roughness remapped by
// sqrt unless remaproughness is false; conductor "reflectance" means eta = 1 and k from the
// normal-incidence reflectance; a dielectric eta that varies with wavelength keeps only the
// hero wavelength).
#include "lensim/render/materials/materials.h"
#include "lensim/render/materials/bxdf_arena.h"
#include "lensim/render/materials/fourier.h"
#include "lensim/render/materials/measured.h"
#include "lensim/render/materials/measured_rgl.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <utility>

#include "lensim/io/image.h"
#include "lensim/render/materials/hair_material.h"
#include "lensim/render/materials/layered.h"
#include "lensim/render/materials/v3materials.h"
#include "lensim/sampling/sampling.h"
#include "lensim/scene/builder.h"
#include "lensim/util/error.h"

namespace lensim::render {

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
    if (m.kind == scene::MaterialKind::Fourier) {
      try {
        fourier_tables_[i] = FourierBSDFTable::loadCached(m.measured_file);
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
    if (m.kind != scene::MaterialKind::Mix) return material;
    const double a = textures_->evalFloat(m.amount, ctx);
    int next;
    if (a <= 0) {
      next = m.mix[0];
    } else if (a >= 1) {
      next = m.mix[1];
    } else {
      auto bits = [](double v) {
        uint64_t u;
        std::memcpy(&u, &v, sizeof u);
        return u;
      };
      const uint64_t h = hashValues({bits(ctx.p.x), bits(ctx.p.y), bits(ctx.p.z), bits(wo.x),
                                     bits(wo.y), uint64_t(material)});
      next = double(h >> 11) * 0x1.0p-53 < a ? m.mix[1] : m.mix[0];
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
         scene_->materials[size_t(material)].kind == scene::MaterialKind::Interface;
}

std::shared_ptr<const BxDF> Materials::bxdf(int material, const TextureEvalContext& ctx,
                                            SampledWavelengths& lambda, bool regularize) const {
  auto reg = [&](double alpha) {
    return regularize && alpha < 0.3 ? std::clamp(2 * alpha, 0.1, 0.3) : alpha;
  };
  if (material < 0) return makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
  const scene::Material& m = scene_->materials[size_t(material)];
  const Textures& tx = *textures_;
  auto distribution = [&]() {
    double ur = tx.evalFloat(m.uroughness, ctx), vr = tx.evalFloat(m.vroughness, ctx);
    if (m.remap_roughness) ur = roughnessToAlpha(ur), vr = roughnessToAlpha(vr);
    return TrowbridgeReitz(reg(ur), reg(vr));
  };
  auto dielectricEta = [&]() -> double {
    if (m.eta.texture >= 0) return tx.evalFloat(m.eta, ctx);
    if (m.eta.spectrum.kind == scene::SpectrumValue::Kind::Rgb &&
        m.eta.spectrum.rgb == Vec3{0, 0, 0})
      return m.eta.value;  // a float eta
    SpectrumPtr s = tx.constant(m.eta.spectrum, SpectrumType::Unbounded);
    const double e = s->eval(lambda.lambda(0));
    if (s->eval(lambda.lambda(1)) != e) lambda.terminateSecondary();
    return e;
  };
  // A conductor's complex index eta + i k: from its "reflectance" (eta 1 and the k that gives it)
  // when one was given, else from its eta and k spectra.
  auto conductorIndex = [&](bool has_reflectance, const scene::Input& reflectance,
                            const scene::Input& eta_in, const scene::Input& k_in) {
    if (has_reflectance) {
      const SampledSpectrum r =
          clampZero(tx.evalSpectrum(reflectance, ctx, lambda, SpectrumType::Albedo));
      return std::pair{SampledSpectrum(1.0), conductorKFromReflectance(r)};
    }
    return std::pair{tx.evalSpectrum(eta_in, ctx, lambda, SpectrumType::Unbounded),
                     tx.evalSpectrum(k_in, ctx, lambda, SpectrumType::Unbounded)};
  };
  using K = scene::MaterialKind;
  if (scene::isV3Kind(m.kind)) return makeV3BxDF(m, tx, ctx, lambda, regularize);
  switch (m.kind) {
    case K::Fourier:
      return makeBxDF<FourierBxDF>(fourier_tables_[size_t(material)], lambda);
    case K::Hair:
      return makeHairBxDF(m, tx, ctx, lambda);
    case K::Measured: {
      if (m.measured_rgl)
        return makeBxDF<RGLMeasuredBxDF>(RGLMeasuredBRDF::loadCached(m.measured_file),
                                                 lambda);
      return makeBxDF<MeasuredBxDF>(MeasuredBRDF::loadCached(m.measured_file), lambda);
    }
    case K::Diffuse: {
      const SampledSpectrum r =
          clampZero(tx.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo));
      const double sigma = tx.evalFloat(m.sigma, ctx);
      if (sigma > 0) return makeBxDF<OrenNayarBxDF>(r, sigma);
      return makeBxDF<DiffuseBxDF>(r);
    }
    case K::DiffuseTransmission: {
      const SampledSpectrum r =
          clampZero(tx.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo)) * m.scale;
      const SampledSpectrum t =
          clampZero(tx.evalSpectrum(m.transmittance, ctx, lambda, SpectrumType::Albedo)) * m.scale;
      return makeBxDF<DiffuseTransmissionBxDF>(r, t);
    }
    case K::CoatedConductor: {
      auto [ceta, ck] = conductorIndex(m.conductor_has_reflectance, m.conductor_reflectance,
                                       m.conductor_eta, m.conductor_k);
      double eta = dielectricEta();
      if (eta == 0) eta = 1;
      // pbrt-v4: the conductor sits under a medium of index eta, so its index is relative to it.
      ceta /= eta;
      ck /= eta;
      double cu = tx.evalFloat(m.conductor_uroughness, ctx),
             cv = tx.evalFloat(m.conductor_vroughness, ctx);
      if (m.remap_roughness) cu = roughnessToAlpha(cu), cv = roughnessToAlpha(cv);
      LayerParams lp;
      lp.thickness = tx.evalFloat(m.thickness, ctx);
      lp.albedo = clampZero(tx.evalSpectrum(m.albedo, ctx, lambda, SpectrumType::Albedo));
      lp.g = tx.evalFloat(m.g, ctx);
      lp.max_depth = m.max_depth;
      lp.n_samples = m.n_samples;
      return makeBxDF<CoatedBxDF>(
          DielectricBxDF(eta, distribution()),
          makeBxDF<ConductorBxDF>(TrowbridgeReitz(reg(cu), reg(cv)), ceta, ck), lp);
    }
    case K::Conductor: {
      const auto [eta, k] = conductorIndex(m.has_reflectance, m.reflectance, m.eta, m.k);
      return makeBxDF<ConductorBxDF>(distribution(), eta, k);
    }
    case K::Dielectric:
    case K::Subsurface: {  // subsurface: its boundary
      double eta = dielectricEta();
      if (eta == 0) eta = 1;
      return makeBxDF<DielectricBxDF>(eta, distribution());
    }
    case K::ThinDielectric: {
      double eta = dielectricEta();
      if (eta == 0) eta = 1;
      return makeBxDF<ThinDielectricBxDF>(eta);
    }
    case K::CoatedDiffuse: {
      const SampledSpectrum r =
          clampZero(tx.evalSpectrum(m.reflectance, ctx, lambda, SpectrumType::Albedo));
      double eta = dielectricEta();
      if (eta == 0) eta = 1;
      LayerParams lp;
      lp.thickness = m.thickness.texture >= 0 || m.thickness.value != 0
                         ? tx.evalFloat(m.thickness, ctx)
                         : 0.01;
      lp.albedo = clampZero(tx.evalSpectrum(m.albedo, ctx, lambda, SpectrumType::Albedo));
      lp.g = tx.evalFloat(m.g, ctx);
      lp.max_depth = m.max_depth;
      lp.n_samples = m.n_samples;
      return makeBxDF<CoatedBxDF>(DielectricBxDF(eta, distribution()),
                                          makeBxDF<DiffuseBxDF>(r), lp);
    }
    case K::Mix:        // resolved before (resolve())
    case K::Interface:  // no BSDF: rays pass (isInterface())
    case K::Plastic:
    case K::Substrate:
    case K::Uber:
    case K::Translucent:
    case K::Glass:
    case K::Metal:
    case K::Mirror:
      break;
  }
  return makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
}

}  // namespace lensim::render
