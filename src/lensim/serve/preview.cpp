#include "lensim/serve/preview.h"

#include <fmt/format.h>
#include <png.h>

#include <algorithm>
#include <cmath>

#include "lensim/render/renderer.h"
#include "lensim/scene/builder.h"
#include "lensim/util/error.h"

namespace lensim::serve {

using Clock = std::chrono::steady_clock;

namespace {

void appendPng(png_structp png, png_bytep data, png_size_t n) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<char*>(data), n);
}

void flushPng(png_structp) {}

}  // namespace

std::string encodePngSrgb(const io::Image& image) {
  const auto r = image.channelIndex("R"), g = image.channelIndex("G"), b = image.channelIndex("B");
  if (!r || !g || !b) throw Error("preview: the image has no R, G, B channels");
  std::vector<uint8_t> rows(size_t(image.width) * image.height * 3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = image.at(x, y, c == 0 ? *r : c == 1 ? *g : *b);
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

std::shared_ptr<const scene::Scene> PreviewRenderer::scene(const std::string& path) {
  std::error_code ec;
  const auto mtime = std::filesystem::last_write_time(path, ec);
  {
    std::lock_guard lock(mutex_);
    auto it = scenes_.find(path);
    if (it != scenes_.end() && it->second.mtime == mtime) return it->second.scene;
  }
  // Loaded outside the lock: a slow scene does not hold up other requests.
  auto s = std::make_shared<const scene::Scene>(scene::loadScene(path));
  std::lock_guard lock(mutex_);
  scenes_[path] = {mtime, s};
  return s;
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
  io::Image sum;
  int total = 0;
  for (int pass = 0; total < rq.max_spp; ++pass) {
    if (cancel.load()) return false;
    // 1, 1, 2, 4, 8, ... samples: a first frame at once, then about doubling the total.
    const int n = std::min(rq.max_spp - total, pass == 0 ? 1 : std::max(1, total));
    render::RenderOptions ro;
    ro.spp = n;
    ro.seed = rq.seed + pass;  // independent passes: their average is an estimate with total spp
    ro.cancel = &cancel;
    const auto t_pass = Clock::now();
    render::RenderResult res = render::render(s, ro);
    if (res.stats.partial) return false;
    if (sum.pixels.empty()) {
      sum = res.image;
      for (float& v : sum.pixels) v *= float(n);
    } else {
      for (size_t i = 0; i < sum.pixels.size(); ++i) sum.pixels[i] += float(n) * res.image.pixels[i];
    }
    total += n;
    io::Image mean = sum;
    for (float& v : mean.pixels) v /= float(total);
    PreviewFrame f;
    f.pass = pass;
    f.spp = total;
    f.width = mean.width;
    f.height = mean.height;
    f.render_ms = std::chrono::duration<double, std::milli>(Clock::now() - t_pass).count();
    f.png = encodePngSrgb(mean);
    f.elapsed_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (!on_frame(f)) return false;
  }
  return true;
}

PreviewViews::Ticket PreviewViews::start(const std::string& view) {
  std::lock_guard lock(mutex_);
  auto it = views_.find(view);
  if (it != views_.end()) it->second.cancel->store(true);
  Ticket t{std::make_shared<std::atomic<bool>>(false), next_++};
  views_[view] = t;
  return t;
}

bool PreviewViews::cancel(const std::string& view) {
  std::lock_guard lock(mutex_);
  auto it = views_.find(view);
  if (it == views_.end()) return false;
  it->second.cancel->store(true);
  views_.erase(it);
  return true;
}

void PreviewViews::finish(const std::string& view, const Ticket& t) {
  std::lock_guard lock(mutex_);
  auto it = views_.find(view);
  if (it != views_.end() && it->second.generation == t.generation) views_.erase(it);
}

int PreviewViews::running() const {
  std::lock_guard lock(mutex_);
  return int(views_.size());
}

}  // namespace lensim::serve
