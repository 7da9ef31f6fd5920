#include "lensim/serve/preview.h"

#include <optional>
#include <thread>

#include <fmt/format.h>
#include <png.h>
#include <sys/resource.h>
#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "lensim/camera/camera.h"
#include "lensim/render/renderer.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::serve {

using Clock = std::chrono::steady_clock;
constexpr int kPreviewNice = 10;

namespace {

void appendPng(png_structp png, png_bytep data, png_size_t n) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<char*>(data), n);
}

void flushPng(png_structp) {}

/// Lowers the calling thread's priority (Linux: nice is per thread).
void lowerThisThread() {
  setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), kPreviewNice);
}

/// Lowers the priority of the worker threads that join the preview's arena.
class NiceWorkers : public tbb::task_scheduler_observer {
 public:
  explicit NiceWorkers(tbb::task_arena& arena) : tbb::task_scheduler_observer(arena) {
    observe(true);
  }
  ~NiceWorkers() override { observe(false); }
  void on_scheduler_entry(bool is_worker) override {
    if (is_worker) lowerThisThread();
  }
};

}  // namespace

double autoExposureGain(const io::Image& image) {
  const auto r = image.channelIndex("R"), g = image.channelIndex("G"), b = image.channelIndex("B");
  if (!r || !g || !b) return 1;
  // The arithmetic mean: a 1-spp frame is mostly noise, black pixels included, and its mean is
  // still the image's (a log average would be dragged down by every black pixel).
  double sum = 0;
  size_t n = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const double lum =
          0.2126 * image.at(x, y, *r) + 0.7152 * image.at(x, y, *g) + 0.0722 * image.at(x, y, *b);
      if (!std::isfinite(lum)) continue;
      sum += std::max(0.0, lum);
      ++n;
    }
  if (n == 0 || !(sum > 0)) return 1;  // black: nothing to meter
  return std::clamp(0.18 * double(n) / sum, std::exp2(-10.0), std::exp2(10.0));
}

std::string encodePngSrgb(const io::Image& image, double gain) {
  const auto r = image.channelIndex("R"), g = image.channelIndex("G"), b = image.channelIndex("B");
  if (!r || !g || !b) throw Error("preview: the image has no R, G, B channels");
  std::vector<uint8_t> rows(size_t(image.width) * image.height * 3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = float(gain) * image.at(x, y, c == 0 ? *r : c == 1 ? *g : *b);
        const float e = io::linearToSrgb(std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f);
        rows[(size_t(y) * image.width + x) * 3 + c] = uint8_t(std::lround(e * 255));
      }
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    throw Error("preview: cannot create a PNG encoder");
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw Error("preview: PNG encoding failed");
  }
  png_set_write_fn(png, &out, appendPng, flushPng);
  png_set_compression_level(png, 1);  // speed over size: the page is on this machine
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y)
    png_write_row(png, rows.data() + size_t(y) * image.width * 3);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

PreviewRenderer::PreviewRenderer()
    : cache_world_and_cameras_(std::getenv("LENSIM_PREVIEW_NO_CACHE") == nullptr) {}

PreviewRenderer::Cached PreviewRenderer::cached(const std::string& path) {
  std::error_code ec;
  const auto mtime = std::filesystem::last_write_time(path, ec);
  {
    std::lock_guard lock(mutex_);
    auto it = scenes_.find(path);
    if (it != scenes_.end() && it->second.mtime == mtime) return it->second;
  }
  // Loaded outside the lock: a slow scene does not hold up other requests.
  Cached c;
  c.mtime = mtime;
  c.scene = std::make_shared<const scene::Scene>(scene::loadScene(path));
  if (cache_world_and_cameras_) c.world = render::prepareWorld(*c.scene);
  std::lock_guard lock(mutex_);
  c.generation = ++generation_;
  ++stats_.scene_loads;
  scenes_[path] = c;
  return c;
}

std::shared_ptr<const scene::Scene> PreviewRenderer::scene(const std::string& path) {
  return cached(path).scene;
}

