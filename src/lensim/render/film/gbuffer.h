// pbrt-v4's GBufferFilm auxiliary data (src/pbrt/film.h and film.cpp, VisibleSurface and
// GBufferFilm): the first surface a camera ray hits, with its position, normals, (u, v), depth
// slopes and albedo, for Film "gbuffer".
#pragma once

#include <optional>

#include "lensim/camera/camera.h"
#include "lensim/render/integrators/integrator.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/util/animated_transform.h"
#include "lensim/util/transform.h"

namespace lensim::render {

/// The first surface seen along a camera ray, in the gbuffer's output coordinates.
struct VisibleSurface {
  Vec3 p;      ///< position
  Vec3 n, ns;  ///< geometric and shading normals (after bump or normal maps), facing the ray
               ///< origin; not normalised (pbrt-v4 normalises the pixel's sums)
  Vec2 uv;     ///< surface (u, v)
  double dzdx = 0, dzdy = 0;  ///< change of camera-space depth per pixel step in x and y
  Vec3 albedo;  ///< the BSDF's directional albedo at the ray's direction, as linear sRGB under
                ///< the colour space's illuminant (pbrt-v4: bsdf.rho(wo) times the illuminant)
};

/// A camera ray with the rays of the film points 1/20 pixel to the right and below, through the
/// same lens point (pbrt-v4's CameraBase::GenerateRayDifferential for cameras without an analytic
/// differential; either may be missing).
struct CameraRayDifferential {
  Vec3 o, d;
  std::optional<Vec3> dx_o, dx_d, dy_o, dy_d;  ///< extrapolated to one whole pixel
};
/// The film offset the differential rays are traced at, in pixels (pbrt-v4's 0.05).
inline constexpr double kDifferentialEpsilon = 0.05;

/// The camera rays of the samples `cs[0..n)` moved kDifferentialEpsilon pixel in x (dx) and in y
/// (dy), through the same lens points; `shift` is scratch space for n samples.
void gbufferDifferentials(const camera::Camera& cam, const camera::CameraSample* cs, int n,
                          camera::CameraSample* shift, std::optional<camera::CameraRay>* dx,
                          std::optional<camera::CameraRay>* dy);
/// The differential of `ray` from its shifted rays, extrapolated to one pixel (pbrt-v4:
/// o + (o_shifted - o) / epsilon, likewise for the direction).
CameraRayDifferential differential(const camera::CameraRay& ray,
                                   const std::optional<camera::CameraRay>& dx,
                                   const std::optional<camera::CameraRay>& dy);

/// The gbuffer's output coordinates ("string coordinatesystem"): camera space at the sample's
/// shutter time, or world space. pbrt-v4's VisibleSurface (src/pbrt/film.cpp) transforms the hit
/// by cameraTransform.CameraFromRender(si.time), so a camera that moves during the shutter gives
/// each sample's position, normals and depth slopes in the camera space of that sample's time.
class GBufferFrame {
 public:
  explicit GBufferFrame(const scene::Scene& scene);
  /// Output from world at shutter time `time` (the ray's time, seconds): the static transform
  /// itself where the camera does not move, else `scratch` filled.
  const Transform& outputFromWorld(double time, Transform& scratch) const;

 private:
  Transform static_;  ///< world: identity; camera: camera from world at the start time
  AnimatedTransform world_from_camera_;  ///< animated only for "camera" with a moving camera
};

/// The first surface along the ray (pbrt-v4's PathIntegrator: the first intersection with a BSDF;
/// surfaces cut out by alpha and "interface" materials are passed), or nullopt if the ray leaves
/// the scene. `output_from_world`: the gbuffer's coordinate system ("camera": the camera's
/// transform; "world": identity), which also gives the depth z of dzdx and dzdy (as pbrt-v4);
/// `diff_scale` scales the differentials as pbrt-v4 does (max(1/8, 1/sqrt(samples per pixel))).
std::optional<VisibleSurface> visibleSurface(const SceneContext& sc,
                                             const CameraRayDifferential& ray,
                                             SampledWavelengths lambda,
                                             const Transform& output_from_world, double diff_scale,
                                             RayCounts& counts);

}  // namespace lensim::render
