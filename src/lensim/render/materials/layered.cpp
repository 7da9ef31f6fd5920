#include "lensim/render/materials/layered.h"

#include <bit>
#include <cmath>

#include <fmt/format.h>

#include "lensim/sampling/sampling.h"
#include "lensim/util/error.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

TransportMode adjoint(TransportMode m) {
  return m == TransportMode::Radiance ? TransportMode::Importance : TransportMode::Radiance;
}

uint64_t hashDirection(const Vec3& w) {
  return hashValues(
      {std::bit_cast<uint64_t>(w.x), std::bit_cast<uint64_t>(w.y), std::bit_cast<uint64_t>(w.z)});
}

/// Orthonormal basis with v as its third axis (Duff et al. 2017, "Building an Orthonormal
/// Basis, Revisited"); returns a * t1 + b * t2 + c * v.
Vec3 fromLocal(const Vec3& v, const Vec3& local) {
  const double sign = std::copysign(1.0, v.z);
  const double a = -1 / (sign + v.z);
  const double b = v.x * v.y * a;
  const Vec3 t1(1 + sign * v.x * v.x * a, sign * b, -sign * v.x);
  const Vec3 t2(b, sign + v.y * v.y * a, -v.y);
  return t1 * local.x + t2 * local.y + v * local.z;
}