std::shared_ptr<const camera::Camera> PreviewRenderer::camera(const scene::Scene& prepared,
                                                              const PreviewRequest& rq,
                                                              uint64_t generation) {
  std::error_code ec;
  const auto lens_mtime = std::filesystem::last_write_time(rq.lens_path, ec);
  // Everything previewScene(rq) takes to make the camera, the scene by its load generation.
  const std::string key =
      fmt::format("{}\n{}\n{}\n{}\n{:a}\n{:a}\n{:a} {:a} {:a} {:a}\n{} {:a}\n{}\n{}", generation,
                  rq.scene_path, rq.lens_path, lens_mtime.time_since_epoch().count(),
                  rq.aperture_diameter_mm, rq.focus_distance_m, rq.tilt_shift.tilt_deg.x,
                  rq.tilt_shift.tilt_deg.y, rq.tilt_shift.shift_mm.x, rq.tilt_shift.shift_mm.y,
                  rq.configuration.value_or(0), rq.zoom_focal_length_mm.value_or(0.0),
                  prepared.film.x_resolution, prepared.film.y_resolution);
  {
    std::lock_guard lock(mutex_);
    for (size_t i = 0; i < cameras_.size(); ++i)
      if (cameras_[i].first == key) {
        std::rotate(cameras_.begin(), cameras_.begin() + std::ptrdiff_t(i),
                    cameras_.begin() + std::ptrdiff_t(i) + 1);
        ++stats_.camera_hits;
        return cameras_.front().second;
      }
  }
  std::shared_ptr<const camera::Camera> cam = camera::makeCamera(prepared);
  std::lock_guard lock(mutex_);
  ++stats_.camera_builds;
  cameras_.insert(cameras_.begin(), {key, cam});
  if (cameras_.size() > kCameraCacheSize) cameras_.pop_back();
  return cam;
}

PreviewRenderer::CacheStats PreviewRenderer::cacheStats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

scene::Scene PreviewRenderer::previewScene(const PreviewRequest& rq) {
  std::shared_ptr<const scene::Scene> base = scene(rq.scene_path);
  if (base->camera.legacy_realistic)
    throw Error(base->camera.loc,
                "the preview needs a pbrt-v3/v4 scene: this pbrt-v1/v2 realistic camera works in "
                "millimetre camera space");
  if (base->camera.type == "spherical" || base->camera.type == "orthographic")
    throw Error(base->camera.loc,
                fmt::format("the preview replaces the camera by a lens; a {} camera has no "
                            "direction of view for it",
                            base->camera.type));
  if (!(rq.width >= 16 && rq.width <= 1920))
    throw Error(fmt::format("preview width {}: expected 16 to 1920 pixels", rq.width));
  scene::Scene s = *base;
  scene::Realistic r = s.camera.realistic.value_or(scene::Realistic{});
  r.lens_file = rq.lens_path;
  r.lens_file_as_written = rq.lens_path;
  r.aperture_diameter_mm = rq.aperture_diameter_mm;
  r.focus_distance_m = rq.focus_distance_m;
  r.film_distance_mm.reset();
  r.focus_method = "thick";
  r.tilt_shift = rq.tilt_shift;
  r.configuration = rq.configuration;
  r.zoom_focal_length_mm = rq.zoom_focal_length_mm;
  s.camera.type = "realistic";
  s.camera.realistic = r;
  const double aspect = double(s.film.y_resolution) / s.film.x_resolution;
  s.film.x_resolution = rq.width;
  s.film.y_resolution = std::max(1, int(std::lround(rq.width * aspect)));
  s.film.crop_window = {0, 1, 0, 1};
  s.film.pixel_bounds.reset();
  return s;
}

