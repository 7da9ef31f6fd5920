// Bidirectional path tracing: pbrt-v4's "bdpt" integrator (Pharr, Jakob & Humphreys, 4th ed.,
// sec. 13.4 of the online edition's "Bidirectional Methods"; Veach 1997, ch. 10). Each camera
// sample traces a camera subpath and a light subpath and connects every prefix pair (s light
// vertices, t camera vertices); each connection is weighted by multiple importance sampling over
// all the strategies that could have made the same path, from the vertices' forward and reverse
// area densities (pbrt-v4's MISWeight: the balance heuristic; the power heuristic on request).
//
// Strategies with t = 1 connect a light-subpath vertex to the camera through
// camera::Camera::sampleWi and land anywhere on the film: they are returned as splats (the
// renderer adds them with Film::addSplat; the image is the pixels' estimates plus the splats
// divided by the samples per pixel). Every camera that supports importance works, the realistic
// lens camera included (pbrt-v4 refuses that combination, its issue #279): the connection enters
// the lens at a point on its front element that sampleWi finds, and the MIS densities of camera
// vertices come from Camera::rayPdf.
//
// Light subpaths are traced for every camera sample, also when the camera sample yields no ray
// (a realistic lens vignettes it): their t = 1 splats do not depend on the camera ray, and
// dropping them would darken the image by the fraction of blocked samples.
//
// Not handled: participating media (the scene builder renders such scenes with volpath, warned).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lensim/render/materials/bsdf.h"
#include "lensim/render/integrators/integrator.h"

namespace lensim::camera {
class Camera;
struct CameraRay;
}  // namespace lensim::camera

namespace lensim::render {

/// A contribution of a t = 1 strategy: where it meets the film and its value (already divided
/// by nothing: the renderer adds it with the splat convention).
struct BdptSplat {
  Vec2 raster;
  SampledSpectrum L;
};

namespace bdpt {

enum class VertexType { Camera, Light, Surface };

/// A subpath vertex (pbrt-v4's Vertex).
struct Vertex {
  VertexType type = VertexType::Surface;
  SampledSpectrum beta;  ///< the subpath's throughput up to here
  Vec3 p;
  Vec3 ng{0, 0, 0};  ///< geometric normal; zero for vertices not on a surface
  Vec3 ns{0, 0, 0};  ///< shading normal
  Vec3 wo;           ///< surface: unit direction toward the vertex the walk came from
  BSDF bsdf;
  /// Light: its light (nullptr: a camera ray that escaped, seeing the infinite lights);
  /// Surface: the area light there, or nullptr.
  const Light* light = nullptr;
  SurfaceHit hit;  ///< surface: the hit (area light emission, normal, uv)
  bool delta = false;
  double pdf_fwd = 0, pdf_rev = 0;  ///< area densities (solid angle toward infinite lights)
  double time = 0;                  ///< camera vertex: the shutter time that places a moving camera

  bool onSurface() const { return ng.x != 0 || ng.y != 0 || ng.z != 0; }
};

/// What the vertex functions read.
struct Context {
  const SceneContext* sc = nullptr;
  const camera::Camera* camera = nullptr;
  const LightSampler* light_sampler = nullptr;  ///< light choice for light subpaths and s = 1
  std::vector<const Light*> infinite;
  double scene_radius = 1;
  double mis_exponent = 1;  ///< 1: balance heuristic (pbrt-v4); 2: power heuristic
  int max_depth = 5;
};

/// A light vertex on an area light (not an infinite one): its point can be connected to the
/// camera (s = 1, t = 1).
bool isAreaLightEnd(const Vertex& v);
bool isConnectible(const Vertex& v);
bool isLight(const Vertex& v);
bool isDeltaLight(const Vertex& v);
bool isInfiniteLight(const Vertex& v);
/// Solid-angle density pdf at `from` toward `next` as a density per unit area at next.
double convertDensity(const Vertex& from, double pdf, const Vertex& next);
/// Area density at `next` of sampling it from v (which was reached from prev; nullptr for an
/// end vertex).
double pdf(const Context& ctx, const Vertex& v, const Vertex* prev, const Vertex& next,
           double lambda_nm);
/// Area density at `next` of a light subpath starting at the light vertex v.
double pdfLight(const Context& ctx, const Vertex& v, const Vertex& next);
/// Density of choosing the light vertex v (light choice and position) as a light subpath's start.
double pdfLightOrigin(const Context& ctx, const Vertex& v, const Vertex& next);
/// The MIS weight of strategy (s, t) (pbrt-v4's MISWeight); `sampled` replaces camera[0]
/// (t = 1) or else light[0] (s = 1). light and camera are modified during the call and restored.
double misWeight(const Context& ctx, Vertex* light, Vertex* camera, const Vertex& sampled, int s,
                 int t, double lambda_nm);

/// Subpaths (pbrt-v4's GenerateCameraSubpath / GenerateLightSubpath); return the vertex count.
int cameraSubpath(const Context& ctx, const camera::CameraRay& ray, SampledWavelengths& lambda,
                  Sampler& sampler, RayCounts& counts, Vertex* path);
/// The light subpath's rays are traced at shutter time `time` (the camera sample's).
int lightSubpath(const Context& ctx, double time, SampledWavelengths& lambda, Sampler& sampler,
                 RayCounts& counts, Vertex* path);

}  // namespace bdpt

/// The bdpt integrator for one render.
class BdptIntegrator {
 public:
  /// Throws lensim::Error for what unsupported() names.
  BdptIntegrator(const SceneContext& sc, const camera::Camera& camera, double mis_exponent = 1);
  ~BdptIntegrator();
  /// The pixel estimate of one camera sample (ray: nullptr when the sample yields none) and its
  /// t = 1 splats, appended to `splats`. `time`: the sample's shutter time (seconds).
  SampledSpectrum Li(const camera::CameraRay* ray, double time, SampledWavelengths& lambda,
                     Sampler& sampler, RayCounts& counts, std::vector<BdptSplat>& splats) const;
  const bdpt::Context& context() const { return ctx_; }
  /// Why bdpt cannot render with this camera and these lights (a camera without importance, a
  /// light without emission sampling), or "" if it can.
  static std::string unsupported(const SceneContext& sc, const camera::Camera& camera);

 private:
  bdpt::Context ctx_;
  std::unique_ptr<LightSampler> light_sampler_;
};

}  // namespace lensim::render