bool valid(const std::optional<BSDFSample>& s) {
  return s && !s->f.isBlack() && s->pdf > 0 && s->wi.z != 0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

double HenyeyGreenstein::p(const Vec3& wo, const Vec3& wi) const {
  const double denom = 1 + g_ * g_ + 2 * g_ * dot(wo, wi);
  return (1 - g_ * g_) / (4 * kPi * denom * std::sqrt(std::max(denom, 1e-300)));
}

std::optional<HenyeyGreenstein::Sample> HenyeyGreenstein::sample(const Vec3& wo, Vec2 u) const {
  // Invert the CDF of cos(theta) = wo . wi (forward scattering, g > 0, gives wi near -wo).
  double cos_theta;
  if (std::abs(g_) < 1e-3) {
    cos_theta = 1 - 2 * u.x;
  } else {
    const double s = (1 - g_ * g_) / (1 + g_ - 2 * g_ * u.x);
    cos_theta = -1 / (2 * g_) * (1 + g_ * g_ - s * s);
  }
  cos_theta = std::clamp(cos_theta, -1.0, 1.0);
  const double sin_theta = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
  const double phi = 2 * kPi * u.y;
  const Vec3 wi = normalize(
      fromLocal(wo, Vec3(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta)));
  const double pdf = p(wo, wi);
  return Sample{wi, pdf, pdf};
}

// ---------------------------------------------------------------------------------------------

CoatedBxDF::CoatedBxDF(DielectricBxDF top, std::shared_ptr<const BxDF> bottom,
                       const LayerParams& params)
    : top_(std::move(top)), bottom_(std::move(bottom)), params_(params) {
  if (!bottom_) throw Error("coated BxDF needs a base");
  if (!(params_.thickness > 0))
    throw Error(fmt::format("coating thickness {} must be positive", params_.thickness));
  if (params_.max_depth < 1 || params_.n_samples < 1)
    throw Error("coating maxdepth and nsamples must be at least 1");
  params_.thickness = std::max(params_.thickness, 1e-12);
}

// Density, over internal directions, with which the next-event strategy (wis: transmission
// sampled from wi through the coating) would have produced the upward internal direction w.
// pbrt-v4 uses the coating's pdf of wi given -w here, a density over the outside directions;
// the two differ by the refraction Jacobian, which leaves the MIS weights not summing to one and
// biased f() by several percent for rough coatings (see layered_test).
double CoatedBxDF::exitStrategyPdf(const Vec3& wi, const Vec3& w, TransportMode mode) const {
  // pbrt-v4 (LayeredBxDF::f, src/pbrt/bxdfs.h): exitInterface.PDF(-w, wi, mode, Transmission).
  if (params_.pbrt_v4_exit_weight) return top_.pdf(-w, wi, mode, ReflTrans::Transmission);
  return top_.pdf(wi, -w, adjoint(mode), ReflTrans::Transmission);
}

double CoatedBxDF::transmittance(double dz, const Vec3& w) const {
  if (std::abs(dz) <= 1e-300) return 1.0;
  return std::exp(-std::abs(dz / w.z));
}

BxDFFlags CoatedBxDF::flags() const {
  const BxDFFlags top = top_.flags(), bottom = bottom_->flags();
  BxDFFlags f = BxDFFlags::Reflection;
  if (isSpecular(top)) f = f | BxDFFlags::Specular;
  if (any(top, BxDFFlags::Diffuse) || any(bottom, BxDFFlags::Diffuse) || !params_.albedo.isBlack())
    f = f | BxDFFlags::Diffuse;
  else if (any(top, BxDFFlags::Glossy) || any(bottom, BxDFFlags::Glossy))
    f = f | BxDFFlags::Glossy;
  return f;
}

SampledSpectrum CoatedBxDF::f(const Vec3& wo_in, const Vec3& wi_in, TransportMode mode) const {
  Vec3 wo = wo_in, wi = wi_in;
  if (wo.z < 0) {  // two-sided: mirror to the top
    wo = -wo;
    wi = -wi;
  }
  // The base is opaque: light can only leave through the top, on wo's side.
  if (!sameHemisphere(wo, wi)) return {};
  const double thickness = params_.thickness, exit_z = thickness;
  const int n = params_.n_samples;
  SampledSpectrum f = top_.f(wo, wi, mode) * static_cast<double>(n);

  Rng rng(hashDirection(wo), hashDirection(wi));
  auto r = [&] { return rng.uniform(); };
  const HenyeyGreenstein phase(params_.g);
  const bool top_specular = isSpecular(top_.flags());
  const bool bottom_specular = isSpecular(bottom_->flags());
  const bool has_medium = !params_.albedo.isBlack();

  for (int s = 0; s < n; ++s) {
    // Enter through the top; and the direction by which light will leave toward wi (sampled
    // with the adjoint mode, since it is traced from wi inward).
    const auto wos = top_.sample_f(wo, r(), {r(), r()}, mode, ReflTrans::Transmission);
    if (!valid(wos)) continue;
    const auto wis = top_.sample_f(wi, r(), {r(), r()}, adjoint(mode), ReflTrans::Transmission);
    if (!valid(wis)) continue;

    SampledSpectrum beta = wos->f * absCosTheta(wos->wi) / wos->pdf;
    double z = thickness;
    Vec3 w = wos->wi;
    for (int depth = 0; depth < params_.max_depth; ++depth) {
      // Russian roulette once the throughput is small.
      if (depth > 3 && beta.maxValue() < 0.25) {
        const double q = std::max(0.0, 1 - beta.maxValue());
        if (r() < q) break;
        beta /= 1 - q;
      }
      if (!has_medium) {
        z = (z == thickness) ? 0.0 : thickness;
        beta *= transmittance(thickness, w);
      } else {
        // Free flight with sigma_t = 1 along w.
        const double dz = -std::log(1 - r()) * std::abs(w.z);
        const double zp = w.z > 0 ? z + dz : z - dz;
        if (zp == z) continue;
        if (zp > 0 && zp < thickness) {
          // Scattering in the medium: next-event estimate through the top toward wi ...
          double wt = 1;
          if (!top_specular) wt = powerHeuristic(1, wis->pdf, 1, phase.p(-w, -wis->wi));
          f += beta * params_.albedo * phase.p(-w, -wis->wi) * wt *
               transmittance(zp - exit_z, wis->wi) * wis->f / wis->pdf;
          // ... then continue the walk in a phase-sampled direction.
          const auto ps = phase.sample(-w, {r(), r()});
          if (!ps || ps->pdf == 0 || ps->wi.z == 0) break;
          beta *= params_.albedo * (ps->p / ps->pdf);
          w = ps->wi;
          z = zp;
          // The phase-sampled direction may leave through a rough top: MIS with the NEE above.
          if (w.z > 0 && !top_specular) {
            const SampledSpectrum f_exit = top_.f(-w, wi, mode);
            if (!f_exit.isBlack()) {
              const double exit_pdf = exitStrategyPdf(wi, w, mode);
              const double wt2 = powerHeuristic(1, ps->pdf, 1, exit_pdf);
              f += beta * transmittance(zp - exit_z, ps->wi) * f_exit * wt2;
            }
          }
          continue;
        }
        z = std::clamp(zp, 0.0, thickness);
      }

      if (z == exit_z) {
        // At the coating from inside: reflect back down (leaving is counted by the estimates).
        const auto bs = top_.sample_f(-w, r(), {r(), r()}, mode, ReflTrans::Reflection);
        if (!valid(bs)) break;
        beta *= bs->f * absCosTheta(bs->wi) / bs->pdf;
        w = bs->wi;
      } else {
        // At the base: next-event estimate toward the exit direction ...
        if (!bottom_specular) {
          double wt = 1;
          if (!top_specular) wt = powerHeuristic(1, wis->pdf, 1, bottom_->pdf(-w, -wis->wi, mode));
          f += beta * bottom_->f(-w, -wis->wi, mode) * absCosTheta(wis->wi) * wt *
               transmittance(thickness, wis->wi) * wis->f / wis->pdf;
        }
        // ... then sample the base's reflection.
        const auto bs = bottom_->sample_f(-w, r(), {r(), r()}, mode, ReflTrans::Reflection);
        if (!valid(bs)) break;
        beta *= bs->f * absCosTheta(bs->wi) / bs->pdf;
        w = bs->wi;
        // The sampled direction may leave through a rough coating: MIS with the NEE above.
        if (!top_specular) {
          const SampledSpectrum f_exit = top_.f(-w, wi, mode);
          if (!f_exit.isBlack()) {
            double wt = 1;
            if (!bottom_specular) {
              const double exit_pdf = exitStrategyPdf(wi, w, mode);
              wt = powerHeuristic(1, bs->pdf, 1, exit_pdf);
            }
            f += beta * transmittance(thickness, bs->wi) * f_exit * wt;
          }
        }
      }
    }
  }
  return f / static_cast<double>(n);
}

std::optional<BSDFSample> CoatedBxDF::sample_f(const Vec3& wo_in, double uc, Vec2 u,
                                               TransportMode mode, ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection)) return std::nullopt;
  Vec3 wo = wo_in;
  const bool flip = wo.z < 0;
  if (flip) wo = -wo;

  // Scatter at the coating first.
  auto bs = top_.sample_f(wo, uc, u, mode);
  if (!valid(bs)) return std::nullopt;
  if (bs->isReflection()) {
    if (flip) bs->wi = -bs->wi;
    bs->pdf_is_proportional = true;
    return bs;
  }
  Vec3 w = bs->wi;
  bool specular_path = bs->isSpecular();
  SampledSpectrum f = bs->f * absCosTheta(bs->wi);
  double pdf = bs->pdf;
  double z = params_.thickness;
  const double thickness = params_.thickness;
  const HenyeyGreenstein phase(params_.g);
  const bool has_medium = !params_.albedo.isBlack();

  Rng rng(hashDirection(wo), hashValues({std::bit_cast<uint64_t>(uc), std::bit_cast<uint64_t>(u.x),
                                         std::bit_cast<uint64_t>(u.y)}));
  auto r = [&] { return rng.uniform(); };

  for (int depth = 0; depth < params_.max_depth; ++depth) {
    const double rr_beta = f.maxValue() / pdf;
    if (depth > 3 && rr_beta < 0.25) {
      const double q = std::max(0.0, 1 - rr_beta);
      if (r() < q) return std::nullopt;
      pdf *= 1 - q;
    }
    if (w.z == 0) return std::nullopt;
    if (has_medium) {
      const double dz = -std::log(1 - r()) * std::abs(w.z);
      const double zp = w.z > 0 ? z + dz : z - dz;
      if (zp == z) return std::nullopt;
      if (zp > 0 && zp < thickness) {
        const auto ps = phase.sample(-w, {r(), r()});
        if (!ps || ps->pdf == 0 || ps->wi.z == 0) return std::nullopt;
        f *= params_.albedo * ps->p;
        pdf *= ps->pdf;
        specular_path = false;
        w = ps->wi;
        z = zp;
        continue;
      }
      z = std::clamp(zp, 0.0, thickness);
    } else {
      z = (z == thickness) ? 0.0 : thickness;
      f *= transmittance(thickness, w);
    }
    const BxDF& layer = (z == 0) ? *bottom_ : static_cast<const BxDF&>(top_);
    const auto ls = layer.sample_f(-w, r(), {r(), r()}, mode);
    if (!valid(ls)) return std::nullopt;
    f *= ls->f;
    pdf *= ls->pdf;
    specular_path = specular_path && ls->isSpecular();
    w = ls->wi;
    if (ls->isTransmission()) {
      // Left through the coating (the base is opaque, so this is the top).
      if (!sameHemisphere(wo, w)) return std::nullopt;
      BSDFSample out{
          f, flip ? -w : w, pdf,
          BxDFFlags::Reflection | (specular_path ? BxDFFlags::Specular : BxDFFlags::Glossy)};
      out.pdf_is_proportional = true;
      return out;
    }
    f *= absCosTheta(ls->wi);
  }
  return std::nullopt;
}

