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
// The camera vertex's position: strategies with t >= 2 pick it as generateRay does (density
// rayPdf().pdf_pos per unit area of the lens / front element / film plane), t = 1 as sampleWi
// does, given the next vertex (Camera::pdfWiPos). pbrt-v4 leaves both out of its MIS weights
// (GenerateCameraSubpath computes pdfPos and drops it; MISWeight's camera loop stops at i = 1,
// src/pbrt/cpu/integrators.cpp), which is exact for its perspective camera, whose SampleWi picks
// the lens point uniformly as GenerateRay does. lensim's orthographic thin lens (sampleWi's
// density depends on the depth of the point), its orthographic pinhole (a delta direction, the
// position sampled over the film) and the realistic camera (sampleWi aims at the part of the
// front element light from the point can pass) differ: the weights carry the ratio
// pdfWiPos / pdf_pos (Vertex::wi_pos_ratio), so they are the balance (or power) heuristic of the
// strategies' true densities for every camera.
//
// Light subpaths are traced for every camera sample, also when the camera sample yields no ray
// (a realistic lens vignettes it): their t = 1 splats do not depend on the camera ray, and
// dropping them would darken the image by the fraction of blocked samples.
//
// A dispersive lens: the renderer generates bdpt's camera rays at the hero wavelength only
// (the path integrator's spectral MIS over the wavelengths' film points needs the pixel filter
// per camera sample; a light subpath shares the camera path's wavelengths and splats anywhere),
// so every strategy of the sample carries the hero alone, and t = 1 connections through the lens
// (sampleWi's hero_only) terminate the secondary wavelengths before they contribute, also for
// samples without a camera ray. Unbiased; the colour noise is that of one wavelength per path.
//
// Participating media (pbrt-v4's BDPT with media): the random walks track delta collisions by
// the majorant (render/integrators/media_tracking.h) and leave medium vertices, whose scattering
// function is the Henyey-Greenstein phase function; every connection (t = 1 to the camera, s = 1
// to a light, and between subpaths) carries the transmittance between its ends, through
// interface surfaces; camera subpaths start in the camera's medium, light subpaths in the
// light's (lightMedium). The MIS densities of medium vertices are those of their phase function
// (solid angle to area without the cosine), as pbrt-v4's, whose MIS also leaves out the
// distance-sampling densities (a partition of unity all the same). Chromatic media: the
// throughputs are divided by the hero wavelength's densities and each vertex keeps r, its
// subpath's densities at the other wavelengths over the hero's (as volpath's r_u); a strategy's
// contribution is divided by the mean of the two subpaths' r product, the one-sample MIS over
// the hero choice that volpath uses, so the two estimate the same image. Emission from media
// reaches the image by the s = 0 strategy alone (no light subpath starts in a medium), weight 1.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lensim/render/integrators/base.h"
#include "lensim/render/materials/bsdf.h"

namespace lensim::camera {
class Camera;
struct CameraRay;
}  // namespace lensim::camera

namespace lensim::render {

using namespace lensim::sampling;

/// A contribution of a t = 1 strategy: where it meets the film and its value (already divided
/// by nothing: the renderer adds it with the splat convention).
struct BdptSplat {
  Vec2 raster;
  SampledSpectrum L;
};

namespace bdpt {

enum class VertexType { Camera, Light, Surface, Medium };

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
  /// Camera vertex: the density with which the t = 1 strategy (Camera::sampleWi from the next
  /// vertex) picks this position, over generateRay's (rayPdf().pdf_pos); see cameraPositionRatio.
  double wi_pos_ratio = 1;
  /// Camera vertex: the subpath starts with a lens-flare ghost path (CameraRay::ghost), whose
  /// light-tracing (t = 1) strategy has no weight (misWeight).
  bool ghost = false;
  /// The medium around the vertex: medium vertices, camera vertices, light vertices; surface
  /// vertices: the medium the walk reached them in (Scene::media index; -1 vacuum).
  int medium = -1;
  double g = 0;  ///< medium vertex: Henyey-Greenstein asymmetry
  /// The subpath's densities with each wavelength as the hero over the hero's (chromatic media).
  SampledSpectrum r = SampledSpectrum(1.0);

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
  /// The camera's rays run along one direction (the orthographic pinhole): the first vertex's
  /// density from the camera is pdf_pos |cos| per unit area, not through a solid angle.
  bool camera_delta_direction = false;
  bool media = false;      ///< the scene's media are tracked (SceneContext::media)
  int camera_medium = -1;  ///< the medium camera rays start in
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
/// pdfWiPos(x1, x0) / pdf_pos for the camera vertex x0 of a path whose next vertex is x1: the
/// t = 1 strategy's density of x0 over that of the strategies that start with generateRay's ray
/// (pdf_pos: rayPdf's for the ray from x0 toward x1); over |x1 - x0|^2 more for a camera of one
/// direction (Context::camera_delta_direction), whose first vertex density is pdf_pos |cos|
/// per unit area where pdf() gives pdf_dir |cos| / d^2 with a delta pdf_dir of 1. 1 where
/// pdf_pos is 0 (no density to compare with).
double cameraPositionRatio(const Context& ctx, double pdf_pos, const Vec3& x0, const Vec3& x1,
                           double time);
/// The MIS weight of strategy (s, t) (pbrt-v4's MISWeight); `sampled` replaces camera[0]
/// (t = 1) or else light[0] (s = 1). light and camera are modified during the call and restored.
double misWeight(const Context& ctx, Vertex* light, Vertex* camera, const Vertex& sampled, int s,
                 int t, double lambda_nm);

/// Subpaths (pbrt-v4's GenerateCameraSubpath / GenerateLightSubpath); return the vertex count.
/// rng: the path's stream for tracking in media (needed when ctx.media); L_medium: emission of
/// media the camera subpath passes is added there (the s = 0 strategy's, weight 1).
int cameraSubpath(const Context& ctx, const camera::CameraRay& ray, SampledWavelengths& lambda,
                  Sampler& sampler, RayCounts& counts, Vertex* path, Rng* rng = nullptr,
                  SampledSpectrum* L_medium = nullptr);
/// The light subpath's rays are traced at shutter time `time` (the camera sample's).
int lightSubpath(const Context& ctx, double time, SampledWavelengths& lambda, Sampler& sampler,
                 RayCounts& counts, Vertex* path, Rng* rng = nullptr);

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

/// bdpt as an integrator of the family (base.h): BdptIntegrator::Li, its splats added to the
/// film. Throws for what BdptIntegrator::unsupported names.
std::unique_ptr<Integrator> makeBdptFamilyIntegrator(const SceneContext& sc,
                                                     const camera::Camera& camera);

}  // namespace lensim::render
