// The explorer's live preview: the scene rendered through the chosen lens in progressive passes
// (1 spp first, then more samples each pass, averaged), each pass handed out as a PNG, and
// cancelled within the renderer's cancellation granularity (one pixel's samples) when a newer
// request for the same view arrives.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/optics/tilt_shift.h"

namespace lensim::scene {
struct Scene;
}
namespace lensim::camera {
class Camera;
}
namespace lensim::render {
struct RenderWorld;
}

namespace lensim::serve {

/// Encodes linear RGB times `gain` as an 8-bit sRGB PNG in memory (values clamped to [0, 1]).
std::string encodePngSrgb(const io::Image& image, double gain = 1);

/// The gain that brings the image's mean luminance to middle grey (0.18), as a camera's
/// averaging meter would; 1 for a black image. Clamped to 2^-10 .. 2^10.
double autoExposureGain(const io::Image& image);

struct PreviewRequest {
  std::string scene_path;  ///< resolved
  std::string lens_path;   ///< resolved
  double aperture_diameter_mm = 0;
  double focus_distance_m = 10;  ///< may be infinity
  /// The lens's tilt and shift against the film (the camera's "lenstilt" and "lensshift"; the
  /// scene's own are replaced: none unless asked).
  optics::TiltShift tilt_shift;
  /// A zoom lens's configuration (1-based) or focal length (mm): the camera's "configuration"
  /// and "focallength" (the scene's own are replaced: none unless asked).
  std::optional<int> configuration;
  std::optional<double> zoom_focal_length_mm;
  int width = 320;   ///< the height follows the scene's aspect ratio
  int max_spp = 64;  ///< stop refining at this many samples per pixel
  int seed = 0;
  double exposure_stops = 0;   ///< brightens (or darkens) the image by 2^stops
  bool auto_exposure = false;  ///< meter the first frame instead (then fixed for the stream)
};

struct PreviewFrame {
  int pass = 0;
  int spp = 0;  ///< samples per pixel so far
  int width = 0, height = 0;
  double render_ms = 0;       ///< this pass
  double elapsed_ms = 0;      ///< since the request started
  double exposure_stops = 0;  ///< the exposure applied to the PNG
  std::string png;
};

/// Scenes are parsed and built once and kept (keyed by path and modification time), with what
/// the renderer builds from their world (acceleration structure, lights, textures, materials,
/// media: render::prepareWorld); the realistic cameras of the last kCameraCacheSize previews are
/// kept too (their start-up traces the exit-pupil bounds), keyed by everything that makes them
/// (scene, lens file and its modification time, stop, focus, tilt and shift, zoom, preview width).
/// A preview of a scene and lens seen before starts rendering at once; its image is the same bit
/// for bit as an uncached render's.
class PreviewRenderer {
 public:
  PreviewRenderer();
  /// The scene (loads it on first use). Throws lensim::Error for a scene that cannot be loaded,
  /// or one whose camera cannot be replaced by a pbrt-v4 realistic camera (pbrt-v1/v2 realistic
  /// cameras work in millimetre camera space).
  std::shared_ptr<const scene::Scene> scene(const std::string& path);

  /// The scene copied with its camera made the realistic camera of the request and its film
  /// scaled to the preview size. Throws lensim::Error.
  scene::Scene previewScene(const PreviewRequest& request);

  /// Renders `prepared` (from previewScene(request)) pass after pass, at a lower priority (the
  /// calling thread and the render's workers are given nice 10: call it from a thread of its own),
  /// calling `on_frame` after each, until max_spp, until `cancel` is set or `on_frame` returns
  /// false. Returns true if it ran to the end. Throws lensim::Error.
  /// The cancellation is seen within one pixel's samples while rendering, and before and after
  /// each set-up step and PNG encoding.
  bool run(const scene::Scene& prepared, const PreviewRequest& request,
           const std::atomic<bool>& cancel,
           const std::function<bool(const PreviewFrame&)>& on_frame);

  static constexpr size_t kCameraCacheSize = 8;
  struct CacheStats {
    int scene_loads = 0;    ///< scenes parsed and built (with their world)
    int camera_builds = 0;  ///< cameras made (cache misses)
    int camera_hits = 0;
  };
  CacheStats cacheStats() const;

 private:
  struct Cached {
    std::filesystem::file_time_type mtime;
    std::shared_ptr<const scene::Scene> scene;
    std::shared_ptr<const render::RenderWorld> world;
    uint64_t generation = 0;  ///< a new one each load: camera keys name it
  };
  Cached cached(const std::string& path);
  std::shared_ptr<const camera::Camera> camera(const scene::Scene& prepared,
                                               const PreviewRequest& request, uint64_t generation);

  /// LENSIM_PREVIEW_NO_CACHE set: every preview builds its world and camera (the behaviour
  /// before the caches, for bench/serve-latency's comparison).
  bool cache_world_and_cameras_ = true;
  mutable std::mutex mutex_;
  std::map<std::string, Cached> scenes_;
  uint64_t generation_ = 0;
  // Most recently used first.
  std::vector<std::pair<std::string, std::shared_ptr<const camera::Camera>>> cameras_;
  CacheStats stats_;
};

/// The running preview of each view (a page has two): starting one cancels the view's previous
/// one. Thread-safe.
class PreviewViews {
 public:
  struct Ticket {
    std::shared_ptr<std::atomic<bool>> cancel;
    std::shared_ptr<std::atomic<int64_t>> cancelled_at_ns;  ///< steady clock, when cancelled
    uint64_t generation = 0;
    /// Set by the preview's render thread when it has returned (finished, cancelled or failed).
    std::shared_ptr<std::atomic<bool>> stopped = std::make_shared<std::atomic<bool>>(false);
    /// Milliseconds since the cancellation (NaN if not cancelled).
    double msSinceCancel() const;
  };
  /// Cancels the view's running preview (if any) and registers a new one. It then waits (at most
  /// `wait_ms`) for the old render to return: the old render runs niced, and while this request
  /// sleeps instead of setting up its own preview the old threads get the CPU at once and stop.
  Ticket start(const std::string& view, int wait_ms = 100);
  /// Cancels the view's running preview; false if there was none.
  bool cancel(const std::string& view);
  /// Cancels every running preview (the server is stopping).
  void cancelAll();
  /// Forgets the ticket if it is still the view's current one.
  void finish(const std::string& view, const Ticket& ticket);
  int running() const;

 private:
  mutable std::mutex mutex_;
  uint64_t next_ = 1;
  std::map<std::string, Ticket> views_;
};

}  // namespace lensim::serve
