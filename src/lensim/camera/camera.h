// Cameras: turn a film sample into a world-space ray and its weight.
//
// Conventions (as pbrt): raster space has (0, 0) at the top-left corner of the full image, x to
// the right and y down, in pixels; camera space looks down +z with +y up; world rays are in scene
// units (metres in pbrt-v4 scenes). A camera sample that yields no ray (the lens blocks it, or
// the film point lies outside the image circle) returns nullopt: it contributes nothing, and the
// renderer counts it.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>

#include "lensim/util/animated_transform.h"
#include "lensim/util/vec.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::sampling {
class Filter;
}

namespace lensim::camera {

/// Wavelengths per camera path (render::kSpectrumSamples; the renderer checks they agree).
inline constexpr int kCameraWavelengths = 4;
/// The wavelengths renders trace, nm (render::kLambdaMin_nm .. kLambdaMax_nm; the renderer
/// checks they agree): the range a camera's lens must refract and bound.
inline constexpr double kRenderedMin_nm = 360, kRenderedMax_nm = 830;

/// What the renderer hands a camera for one sample.
struct CameraSample {
  Vec2 film_raster;     ///< continuous raster position in the full image (pixels)
  Vec2 lens{0.5, 0.5};  ///< [0,1)^2: position on the lens / exit pupil
  double time = 0;      ///< [0,1): position in the shutter interval
  /// For a camera whose lens disperses: the path's wavelengths (nm), the hero first; 0: not
  /// given (a dispersive lens then refracts at its primary wavelength).
  std::array<double, kCameraWavelengths> lambda_nm{};
  /// The pixel the sample belongs to (raster position of its centre), the pixel filter and the
  /// sample's filter weight f/pdf: a dispersive lens weighs each wavelength by where its ray
  /// meets the film (realistic.cpp, "Dispersive lenses"). Without a filter it keeps only the
  /// hero wavelength.
  Vec2 pixel_centre;
  const sampling::Filter* filter = nullptr;
  double filter_weight = 1;
  /// [0,1)^3 for a camera with flare (Camera::flare): the ghost path's choice of surface pair
  /// ([0]) and its direction toward the lens ([1], [2]); unused otherwise.
  std::array<double, 3> ghost_u{};
};

/// A camera ray in world space and the weight of its radiance estimate.
///
/// The film accumulates weight x L. For a pinhole-style camera weight is 1 and the film holds
/// radiance; for the realistic camera it is the importance of the ray for the film irradiance
/// (Kolb et al.: shutter time x cos^4(theta) x A / z^2 for a uniformly sampled pupil region of
/// area A at axial distance z), so the film holds exposure, as pbrt-v4's does with that camera.
struct CameraRay {
  Vec3 origin;     ///< world space, scene units
  Vec3 direction;  ///< world space, unit length
  double weight = 1;
  double time = 0;  ///< shutter time of the ray (seconds from shutter open)
  /// The ray was refracted at the sample's hero wavelength only (a dispersive lens): the path
  /// must terminate its secondary wavelengths (SampledWavelengths::terminateSecondary), whose
  /// rays would leave the lens in other directions.
  bool hero_only = false;
  /// A dispersive lens with the sample's pixel filter known: wavelength i of the path's estimate
  /// is weighted by wavelength_weight[i] instead of weight (spectral MIS over the wavelengths'
  /// film points); `weight` stays the hero's own, for a path that drops its other wavelengths
  /// later (at a dispersive material).
  bool per_wavelength = false;
  std::array<double, kCameraWavelengths> wavelength_weight{};
  /// A lens-flare ghost path (Camera::generateGhostRay): bdpt gives its light-tracing (t = 1)
  /// strategy no weight (the ghost's t = 1 connection is not the direct one sampleWi makes).
  bool ghost = false;
};

/// A connection from a scene point to the camera (pbrt-v4's Camera::SampleWi), for light
/// tracing and bidirectional methods.
///
/// Measurement convention (shared by every camera, the realistic one included): the light
/// tracer's contribution of radiance L, arriving at the scene point `ref` from the camera's side
/// along -wi, to the film is
///     importance[i] * L[i] * |cos(n_ref, wi)| / pdf      (times the BSDF at ref, for a surface)
/// splatted at `film_raster` (Film::addSplat), and the final image is the pixels' filtered
/// estimates plus the splats divided by the samples per pixel (pbrt-v4's convention). A camera's
/// importance is thus on the same scale as generateRay's weight: a light tracer and a path tracer
/// estimate the same image.
struct CameraWiSample {
  Vec3 wi;              ///< unit direction from ref toward p_lens (world)
  double distance = 0;  ///< |p_lens - ref| (scene units)
  Vec3 p_lens;          ///< world point where the connection enters the camera (pinhole: the eye;
                        ///< thin lens: the lens point; realistic: a point on the front element)
  Vec3 n_lens;          ///< the camera's forward axis at p_lens (world, unit)
  double pdf = 0;       ///< solid-angle density of wi at ref
  Vec2 film_raster;     ///< where the connection meets the film (full-image raster)
  /// Importance per path wavelength (all equal for a lens that does not disperse).
  std::array<double, kCameraWavelengths> importance{};
  /// The connection was traced through a dispersive lens at the hero wavelength only (the
  /// others would meet the film elsewhere): the path must terminate its secondary wavelengths
  /// (SampledWavelengths::terminateSecondary) before using it; importance[0] is the hero's.
  bool hero_only = false;
};

/// Density of a camera ray as generateRay samples it: pdf_pos per unit area of the surface the
/// ray starts on (pinhole: 1, a delta; thin lens: the lens disc; realistic: the front element),
/// pdf_dir per unit solid angle of its direction (both in world scene units).
struct CameraRayPdf {
  double pdf_pos = 0, pdf_dir = 0;
};

/// The interface every camera implements.
class Camera {
 public:
  virtual ~Camera() = default;
  /// A ray for the sample, or nullopt when the sample yields none.
  virtual std::optional<CameraRay> generateRay(const CameraSample& sample) const = 0;
  /// The most samples generateRays takes at once.
  static constexpr int kMaxBatch = 16;
  /// Rays for n <= kMaxBatch samples, each exactly what generateRay gives (a camera may work
  /// on them together: the realistic camera traces them through the lens side by side).
  virtual void generateRays(const CameraSample* samples, int n,
                            std::optional<CameraRay>* rays) const {
    for (int i = 0; i < n; ++i) rays[i] = generateRay(samples[i]);
  }
  /// Whether light reaches the film at the sample's raster position at all, at the sample's
  /// (hero) wavelength (false outside a lens's image circle at that wavelength), for render
  /// statistics: samples there yield no ray by design, and nothing is traced for them.
  virtual bool reachesFilm(const CameraSample& /*sample*/) const { return true; }
  /// Seconds spent building the camera (lens set-up, pupil bounds), for render statistics.
  virtual double startupSeconds() const { return 0; }
  /// Processor seconds of that (all threads): on a loaded machine the wall time above mostly
  /// measures the wait for a core.
  virtual double startupCpuSeconds() const { return 0; }
  /// One line for logs: the type and its main settings.
  virtual std::string describe() const = 0;

