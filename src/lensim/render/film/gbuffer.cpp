// pbrt-v4's VisibleSurface for the gbuffer film; see gbuffer.h.
#include "lensim/render/film/gbuffer.h"

#include <cmath>

#include "lensim/render/materials/bsdf.h"
#include "lensim/scene/description.h"

namespace lensim::render {

namespace {

/// Where the differential ray o + t d meets the plane through p with normal n (pbrt-v4's
/// SurfaceInteraction::ComputeDifferentials), minus p; zero if parallel.
Vec3 planeOffset(const Vec3& p, const Vec3& n, const Vec3& o, const Vec3& d) {
  const double den = dot(n, d);
  if (den == 0) return {0, 0, 0};
  const double t = dot(n, p - o) / den;
  return o + d * t - p;
}

}  // namespace

GBufferFrame::GBufferFrame(const scene::Scene& scene) {
  if (scene.film.gbuffer_coordinates == "world") return;
  static_ = scene.camera.camera_from_world;
  world_from_camera_ = camera::worldFromCamera(scene);
}

const Transform& GBufferFrame::outputFromWorld(double time, Transform& scratch) const {
  if (!world_from_camera_.isAnimated()) return static_;
  scratch = inverse(world_from_camera_.interpolate(time));
  return scratch;
}

void gbufferDifferentials(const camera::Camera& cam, const camera::CameraSample* cs, int n,
                          camera::CameraSample* shift, std::optional<camera::CameraRay>* dx,
                          std::optional<camera::CameraRay>* dy) {
  for (int axis = 0; axis < 2; ++axis) {
    for (int k = 0; k < n; ++k) {
      shift[k] = cs[k];
      shift[k].filter = nullptr;  // the ray only, no spectral filter weights
      (axis == 0 ? shift[k].film_raster.x : shift[k].film_raster.y) += kDifferentialEpsilon;
    }
    cam.generateRays(shift, n, axis == 0 ? dx : dy);
  }
}

CameraRayDifferential differential(const camera::CameraRay& ray,
                                   const std::optional<camera::CameraRay>& dx,
                                   const std::optional<camera::CameraRay>& dy) {
  CameraRayDifferential r;
  r.o = ray.origin;
  r.d = ray.direction;
  if (dx) {
    r.dx_o = ray.origin + (dx->origin - ray.origin) / kDifferentialEpsilon;
    r.dx_d = ray.direction + (dx->direction - ray.direction) / kDifferentialEpsilon;
  }
  if (dy) {
    r.dy_o = ray.origin + (dy->origin - ray.origin) / kDifferentialEpsilon;
    r.dy_d = ray.direction + (dy->direction - ray.direction) / kDifferentialEpsilon;
  }
  return r;
}

std::optional<VisibleSurface> visibleSurface(const SceneContext& sc,
                                             const CameraRayDifferential& ray,
                                             SampledWavelengths lambda,
                                             const Transform& output_from_world, double diff_scale,
                                             RayCounts& counts) {
  Ray r{ray.o, ray.d, INFINITY};
  for (int interfaces = 0; interfaces <= 100; ++interfaces) {
    const auto hit = intersectScene(sc, r, counts);
    if (!hit) return std::nullopt;
    const SurfaceHit& h = *hit;
    const Vec3 wo = -r.d / length(r.d);
    const TextureEvalContext tctx{h.p, h.uv, h.ns};
    const int material =
        sc.materials->resolve(sc.scene->shapes[size_t(h.shape)].material, tctx, wo);
    if (sc.materials->isInterface(material)) {  // no BSDF: pbrt-v4 skips the intersection
      r.o = offsetOrigin(h.p, h.ng, r.d);
      continue;
    }
    auto bxdf = sc.materials->bxdf(material, tctx, lambda);
    Vec3 ns = sc.materials->shadingNormal(material, tctx, h.ns, h.dpdu);
    if (sc.materials->hasBump(material))
      ns = sc.materials->bumpedNormal(material, tctx, ns, h.dpdu, h.dpdv, h.dndu, h.dndv);
    const BSDF bsdf(ns, h.dpdu, bxdf);
    // pbrt-v4's PathIntegrator estimates the albedo as bsdf.rho(wo) with 16 fixed samples; a
    // fixed stratified set here (exact for Lambertian and specular lobes, whose sampling weight
    // f |cos| / pdf is constant).
    constexpr int kRho = 16;
    SampledSpectrum rho(0.0);
    for (int i = 0; i < kRho; ++i) {
      const double uc = (i + 0.5) / kRho;
      const Vec2 u{((i * 5) % kRho + 0.5) / kRho, ((i * 11 + 3) % kRho + 0.5) / kRho};
      if (auto bs = bsdf.sample_f(wo, uc, u); bs && bs->pdf > 0)
        rho += bs->f * (std::abs(dot(bs->wi, ns)) / bs->pdf);
    }
    rho = rho / double(kRho);
    const RGBColorSpace& cs = RGBColorSpace::sRGB();
    VisibleSurface vs;
    vs.albedo = cs.toRgb(sampledToXyz(rho * cs.illuminant()->sample(lambda), lambda));
    const Vec3 ng = dot(h.ng, wo) < 0 ? -h.ng : h.ng;  // pbrt-v4: FaceForward(n, wo)
    const Vec3 nsf = dot(ns, wo) < 0 ? -ns : ns;
    vs.p = output_from_world.applyPoint(h.p);
    vs.n = output_from_world.applyNormal(ng);
    vs.ns = output_from_world.applyNormal(nsf);
    vs.uv = h.uv;
    // pbrt-v4: the camera ray's differentials scaled by max(1/8, 1/sqrt(spp)), met with the
    // tangent plane; dzdx is the z of that offset in the output coordinates.
    const auto slope = [&](const std::optional<Vec3>& o, const std::optional<Vec3>& d) {
      if (!o || !d) return 0.0;
      const Vec3 so = ray.o + (*o - ray.o) * diff_scale, sd = ray.d + (*d - ray.d) * diff_scale;
      return output_from_world.applyVector(planeOffset(h.p, h.ng, so, sd)).z;
    };
    vs.dzdx = slope(ray.dx_o, ray.dx_d);
    vs.dzdy = slope(ray.dy_o, ray.dy_d);
    return vs;
  }
  return std::nullopt;
}

}  // namespace lensim::render
