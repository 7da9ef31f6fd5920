// Tiles, threads, progress and statistics. See renderer.h.
#include "lensim/render/renderer.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "lensim/camera/camera.h"
#include "lensim/render/film/gbuffer.h"
#include "lensim/render/integrators/bdpt.h"
#include "lensim/render/integrators/directlighting.h"
#include "lensim/render/integrators/integrator.h"
#include "lensim/render/integrators/lighttracer.h"
#include "lensim/render/integrators/volpath.h"
#include "lensim/render/media/media.h"
#include "lensim/render/parts.h"
#include "lensim/sampling/filter.h"
#include "lensim/scene/builder.h"
#include "lensim/util/error.h"
#include "lensim/util/limits.h"
#include "lensim/util/log.h"

namespace lensim::render {

namespace {

using Clock = std::chrono::steady_clock;

std::unique_ptr<Sampler> makeSampler(const scene::Scene& scene, int spp, int seed) {
  const std::string& t = scene.sampler.type;
  if (t == "independent") return std::make_unique<IndependentSampler>(spp, seed);
  if (t == "stratified") {
    int xs = int(std::lround(std::sqrt(double(spp))));
    if (xs * xs != spp) xs = spp;
    return std::make_unique<StratifiedSampler>(xs, spp / xs, scene.sampler.jitter, seed);
  }
  if (t == "zsobol")
    return std::make_unique<ZSobolSampler>(
        spp, Point2i{scene.film.x_resolution, scene.film.y_resolution},
        parseSobolRandomization(scene.sampler.randomization), seed);
  if (t != "paddedsobol") {
    static std::once_flag once;
    std::call_once(once, [&] {
      logWarning(
          fmt::format("sampler \"{}\" renders as lensim's padded Owen-scrambled Sobol "
                      "sampler",
                      t));
    });
  }
  return std::make_unique<PaddedSobolSampler>(spp, seed);
}

std::unique_ptr<Filter> makeFilter(const scene::Filter& f) {
  const Vec2 r{f.x_radius, f.y_radius};
  if (f.type == "box") return std::make_unique<BoxFilter>(r);
  if (f.type == "mitchell") return std::make_unique<MitchellFilter>(r, f.b, f.c);
  if (f.type == "lanczos") return std::make_unique<LanczosSincFilter>(r, f.tau);
  if (f.type == "triangle") return std::make_unique<TriangleFilter>(r);
  return std::make_unique<GaussianFilter>(r, f.sigma);
}

/// The finished tiles' sums of `film` (the others zero).
RenderCheckpoint snapshot(const Film& film, const std::vector<std::atomic<uint8_t>>& done,
                          int tiles_x) {
  constexpr int kTile = RenderCheckpoint::kTileSize;
  RenderCheckpoint c;
  c.bounds = film.bounds();
  c.tile_done.resize(done.size());
  c.sums.assign(film.sums().size(), PixelSum{});
  const int w = c.bounds.width(), h = c.bounds.height();
  for (size_t t = 0; t < done.size(); ++t) {
    c.tile_done[t] = done[t].load(std::memory_order_acquire);
    if (!c.tile_done[t]) continue;
    const int tx = int(t) % tiles_x, ty = int(t) / tiles_x;
    for (int y = ty * kTile; y < std::min(h, (ty + 1) * kTile); ++y)
      for (int x = tx * kTile; x < std::min(w, (tx + 1) * kTile); ++x)
        c.sums[size_t(y) * size_t(w) + size_t(x)] = film.sums()[size_t(y) * size_t(w) + size_t(x)];
  }
  return c;
}

}  // namespace

bool RenderCheckpoint::complete() const {
  return !tile_done.empty() && tilesDone() == int(tile_done.size());
}

int RenderCheckpoint::tilesDone() const {
  int n = 0;
  for (uint8_t d : tile_done) n += d != 0;
  return n;
}

namespace {

std::string fmtDuration(double s) {
  if (s < 60) return fmt::format("{:.1f}s", s);
  const int m = int(s / 60);
  if (m < 60) return fmt::format("{}m{:02d}s", m, int(s) % 60);
  return fmt::format("{}h{:02d}m", m / 60, m % 60);
}

}  // namespace

RenderPlan planRender(const scene::Scene& scene, const RenderOptions& opt) {
  const int x_res = scene.film.x_resolution, y_res = scene.film.y_resolution;
  PixelBounds bounds{0, x_res, 0, y_res};
  if (opt.pixelbounds) {
    const auto& b = *opt.pixelbounds;
    bounds = {b[0], b[1], b[2], b[3]};
  } else if (opt.crop) {
    bounds = cropWindowBounds(x_res, y_res, *opt.crop);
  } else if (scene.film.pixel_bounds) {
    const auto& b = *scene.film.pixel_bounds;
    bounds = {b[0], b[1], b[2], b[3]};
  } else {
    bounds = cropWindowBounds(x_res, y_res, scene.film.crop_window);
  }
  bounds.x0 = std::clamp(bounds.x0, 0, x_res), bounds.x1 = std::clamp(bounds.x1, 0, x_res);
  bounds.y0 = std::clamp(bounds.y0, 0, y_res), bounds.y1 = std::clamp(bounds.y1, 0, y_res);
  if (bounds.width() <= 0 || bounds.height() <= 0) {
    const std::string empty = fmt::format("empty pixel bounds [{}, {}) x [{}, {})", bounds.x0,
                                          bounds.x1, bounds.y0, bounds.y1);
    // Bounds from the command line are not the scene file's fault.
    if (opt.pixelbounds || opt.crop)
      throw Error(
          fmt::format("{} gives {} on the {}x{} film; expected a window of at least one "
                      "pixel",
                      opt.pixelbounds ? "--pixelbounds" : "--cropwindow", empty, x_res, y_res));
    throw Error(scene.film.loc, empty);
  }
  const PixelBounds full_bounds = bounds;
  if (opt.tile) bounds = tileBounds(full_bounds, opt.tile->first, opt.tile->second);
  RenderPlan plan;
  plan.full_bounds = full_bounds;
  plan.bounds = bounds;
  plan.seed = opt.seed.value_or(scene.sampler.seed);
  plan.spp = makeSampler(scene, opt.spp.value_or(scene.sampler.pixel_samples), plan.seed)
                 ->samplesPerPixel();
  plan.spp_begin = 0, plan.spp_end = plan.spp;
  if (opt.spp_range) {
    plan.spp_begin = opt.spp_range->first, plan.spp_end = opt.spp_range->second;
    if (plan.spp_begin < 0 || plan.spp_end > plan.spp || plan.spp_begin >= plan.spp_end)
      throw Error(
          fmt::format("--spp-range {}:{} is not a non-empty range of the {} samples per "
                      "pixel (expected 0 <= A < B <= {})",
                      plan.spp_begin, plan.spp_end, plan.spp, plan.spp));
  }
  return plan;
}

struct RenderWorld {
  explicit RenderWorld(const scene::Scene& scene)
      : accel(scene),
        textures(scene),
        materials(scene, textures),
        lights(scene, accel, textures),
        media(scene) {}
  Accel accel;
  Textures textures;
  Materials materials;
  LightSet lights;
  Media media;
};

std::shared_ptr<const RenderWorld> prepareWorld(const scene::Scene& scene) {
  return std::make_shared<const RenderWorld>(scene);
}

RenderResult render(const scene::Scene& scene, const RenderOptions& opt) {
  const auto t_setup = Clock::now();
  camera::CameraOptions camera_options;
  camera_options.pbrt_v2_quirks = opt.pbrt_v2_quirks;
  std::shared_ptr<const camera::Camera> cam = opt.camera;
  if (!cam) cam = camera::makeCamera(scene, camera_options);
  const int x_res = scene.film.x_resolution, y_res = scene.film.y_resolution;
  const RenderPlan plan = planRender(scene, opt);
  const PixelBounds full_bounds = plan.full_bounds;
  const PixelBounds bounds = plan.bounds;

  const std::shared_ptr<const RenderWorld> world = opt.world ? opt.world : prepareWorld(scene);
  const Accel& accel = world->accel;
  const Textures& textures = world->textures;
  const Materials& materials = world->materials;
  const LightSet& lights = world->lights;
  SceneContext sc;
  sc.scene = &scene;
  sc.accel = &accel;
  sc.textures = &textures;
  sc.materials = &materials;
  sc.lights = &lights;
  sc.max_depth = scene.integrator.max_depth;
  sc.regularize = scene.integrator.regularize;
  sc.pbrt_v2_epsilon = opt.pbrt_v2_quirks;
  sc.camera_from_world = scene.camera.camera_from_world;
  const Media& media = world->media;
  // Subsurface materials need volpath's tracking (render/media/subsurface.h): the path integrator
  // renders them with it too, without the scene's media (which it ignores, with a warning).
  bool volpath = scene.integrator.type == "volpath" || media.hasSubsurface();
  // lighttracer and bdpt track the scene's media too (render/integrators/media_tracking.h).
  const bool splatting = scene.integrator.type == "lighttracer" || scene.integrator.type == "bdpt";
  if (volpath || splatting) sc.media = &media;
  sc.scene_media = scene.integrator.type == "volpath" || splatting;
  sc.camera_medium = scene.camera.medium;
  // pbrt-v1–v3's directlighting (render/integrators/directlighting.h).
  const bool direct_lighting = scene.integrator.type == "directlighting";
  const DirectLightingOptions direct_opt{scene.integrator.all_lights, scene.integrator.max_depth};
  if (direct_lighting && opt.pbrt_v2_quirks)
    logWarning(
        fmt::format("{}: --pbrt-v2-quirks: pbrt-v2's ray epsilon is reproduced by the path "
                    "integrator only; \"directlighting\" uses lensim's ray offsets",
                    scene.integrator.loc.str()));
  for (const scene::Material& m : scene.materials)
    sc.has_interfaces = sc.has_interfaces || m.kind == scene::MaterialKind::Interface;
  for (const scene::Shape& s : scene.shapes) sc.has_alpha = sc.has_alpha || s.alpha.has_value();

  // A camera sensor lensim does not bundle is warned once, at its parameter, by the builder
  // (scene/film_sensor.cpp).
  const int spp_req = opt.spp.value_or(scene.sampler.pixel_samples);
  if (spp_req <= 0 || spp_req > kMaxSamplesPerPixel)
    throw Error(
        fmt::format("{} samples per pixel: expected 1 to {}", spp_req, kMaxSamplesPerPixel));
  const int seed = opt.seed.value_or(scene.sampler.seed);
  std::unique_ptr<Sampler> proto = makeSampler(scene, spp_req, seed);
  const int spp = proto->samplesPerPixel();
  const int spp_begin = plan.spp_begin, spp_end = plan.spp_end;
  std::unique_ptr<Filter> filter = makeFilter(scene.filter);
  Film film(scene, bounds);
  // A splatting integrator (lighttracer, bdpt): each pixel sample starts a light path that
  // splats anywhere in the image, so a tile's pixels are not its own: no tiles of a distributed
  // render, no exact part sums, no checkpoints, no resuming (render/film.h, splats).
  auto refuseSplatting = [&](const char* integrator, const char* what) {
    const char* refused = opt.tile            ? "--tile"
                          : opt.keep_sums     ? "parts (exact sums)"
                          : opt.on_checkpoint ? "checkpoints"
                          : opt.resume        ? "resuming"
                                              : nullptr;
    if (refused)
      throw Error(scene.integrator.loc,
                  fmt::format("integrator \"{}\" does not support {}: its {} splat anywhere in "
                              "the image (split a render by --spp-range and average the images "
                              "instead)",
                              integrator, refused, what));
  };
  std::optional<LightTracer> light_tracer;
  if (scene.integrator.type == "lighttracer") {
    refuseSplatting("lighttracer", "light paths");
    light_tracer.emplace(sc, *cam);
    film.enableSplats(*filter);
  }
  // bdpt (render/bdpt.h): its t = 1 strategies splat as the light tracer's paths do, so it has
  // the same limits; scenes it cannot render (a camera without importance, lights without
  // emission sampling) render with path (volpath where the scene has media), warned.
  std::optional<BdptIntegrator> bdpt;
  if (scene.integrator.type == "bdpt") {
    refuseSplatting("bdpt", "light subpaths");
    if (const std::string why = BdptIntegrator::unsupported(sc, *cam); !why.empty()) {
      // With media, as volpath (which tracks them).
      volpath = volpath || !media.empty();
      logWarning(fmt::format("{}: integrator \"bdpt\" renders as \"{}\": {}",
                             scene.integrator.loc.str(), volpath ? "volpath" : "path", why));
    } else {
      bdpt.emplace(sc, *cam);
      film.enableSplats(*filter);
    }
  }
  const double shutter_open = scene.camera.shutter_open;
  // Film "gbuffer" (pbrt-v4's GBufferFilm): its coordinate system and the differential scale
  // pbrt-v4 applies to camera rays, max(1/8, 1/sqrt(samples per pixel)).
  const bool gbuffer = film.gbuffer();
  const GBufferFrame gbuffer_frame(scene);
  const double gbuffer_diff_scale = std::max(0.125, 1 / std::sqrt(double(spp)));
  const double shutter_length = scene.camera.shutter_close - scene.camera.shutter_open;
  // The splats' scale for `n` samples per pixel taken: one light path per sample of every
  // pixel rendered, the image normalised per pixel of the full image (camera.h).
  auto setSplatScale = [&](int n) {
    film.setSplatScale(
        double(x_res) * double(y_res) / (double(std::max(n, 1)) * double(bounds.area())), n);
  };

  RenderResult result;
  result.bounds = bounds;
  result.full_bounds = full_bounds;
  RenderStats& st = result.stats;
  st.spp = spp;
  st.spp_begin = spp_begin, st.spp_end = spp_end;
  st.camera = cam->describe();
  st.camera_startup_s = cam->startupSeconds();
  st.camera_startup_cpu_s = cam->startupCpuSeconds();
  st.setup_s = std::chrono::duration<double>(Clock::now() - t_setup).count();
  st.load_s = opt.scene_load_s;

  constexpr int kTile = RenderCheckpoint::kTileSize;
  const int tiles_x = (bounds.width() + kTile - 1) / kTile;
  const int tiles_y = (bounds.height() + kTile - 1) / kTile;
  const int n_tiles = tiles_x * tiles_y;
  std::atomic<int> tiles_done{0};
  // Finished tiles (for checkpoints), and those taken from the state resumed.
  std::vector<std::atomic<uint8_t>> done(static_cast<size_t>(n_tiles));
  for (auto& d : done) d.store(0);
  if (opt.resume) {
    const RenderCheckpoint& r = *opt.resume;
    if (!(r.bounds == bounds) || r.tile_done.size() != size_t(n_tiles) ||
        r.sums.size() != film.sums().size())
      throw Error(
          fmt::format("cannot resume: the checkpoint covers pixels [{}, {}) x [{}, {}), "
                      "this render [{}, {}) x [{}, {})",
                      r.bounds.x0, r.bounds.x1, r.bounds.y0, r.bounds.y1, bounds.x0, bounds.x1,
                      bounds.y0, bounds.y1));
    const int w = bounds.width();
    for (int t = 0; t < n_tiles; ++t) {
      if (!r.tile_done[size_t(t)]) continue;
      done[size_t(t)].store(1);
      ++tiles_done;
      const int tx = t % tiles_x, ty = t / tiles_x;
      for (int y = ty * kTile; y < std::min(bounds.height(), (ty + 1) * kTile); ++y)
        for (int x = tx * kTile; x < std::min(w, (tx + 1) * kTile); ++x)
          film.sums()[size_t(y) * size_t(w) + size_t(x)] =
              r.sums[size_t(y) * size_t(w) + size_t(x)];
    }
    st.tiles_resumed = tiles_done.load();
  }
  // A failing checkpoint stops the render.
  std::atomic<bool> abort_render{false};
  auto stopRequested = [&] { return (opt.cancel && opt.cancel->load()) || abort_render.load(); };
  std::atomic<uint64_t> camera_samples{0}, camera_rays{0}, no_ray{0}, outside{0}, nonfinite{0},
      rays{0};
  std::atomic<bool> cancelled{false};
  const int threads =
      opt.threads > 0 ? opt.threads : std::max(1, int(std::thread::hardware_concurrency()));
  st.threads = threads;
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));

  // Progress reporter.
  const auto t0 = Clock::now();
  std::mutex pm;
  std::condition_variable pcv;
  bool finished = false;
  std::thread progress;
  if (opt.progress) {
    progress = std::thread([&] {
      const bool tty = isatty(STDERR_FILENO);
      int last_reported = -1;
      std::unique_lock lock(pm);
      while (!finished) {
        pcv.wait_for(lock, std::chrono::milliseconds(tty ? 250 : 1000));
        const int done = tiles_done.load();
        const double el = std::chrono::duration<double>(Clock::now() - t0).count();
        const double frac = double(done) / n_tiles;
        const std::string eta = done > 0 ? fmtDuration(el / frac - el) : "?";
        if (tty) {
          const int w = 40, fill = int(frac * w);
          std::fprintf(stderr, "\r[%s%s] %5.1f%%  elapsed %s  ETA %s ",
                       std::string(fill, '=').c_str(), std::string(w - fill, ' ').c_str(),
                       100 * frac, fmtDuration(el).c_str(),
                       finished || done == n_tiles ? "0.0s" : eta.c_str());
        } else if (int(frac * 10) != last_reported) {
          last_reported = int(frac * 10);
          std::fprintf(stderr, "render: %3.0f%% of %d tiles, elapsed %s, ETA %s\n", 100 * frac,
                       n_tiles, fmtDuration(el).c_str(), eta.c_str());
        }
        std::fflush(stderr);
      }
      if (tty) std::fprintf(stderr, "\n");
    });
  }

  // Checkpoint writer.
  std::thread checkpointer;
  std::exception_ptr checkpoint_error;
  if (opt.on_checkpoint) {
    checkpointer = std::thread([&] {
      std::unique_lock lock(pm);
      while (!finished) {
        pcv.wait_for(lock, std::chrono::duration<double>(std::max(opt.checkpoint_every_s, 1e-3)));
        if (finished) break;
        lock.unlock();
        try {
          opt.on_checkpoint(snapshot(film, done, tiles_x));
        } catch (...) {
          checkpoint_error = std::current_exception();
          abort_render = true;
          lock.lock();
          break;
        }
        lock.lock();
      }
    });
  }

  auto stopProgress = [&] {
    {
      std::lock_guard lock(pm);
      finished = true;
    }
    pcv.notify_all();
    if (progress.joinable()) progress.join();
    if (checkpointer.joinable()) checkpointer.join();
  };
  // Passes over sample indices [pass_begin, pass_end) of every pixel (within the render's
  // [spp_begin, spp_end)): one pass over all of them, or, with RenderOptions::on_pass, 1, 1, 2,
  // 4, ... samples (the total doubling), the image handed out after each. Each pixel's samples
  // are the same and added in the same order. A tile is "done" (for checkpoints) when its last
  // pass is, so progressive passes clear the flags between passes.
  if (opt.on_pass && (opt.resume || opt.on_checkpoint))
    throw Error("progressive passes (on_pass) do not combine with checkpoints or resume");
  int pass_begin = spp_begin, pass_end = spp_begin, passes = 0;
  for (; pass_begin < spp_end && !cancelled.load(); pass_begin = pass_end, ++passes) {
    pass_end = !opt.on_pass ? spp_end
               : pass_begin == spp_begin
                   ? spp_begin + 1
                   : std::min(spp_end, spp_begin + 2 * (pass_begin - spp_begin));
    if (opt.on_pass && passes > 0) {
      for (auto& d : done) d.store(0, std::memory_order_relaxed);
      tiles_done = 0;
    }
    try {
      tbb::parallel_for(
          tbb::blocked_range<int>(0, n_tiles, 1), [&](const tbb::blocked_range<int>& r) {
            std::unique_ptr<Sampler> sampler = proto->clone();
            for (int tile = r.begin(); tile != r.end(); ++tile) {
              if (stopRequested()) {
                cancelled = true;
                return;
              }
              if (done[size_t(tile)].load()) continue;  // resumed
              bool tile_cancelled = false;
              RayCounts counts;
              uint64_t n_samples = 0, n_rays = 0, n_none = 0, n_outside = 0, n_bad = 0;
              const int tx = tile % tiles_x, ty = tile / tiles_x;
              const int x0 = bounds.x0 + tx * kTile, y0 = bounds.y0 + ty * kTile;
              const int x1 = std::min(x0 + kTile, bounds.x1), y1 = std::min(y0 + kTile, bounds.y1);
              // A pixel's samples go in batches: first the camera dimensions of each sample, then
              // the camera rays of the batch together (the realistic camera traces them through
              // the lens side by side), then each sample's path, the sampler restarted at the
              // dimension after the camera's. The values are those of one sample at a time.
              constexpr int kB = camera::Camera::kMaxBatch;
              camera::CameraSample cs[kB];
              FilterSample fs[kB];
              double u_lambda[kB];
              SampledWavelengths lambdas[kB];
              std::optional<camera::CameraRay> cam_rays[kB];
              // Film "gbuffer": the rays of film points kDifferentialEpsilon pixel to the right and
              // below (differentials for dzdx, dzdy) and the first visible surface.
              camera::CameraSample cs_shift[kB];
              std::optional<camera::CameraRay> dx_rays[kB], dy_rays[kB];
              std::vector<BdptSplat> bdpt_splats;
              Transform gbuffer_scratch;
              // Sample k of the batch: pixel (x, y), sample index i. Dimension order: wavelength,
              // film (filter), lens, time, then the path (path_dimension).
              int path_dimension = 0;
              const auto cameraSample = [&](int x, int y, int i, int k) {
                sampler->startPixelSample({x, y}, i);
                u_lambda[k] = sampler->get1D();
                fs[k] = filter->sample(sampler->getPixel2D());
                cs[k].lens = sampler->get2D();
                cs[k].time = sampler->get1D();
                cs[k].film_raster = {x + 0.5 + fs[k].p.x, y + 0.5 + fs[k].p.y};
                lambdas[k] = SampledWavelengths::sampleVisible(u_lambda[k]);
                static_assert(camera::kCameraWavelengths == kSpectrumSamples);
                for (int c = 0; c < kSpectrumSamples; ++c)
                  cs[k].lambda_nm[size_t(c)] = lambdas[k].lambda(c);
                cs[k].pixel_centre = {x + 0.5, y + 0.5};
                // bdpt keeps a dispersive lens's hero wavelength only (as pbrt-v4 does): its light
                // subpaths share the camera path's wavelengths.
                cs[k].filter = opt.dispersion_hero_only || bdpt ? nullptr : filter.get();
                cs[k].filter_weight = fs[k].weight;
                path_dimension = sampler->dimension();
              };
              // Film "gbuffer": the first visible surface of camera ray k of the batch.
              const auto visible = [&](int k) {
                return visibleSurface(
                    sc, differential(*cam_rays[k], dx_rays[k], dy_rays[k]), lambdas[k],
                    gbuffer_frame.outputFromWorld(cam_rays[k]->time, gbuffer_scratch),
                    gbuffer_diff_scale, counts);
              };
              if (light_tracer) {
                for (int y = y0; y < y1 && !tile_cancelled; ++y)
                  for (int x = x0; x < x1; ++x) {
                    if (stopRequested()) {
                      cancelled = true;
                      tile_cancelled = true;
                      break;
                    }
                    for (int i = pass_begin; i < pass_end; ++i) {
                      sampler->startPixelSample({x, y}, i);
                      // Dimension order: wavelength, then the light path.
                      SampledWavelengths lambda =
                          SampledWavelengths::sampleVisible(sampler->get1D());
                      n_bad += uint64_t(light_tracer->trace(lambda, *sampler, film, counts));
                      ++n_samples;
                    }
                    // Film "gbuffer": the light tracer traces no camera rays, so the auxiliary
                    // channels get camera rays of their own, sampled as path's are (the same
                    // sampler dimensions: the same rays and wavelengths as path's for the same
                    // pixel sample).
                    if (gbuffer)
                      for (int i0 = pass_begin; i0 < pass_end; i0 += kB) {
                        const int m = std::min(kB, pass_end - i0);
                        for (int k = 0; k < m; ++k) cameraSample(x, y, i0 + k, k);
                        cam->generateRays(cs, m, cam_rays);
                        gbufferDifferentials(*cam, cs, m, cs_shift, dx_rays, dy_rays);
                        for (int k = 0; k < m; ++k) {
                          const auto vs = cam_rays[k] ? visible(k) : std::nullopt;
                          film.addVisibleSurface(x, y, fs[k].weight, vs ? &*vs : nullptr);
                        }
                      }
                  }
              }
              for (int y = y0; y < (light_tracer ? y0 : y1); ++y)
                for (int x = x0; x < x1; ++x)
                  for (int i0 = pass_begin; i0 < pass_end; i0 += kB) {
                    if (((i0 - pass_begin) & 63) == 0 && stopRequested()) {
                      cancelled = true;
                      tile_cancelled = true;
                      break;
                    }
                    const int m = std::min(kB, pass_end - i0);
                    for (int k = 0; k < m; ++k) cameraSample(x, y, i0 + k, k);
                    cam->generateRays(cs, m, cam_rays);
                    if (gbuffer) gbufferDifferentials(*cam, cs, m, cs_shift, dx_rays, dy_rays);
                    for (int k = 0; k < m; ++k) {
                      ++n_samples;
                      SampledWavelengths& lambda = lambdas[k];
                      const std::optional<camera::CameraRay>& ray = cam_rays[k];
                      // A dispersive lens refracted the ray at the hero wavelength only.
                      if (ray && ray->hero_only) lambda.terminateSecondary();
                      SampledSpectrum L(0.0);
                      if (bdpt) {
                        // Also without a camera ray: the light subpath's splats do not need it.
                        if (!ray) {
                          ++n_none;
                          n_outside += !cam->reachesFilm(cs[k]);
                        } else {
                          ++n_rays;
                        }
                        sampler->startPixelSample({x, y}, i0 + k, path_dimension);
                        bdpt_splats.clear();
                        const double time =
                            ray ? ray->time : shutter_open + cs[k].time * shutter_length;
                        L = bdpt->Li(ray ? &*ray : nullptr, time, lambda, *sampler, counts,
                                     bdpt_splats);
                        for (const BdptSplat& sp : bdpt_splats) {
                          bool ok = true;
                          for (int c = 0; c < kSpectrumSamples; ++c)
                            ok = ok && std::isfinite(sp.L[c]);
                          if (ok)
                            film.addSplat(sp.raster, sp.L, lambda);
                          else
                            ++n_bad;
                        }
                      } else if (!ray) {
                        ++n_none;
                        n_outside += !cam->reachesFilm(cs[k]);
                      } else {
                        ++n_rays;
                        sampler->startPixelSample({x, y}, i0 + k, path_dimension);
                        L = direct_lighting
                                ? directLightingLi(sc, direct_opt, ray->origin, ray->direction,
                                                   ray->time, lambda, *sampler, counts)
                            : volpath ? volpathLi(sc, ray->origin, ray->direction, ray->time,
                                                  sc.scene_media ? sc.camera_medium : -1, lambda,
                                                  *sampler, counts)
                                      : pathLi(sc, ray->origin, ray->direction, ray->time, lambda,
                                               *sampler, counts);
                        if (ray->per_wavelength && !lambda.secondaryTerminated()) {
                          for (int c = 0; c < kSpectrumSamples; ++c)
                            L[c] *= ray->wavelength_weight[size_t(c)];
                        } else {
                          L = L * ray->weight;
                        }
                      }
                      bool finite = true;
                      for (int c = 0; c < kSpectrumSamples; ++c)
                        finite = finite && std::isfinite(L[c]);
                      if (!finite) {
                        ++n_bad;
                        continue;
                      }
                      // Film "gbuffer" (also with bdpt, whose camera subpath starts with the
                      // same camera ray and first surface as path's).
                      if (gbuffer && ray) {
                        const auto vs = visible(k);
                        film.addSample(x, y, L, lambda, fs[k].weight, vs ? &*vs : nullptr);
                        continue;
                      }
                      film.addSample(x, y, L, lambda, fs[k].weight);
                    }
                  }
              camera_samples += n_samples;
              camera_rays += n_rays;
              no_ray += n_none;
              outside += n_outside;
              nonfinite += n_bad;
              rays += counts.intersect + counts.shadow;
              if (!tile_cancelled) {
                done[size_t(tile)].store(1, std::memory_order_release);
                ++tiles_done;
              }
            }
          });
    } catch (...) {
      stopProgress();  // a joinable thread must not outlive the render
      throw;
    }
    setSplatScale(pass_end - spp_begin);
    if (opt.on_pass && !cancelled.load() && (opt.cancel == nullptr || !opt.cancel->load()) &&
        !opt.on_pass(film.image(), pass_end - spp_begin))
      cancelled = true;
  }
  stopProgress();
  if (checkpoint_error) std::rethrow_exception(checkpoint_error);
  if (opt.on_checkpoint) opt.on_checkpoint(snapshot(film, done, tiles_x));

  st.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  st.camera_samples = camera_samples;
  st.camera_rays = camera_rays;
  st.no_ray_samples = no_ray;
  st.outside_samples = outside;
  st.nonfinite_samples = nonfinite;
  st.rays = rays;
  st.partial = cancelled.load() || tiles_done.load() < n_tiles || pass_begin < spp_end;
  st.invalid_rays = accel.invalidRays();
  result.image = film.image();
  // No pixel is ever NaN or inf (an overflowing light, a degenerate film setting): such values
  // are written as 0, counted and reported.
  for (float& v : result.image.pixels)
    if (!std::isfinite(v)) {
      v = 0;
      ++st.nonfinite_pixels;
    }
  if (st.invalid_rays > 0)
    logWarning(
        fmt::format("{} rays with a non-finite or huge origin or direction were dropped "
                    "(check the scene's numbers)",
                    st.invalid_rays));
  if (st.nonfinite_pixels > 0)
    logWarning(
        fmt::format("{} pixel values were NaN or infinite and are written as 0 (check the "
                    "scene's light and film values)",
                    st.nonfinite_pixels));
  auto& md = result.image.metadata;
  md["lensim:spp"] = std::to_string(spp);
  md["lensim:setup_seconds"] = fmt::format("{:.3f}", st.load_s + st.setup_s);
  md["lensim:camera"] = st.camera;
  md["lensim:pixelbounds"] = fmt::format("{} {} {} {}", bounds.x0, bounds.x1, bounds.y0, bounds.y1);
  md["lensim:resolution"] = fmt::format("{} {}", x_res, y_res);
  md["lensim:colorspace"] = "linear sRGB (Rec. 709 primaries, D65)";
  if (opt.spp_range) md["lensim:spp_range"] = fmt::format("{}:{}", spp_begin, spp_end);
  if (opt.tile) md["lensim:tile"] = fmt::format("{}/{}", opt.tile->first, opt.tile->second);
  if (st.partial) md["lensim:partial"] = "true";
  if (opt.keep_sums) result.sums = film.sums();
  return result;
}