  // Lens flare (the realistic camera's "bool flare"; docs/flare.md, "Rendering ghosts").
  /// Whether each camera sample also yields a ghost path (generateGhostRay), and generateRay's
  /// weights include the lens's reflection losses.
  virtual bool flare() const { return false; }
  /// Whether light paths (lighttracer, bdpt) can carry this camera's flare (sampleGhostWi).
  virtual bool flareInLightPaths() const { return flare(); }
  /// The ghost path of the sample (sample.ghost_u chooses it): a camera ray whose radiance,
  /// weighted per wavelength (CameraRay::per_wavelength), the film adds to the direct path's in
  /// the same sample; nullopt when the path is blocked (an estimate of zero).
  virtual std::optional<CameraRay> generateGhostRay(const CameraSample& /*sample*/) const {
    return std::nullopt;
  }
  /// The light tracer's side of flare: a connection from the scene point ref through one ghost
  /// path of the lens (u[0] chooses the pair as generateGhostRay does, u[1], u[2] the point on
  /// the front element) to the film, with the importance of that path per wavelength (the
  /// coatings' R at its two reflections and T at every other crossing, over the pair's
  /// probability) on sampleWi's scale; nullopt when it is blocked or misses the film.
  virtual std::optional<CameraWiSample> sampleGhostWi(
      const Vec3& /*ref*/, const std::array<double, 3>& /*u*/,
      const std::array<double, kCameraWavelengths>& /*lambda_nm*/, double /*time*/) const {
    return std::nullopt;
  }

