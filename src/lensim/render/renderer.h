// Rendering a scene: image tiles in parallel (oneTBB), deterministic for a given seed and
// sample count whatever the number of threads (each pixel's samples depend only on the pixel,
// the sample index and the seed, and only that pixel's samples touch it), progress reporting,
// statistics and cancellation (the image so far is returned, marked partial).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/film/film.h"

namespace lensim::scene {
struct Scene;
}
namespace lensim::camera {
class Camera;
}

namespace lensim::render {

/// The state of a render at a point in time, for checkpoints and resuming: which of the
/// renderer's tiles (kTileSize pixels square, row by row over the rendered bounds) are finished,
/// and the exact film sums (only the finished tiles' pixels are kept; the others are zero).
struct RenderCheckpoint {
  static constexpr int kTileSize = 16;
  PixelBounds bounds;              ///< the pixels rendered (the part's tile of the image)
  std::vector<uint8_t> tile_done;  ///< 1 for a finished tile
  std::vector<PixelSum> sums;      ///< bounds-sized, row by row
  /// Lens flare: the ghost layer's sums, bounds-sized (empty for a film without the layer).
  std::vector<GhostSum> ghost_sums;
  bool complete() const;
  int tilesDone() const;
};

/// What a render builds from the scene's world before its first sample: the acceleration
/// structure, textures, materials, lights and media (none of them depends on the camera or the
/// film). prepareWorld builds it once so that renders of the same world with other cameras or
/// films (the explorer's previews) skip the build: RenderOptions::world. It keeps references into
/// the scene it was built from, which must outlive it.
struct RenderWorld;
std::shared_ptr<const RenderWorld> prepareWorld(const scene::Scene& scene);

/// Overrides of the scene's settings (pbrt's command-line flags).
struct RenderOptions {
  std::optional<int> spp;                         ///< samples per pixel
  std::optional<int> seed;                        ///< sampler seed
  int threads = 0;                                ///< 0: all cores
  std::optional<std::array<double, 4>> crop;      ///< crop window x0 x1 y0 y1 (fractions)
  std::optional<std::array<int, 4>> pixelbounds;  ///< pixel bounds x0 x1 y0 y1
  bool progress = false;                          ///< print a progress bar to stderr
  const std::atomic<bool>* cancel = nullptr;      ///< set to stop early (Ctrl-C)
  /// Progressive rendering (the explorer's preview): the samples go in passes of 1, 1, 2, 4, ...
  /// per pixel (the total doubling up to spp) and this is called after each with the image so
  /// far and its samples per pixel. Returning false stops the render (the result is partial).
  /// Unset: one pass. Either way each pixel gets the same samples in the same order.
  std::function<bool(const io::Image& image, int spp_done)> on_pass;
  /// Reproduce two numerical artefacts of pbrt-v2 that old reference images carry (the CS348B /
  /// NTU assignment's references): its ray epsilon proportional to the camera-ray parameter
  /// (SceneContext::pbrt_v2_epsilon) and its realistic camera's zero-weight samples
  /// (camera::CameraOptions::pbrt_v2_quirks). Off by default: both are physically wrong.
  bool pbrt_v2_quirks = false;
  /// A dispersive lens keeps only each path's hero wavelength (pbrt-v4's way) instead of
  /// weighting every wavelength by its own film point (realistic.cpp, "Dispersive lenses"); for
  /// comparing the two (bench/dispersion).
  bool dispersion_hero_only = false;
  // Distributed renders (render/parts.h, docs/cluster.md).
  /// Render only tile `first` of `second` tiles of the pixel bounds (render/parts.h tileBounds).
  std::optional<std::pair<int, int>> tile;
  /// Take only the sample indices [first, second) of every pixel (of the sampler's spp).
  std::optional<std::pair<int, int>> spp_range;
  /// Keep the exact film sums in RenderResult::sums (for writing a part).
  bool keep_sums = false;
  /// Called from a background thread every checkpoint_every_s seconds, and once at the end,
  /// with the finished tiles so far (e.g. to write a checkpoint file). Exceptions it throws stop
  /// the render and are rethrown by render().
  std::function<void(const RenderCheckpoint&)> on_checkpoint;
  double checkpoint_every_s = 60;
  /// Continue from this state: its finished tiles are taken as they are and not rendered again.
  /// Its bounds must be the bounds this render covers.
  const RenderCheckpoint* resume = nullptr;
  /// Seconds the caller spent reading, parsing and building the scene (PLY files, subdivision)
  /// before render(); reported in RenderStats::load_s and the total set-up time.
  double scene_load_s = 0;
  /// Render with this camera instead of making one from the scene (the explorer keeps its
  /// realistic cameras: their start-up traces the exit-pupil bounds). It must be the camera
  /// camera::makeCamera(scene) makes; the image is then the same bit for bit.
  std::shared_ptr<const camera::Camera> camera;
  /// Render with this world (prepareWorld of a scene with this scene's shapes, materials,
  /// textures, lights and media; its camera and film may differ) instead of building it.
  std::shared_ptr<const RenderWorld> world;
};

/// What happened during a render.
struct RenderStats {
  double wall_s = 0;            ///< rendering time (excluding scene and camera set-up)
  double setup_s = 0;           ///< building the acceleration structure, lights, textures
  double load_s = 0;            ///< reading, parsing and building the scene before (RenderOptions)
  double camera_startup_s = 0;  ///< the camera's startupSeconds()
  double camera_startup_cpu_s = 0;  ///< the camera's startupCpuSeconds()
  uint64_t camera_samples = 0;      ///< camera samples taken
  uint64_t camera_rays = 0;         ///< camera samples that produced a ray
  uint64_t ghost_rays = 0;          ///< lens flare: ghost paths that got through the lens
  /// lens flare: the light tracer's and bdpt's connections through a ghost path that carried
  /// light (render::RayCounts::ghost_connections)
  uint64_t ghost_connections = 0;
  uint64_t no_ray_samples = 0;      ///< camera samples without a ray (blocked by the lens)
  uint64_t outside_samples = 0;     ///< of those, samples where no light reaches the film (outside
                                    ///< the image circle: camera::Camera::reachesFilm)
  uint64_t nonfinite_samples = 0;   ///< NaN/inf radiance samples, discarded
  uint64_t rays = 0;                ///< all rays traced (intersection and shadow)
  uint64_t invalid_rays = 0;        ///< rays with non-finite or huge numbers, dropped (Accel)
  uint64_t nonfinite_pixels = 0;    ///< NaN/inf pixel values of the image, written as 0
  int spp = 0;
  int spp_begin = 0, spp_end = 0;  ///< the sample indices taken, [spp_begin, spp_end)
  int threads = 0;
  int tiles_resumed = 0;  ///< tiles taken from RenderOptions::resume
  bool partial = false;   ///< cancelled before every tile was done
  std::string camera;     ///< the camera's description
};

struct RenderResult {
  io::Image image;     ///< R, G, B over the rendered pixel bounds; metadata describes the render
  PixelBounds bounds;  ///< the pixels rendered
  PixelBounds full_bounds;     ///< the pixel bounds of the whole render (bounds, unless a tile)
  std::vector<PixelSum> sums;  ///< the exact film sums over bounds (RenderOptions::keep_sums)
  /// Lens flare: the exact ghost-layer sums over bounds (RenderOptions::keep_sums; empty
  /// without the layer).
  std::vector<GhostSum> ghost_sums;
  RenderStats stats;
};

/// What a render with these options covers, before it starts.
struct RenderPlan {
  PixelBounds full_bounds;  ///< the pixel bounds of the whole render (crop window, pixel bounds)
  PixelBounds bounds;       ///< the pixels this render takes (full_bounds, or a tile of it)
  int spp = 0;              ///< the sampler's samples per pixel (after its rounding)
  int spp_begin = 0, spp_end = 0;  ///< the sample indices taken
  int seed = 0;
};

/// The plan of render(scene, options). Throws lensim::Error for empty bounds, a bad tile or a
/// bad sample range.
RenderPlan planRender(const scene::Scene& scene, const RenderOptions& options);

/// Renders the scene. Throws lensim::Error for scenes that cannot be rendered (camera errors,
/// unreadable textures).
RenderResult render(const scene::Scene& scene, const RenderOptions& options);

/// The statistics as the lines `lensim render` prints.
std::string formatStats(const RenderStats& stats);

}  // namespace lensim::render