std::string formatStats(const RenderStats& s) {
  const double w = std::max(s.wall_s, 1e-9);
  std::string out;
  out += fmt::format("render time          {:.3f} s ({} threads, {} spp){}\n", s.wall_s, s.threads,
                     s.spp, s.partial ? " -- interrupted, image partial" : "");
  // The whole set-up: reading and building the scene (parsing, PLY files, subdivision) and the
  // render's own (BVH, lights, textures, camera).
  out += fmt::format(
      "setup time           {:.3f} s (scene load {:.3f} s; BVH, lights, textures {:.3f} s, "
      "of which camera startup {:.3f} s, {:.3f} s CPU)\n",
      s.load_s + s.setup_s, s.load_s, s.setup_s, s.camera_startup_s, s.camera_startup_cpu_s);
  out += fmt::format("camera               {}\n", s.camera);
  out += fmt::format("camera samples       {} ({:.3g} samples/s)\n", s.camera_samples,
                     double(s.camera_samples) / w);
  out += fmt::format("camera rays          {} ({:.3g} camera rays/s)\n", s.camera_rays,
                     double(s.camera_rays) / w);
  const uint64_t inside = s.camera_samples - s.outside_samples;
  out += fmt::format(
      "samples without ray  {} ({} where no light reaches the film; {:.2f}% of the other {})\n",
      s.no_ray_samples, s.outside_samples,
      inside ? 100.0 * double(s.no_ray_samples - s.outside_samples) / double(inside) : 0.0, inside);
  out += fmt::format("rays traced          {} ({:.3g} rays/s)\n", s.rays, double(s.rays) / w);
  out += fmt::format("NaN/inf samples      {} (discarded)\n", s.nonfinite_samples);
  if (s.invalid_rays > 0)
    out += fmt::format("invalid rays         {} (non-finite or huge; dropped)\n", s.invalid_rays);
  if (s.nonfinite_pixels > 0)
    out += fmt::format("NaN/inf pixels       {} (written as 0)\n", s.nonfinite_pixels);
  return out;
}

}  // namespace lensim::render