  // Camera importance (light tracing, bdpt). Cameras that support it override all five.
  /// Whether sampleWi, importance and pdf are implemented.
  virtual bool supportsImportance() const { return false; }
  /// A connection from the scene point ref (time: shutter time of the path) through the camera
  /// to its film, u in [0,1)^2 choosing the lens point; nullopt if none reaches the film (the
  /// point is behind the camera, the lens blocks the path, it lands outside the image).
  virtual std::optional<CameraWiSample> sampleWi(
      const Vec3& /*ref*/, Vec2 /*u*/, const std::array<double, kCameraWavelengths>& /*lambda_nm*/,
      double /*time*/) const {
    return std::nullopt;
  }
  /// Importance of the world ray (o, d) leaving the camera as generateRay makes them (hero
  /// wavelength lambda_nm) at shutter time `time`, and its raster point; 0 if no film point
  /// sends that ray.
  virtual double importance(const Vec3& /*o*/, const Vec3& /*d*/, double /*lambda_nm*/,
                            Vec2* /*film_raster*/, double /*time*/) const {
    return 0;
  }
  /// Density per unit world area (of the lens disc, the front element: the surface p_lens lies
  /// on) with which sampleWi(ref, ...) picks the point p_lens; 1 for a camera whose connections
  /// all pass one point (pinhole, spherical: a delta), 0 where sampleWi cannot pick it. The
  /// realistic camera's depends on ref (it aims at the part of the front element light from ref
  /// can pass); the projective cameras' does not. For bidirectional MIS.
  /// (`time`: the shutter time, which places a moving camera.)
  virtual double pdfWiPos(const Vec3& /*ref*/, const Vec3& /*p_lens*/, double /*time*/) const {
    return 0;
  }
  /// Densities with which generateRay produces the world ray (o, d) at shutter time `time`.
  virtual CameraRayPdf rayPdf(const Vec3& /*o*/, const Vec3& /*d*/, double /*lambda_nm*/,
                              double /*time*/) const {
    return {};
  }
};

/// Choices the scene file does not make.
struct CameraOptions {
  /// Reproduce pbrt-v2's camera-ray artefact that the assignment's reference images carry: a
  /// sample yields no ray when the ray one pixel to the right or one pixel down, through the same
  /// lens point, is blocked (pbrt-v2's Camera::GenerateRayDifferential returns weight 0 then; the
  /// assignment's realistic camera inherits it). Realistic camera only; off by default.
  bool pbrt_v2_quirks = false;
};

/// World from camera space over the shutter, as pbrt-v4's CameraTransform
/// (src/pbrt/cameras.h; BasicSceneBuilder::Camera in scene.cpp): the inverses of the CTM at the
/// Camera directive at its start and end times, decomposed and interpolated (an animated camera:
/// ActiveTransform before Camera). Every camera places its rays with it at the ray's time.
AnimatedTransform worldFromCamera(const scene::Scene& scene);

/// Builds the camera the scene describes (its film gives the resolution and sensor size).
/// Throws lensim::Error, located at the Camera directive, for settings that cannot work.
std::unique_ptr<Camera> makeCamera(const scene::Scene& scene, const CameraOptions& options = {});

/// The realistic camera (pbrt-v1/v2 and v3/v4 parameters); see realistic.h.
std::unique_ptr<Camera> makeRealisticCamera(const scene::Scene& scene,
                                            const CameraOptions& options = {});

}  // namespace lensim::camera
