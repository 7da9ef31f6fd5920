// Rendering a scene: image tiles in parallel (oneTBB), deterministic for a given seed and
// sample count whatever the number of threads (each pixel's samples depend only on the pixel,
// the sample index and the seed, and only that pixel's samples touch it), progress reporting,
// statistics and cancellation (the image so far is returned, marked partial).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>

#include "lensim/io/image.h"
#include "lensim/render/film.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::render {

/// Overrides of the scene's settings (pbrt's command-line flags).
struct RenderOptions {
  std::optional<int> spp;                         ///< samples per pixel
  std::optional<int> seed;                        ///< sampler seed
  int threads = 0;                                ///< 0: all cores
  std::optional<std::array<double, 4>> crop;      ///< crop window x0 x1 y0 y1 (fractions)
  std::optional<std::array<int, 4>> pixelbounds;  ///< pixel bounds x0 x1 y0 y1
  bool progress = false;                          ///< print a progress bar to stderr
  const std::atomic<bool>* cancel = nullptr;      ///< set to stop early (Ctrl-C)
  /// Reproduce two numerical artefacts of pbrt-v2 that old reference images carry (the CS348B /
  /// NTU assignment's references): its ray epsilon proportional to the camera-ray parameter
  /// (SceneContext::pbrt_v2_epsilon) and its realistic camera's zero-weight samples
  /// (camera::CameraOptions::pbrt_v2_quirks). Off by default: both are physically wrong.
  bool pbrt_v2_quirks = false;
};

/// What happened during a render.
struct RenderStats {
  double wall_s = 0;               ///< rendering time (excluding scene and camera set-up)
  double setup_s = 0;              ///< building the acceleration structure, lights, textures
  double camera_startup_s = 0;     ///< the camera's startupSeconds()
  uint64_t camera_samples = 0;     ///< camera samples taken
  uint64_t camera_rays = 0;        ///< camera samples that produced a ray
  uint64_t no_ray_samples = 0;     ///< camera samples without a ray (blocked by the lens)
  uint64_t outside_samples = 0;    ///< of those, samples where no light reaches the film (outside
                                   ///< the image circle: camera::Camera::reachesFilm)
  uint64_t nonfinite_samples = 0;  ///< NaN/inf radiance samples, discarded
  uint64_t rays = 0;               ///< all rays traced (intersection and shadow)
  uint64_t invalid_rays = 0;       ///< rays with non-finite or huge numbers, dropped (Accel)
  uint64_t nonfinite_pixels = 0;   ///< NaN/inf pixel values of the image, written as 0
  int spp = 0;
  int threads = 0;
  bool partial = false;  ///< cancelled before every tile was done
  std::string camera;    ///< the camera's description
};

struct RenderResult {
  io::Image image;  ///< R, G, B over the rendered pixel bounds; metadata describes the render
  PixelBounds bounds;
  RenderStats stats;
};

/// Renders the scene. Throws lensim::Error for scenes that cannot be rendered (camera errors,
/// unreadable textures).
RenderResult render(const scene::Scene& scene, const RenderOptions& options);

/// The statistics as the lines `lensim render` prints.
std::string formatStats(const RenderStats& stats);

}  // namespace lensim::render