bool PreviewRenderer::run(const scene::Scene& s, const PreviewRequest& rq,
                          const std::atomic<bool>& cancel,
                          const std::function<bool(const PreviewFrame&)>& on_frame) {
  const auto t0 = Clock::now();
  // The preview renders below the priority of the optics requests, so that the diagram and the
  // plots of a slider move are not slowed down by the render it also starts.
  lowerThisThread();
  tbb::task_arena arena;
  NiceWorkers nice(arena);
  // One render in progressive passes (1, 1, 2, 4, ... samples per pixel): the scene, the camera
  // and the acceleration structure are set up once.
  render::RenderOptions ro;
  ro.spp = rq.max_spp;
  ro.seed = rq.seed;
  ro.cancel = &cancel;
  // The world and the camera from the caches: the first frame does not wait for the
  // acceleration structure or the exit-pupil bounds of a scene and lens seen before, and a
  // cancellation is not held up by them either.
  if (cancel.load()) return false;
  const Cached c = cached(rq.scene_path);
  // `s` was made from the scene as loaded then; should the file have changed since (a new
  // load), its world is built afresh rather than taken from a scene that may differ.
  const scene::Scene& b = *c.scene;
  if (b.shapes.size() == s.shapes.size() && b.meshes.size() == s.meshes.size() &&
      b.objects.size() == s.objects.size() && b.instances.size() == s.instances.size() &&
      b.materials.size() == s.materials.size() && b.textures.size() == s.textures.size() &&
      b.lights.size() == s.lights.size() && b.media.size() == s.media.size())
    ro.world = c.world;
  if (cancel.load()) return false;
  if (cache_world_and_cameras_) ro.camera = camera(s, rq, c.generation);
  if (cancel.load()) return false;
  int pass = 0;
  auto t_pass = Clock::now();
  bool stopped_by_caller = false;
  double gain = std::exp2(rq.exposure_stops);
  ro.on_pass = [&](const io::Image& image, int spp_done) {
    PreviewFrame f;
    f.pass = pass++;
    f.spp = spp_done;
    f.width = image.width;
    f.height = image.height;
    f.render_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_pass).count();
    if (cancel.load()) return false;  // no PNG for a cancelled preview
    // A raw film's expected electrons, shown as lensim develop would colour them.
    const io::Image raw = render::isRawImage(image) ? render::previewRawImage(image) : io::Image();
    const io::Image& shown = render::isRawImage(image) ? raw : image;
    if (rq.auto_exposure && f.pass == 0) gain = autoExposureGain(shown);
    f.exposure_stops = std::log2(gain);
    f.png = encodePngSrgb(shown, gain);
    f.elapsed_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    const bool go_on = on_frame(f);
    stopped_by_caller = !go_on;
    t_pass = Clock::now();
    return go_on;
  };
  render::RenderResult res;
  arena.execute([&] { res = render::render(s, ro); });
  return !res.stats.partial && !stopped_by_caller;
}

namespace {

void cancelTicket(const PreviewViews::Ticket& t) {
  t.cancelled_at_ns->store(Clock::now().time_since_epoch().count());
  t.cancel->store(true);
}

}  // namespace

double PreviewViews::Ticket::msSinceCancel() const {
  if (!cancel->load()) return std::numeric_limits<double>::quiet_NaN();
  return double(Clock::now().time_since_epoch().count() - cancelled_at_ns->load()) * 1e-6 *
         (double(Clock::period::num) / Clock::period::den) * 1e9;
}

PreviewViews::Ticket PreviewViews::start(const std::string& view, int wait_ms) {
  std::optional<Ticket> old;
  Ticket t{std::make_shared<std::atomic<bool>>(false), std::make_shared<std::atomic<int64_t>>(0),
           0};
  {
    std::lock_guard lock(mutex_);
    auto it = views_.find(view);
    if (it != views_.end()) {
      cancelTicket(it->second);
      old = it->second;
    }
    t.generation = next_++;
    views_[view] = t;
  }
  // Let the old render see its flag and return before this request competes for the CPU.
  if (old)
    for (int i = 0; i < wait_ms && !old->stopped->load(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return t;
}

bool PreviewViews::cancel(const std::string& view) {
  std::lock_guard lock(mutex_);
  auto it = views_.find(view);
  if (it == views_.end()) return false;
  cancelTicket(it->second);
  views_.erase(it);
  return true;
}

void PreviewViews::cancelAll() {
  std::lock_guard lock(mutex_);
  for (auto& [view, ticket] : views_) cancelTicket(ticket);
  views_.clear();
}

void PreviewViews::finish(const std::string& view, const Ticket& t) {
  t.stopped->store(true);  // also for a preview that never started its render
  std::lock_guard lock(mutex_);
  auto it = views_.find(view);
  if (it != views_.end() && it->second.generation == t.generation) views_.erase(it);
}

int PreviewViews::running() const {
  std::lock_guard lock(mutex_);
  return int(views_.size());
}

}  // namespace lensim::serve