double CoatedBxDF::pdf(const Vec3& wo_in, const Vec3& wi_in, TransportMode mode,
                       ReflTrans allowed) const {
  if (!allows(allowed, ReflTrans::Reflection)) return 0;
  Vec3 wo = wo_in, wi = wi_in;
  if (wo.z < 0) {
    wo = -wo;
    wi = -wi;
  }
  if (!sameHemisphere(wo, wi)) return 0;
  const int n = params_.n_samples;
  Rng rng(hashDirection(wi), hashDirection(wo));
  auto r = [&] { return rng.uniform(); };
  double pdf_sum = n * top_.pdf(wo, wi, mode, ReflTrans::Reflection);
  const bool top_specular = isSpecular(top_.flags());
  const bool bottom_specular = isSpecular(bottom_->flags());
  for (int s = 0; s < n; ++s) {
    // Transmission - base reflection - transmission, estimated from both ends with MIS.
    const auto wos = top_.sample_f(wo, r(), {r(), r()}, mode, ReflTrans::Transmission);
    const auto wis = top_.sample_f(wi, r(), {r(), r()}, adjoint(mode), ReflTrans::Transmission);
    if (!valid(wos) || !valid(wis)) continue;
    if (top_specular) {
      pdf_sum += bottom_->pdf(-wos->wi, -wis->wi, mode);
      continue;
    }
    const auto rs = bottom_->sample_f(-wos->wi, r(), {r(), r()}, mode);
    if (!valid(rs)) continue;
    if (!bottom_specular) {
      const double r_pdf = bottom_->pdf(-wos->wi, -wis->wi, mode);
      pdf_sum += powerHeuristic(1, wis->pdf, 1, r_pdf) * r_pdf;
      const double t_pdf = top_.pdf(-rs->wi, wi, mode);
      pdf_sum += powerHeuristic(1, rs->pdf, 1, t_pdf) * t_pdf;
    } else {
      pdf_sum += top_.pdf(-rs->wi, wi, mode);
    }
  }
  // Blend with a uniform density to stay positive where the estimate misses (pbrt-v4 uses 0.9).
  return 0.1 * uniformSpherePdf() + 0.9 * pdf_sum / n;
}

}  // namespace lensim::render
