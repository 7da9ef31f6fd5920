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
#include "lensim/render/integrators/base.h"
#include "lensim/render/media/media.h"
#include "lensim/render/parts.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/sampling/filter.h"
#include "lensim/scene/description.h"
#include "lensim/util/check.h"
#include "lensim/util/error.h"
#include "lensim/util/limits.h"
#include "lensim/util/log.h"

namespace lensim::render {

using namespace lensim::sampling;

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

/// The renderer's tiles: kTileSize pixels square, row by row over the rendered bounds.
struct TileGrid {
  static constexpr int kTile = RenderCheckpoint::kTileSize;
  explicit TileGrid(const PixelBounds& b)
      : bounds(b),
        tiles_x((b.width() + kTile - 1) / kTile),
        tiles_y((b.height() + kTile - 1) / kTile) {}
  int count() const { return tiles_x * tiles_y; }
  /// Tile t's pixels, relative to bounds' corner.
  PixelBounds local(int t) const {
    LENSIM_CHECK_GE(t, 0);
    LENSIM_CHECK_LT(t, count());
    const int tx = t % tiles_x, ty = t / tiles_x;
    return {tx * kTile, std::min(bounds.width(), (tx + 1) * kTile), ty * kTile,
            std::min(bounds.height(), (ty + 1) * kTile)};
  }
  PixelBounds bounds;
  int tiles_x, tiles_y;
};

/// The finished tiles' sums of `film` (the others zero).
RenderCheckpoint snapshot(const Film& film, const std::vector<std::atomic<uint8_t>>& done,
                          const TileGrid& grid) {
  RenderCheckpoint c;
  c.bounds = film.bounds();
  c.tile_done.resize(done.size());
  c.sums.assign(film.sums().size(), PixelSum{});
  c.ghost_sums.assign(film.ghostSums().size(), GhostSum{});
  const bool ghost = film.ghostLayer();
  const size_t w = size_t(c.bounds.width());
  for (size_t t = 0; t < done.size(); ++t) {
    c.tile_done[t] = done[t].load(std::memory_order_acquire);
    if (!c.tile_done[t]) continue;
    const PixelBounds p = grid.local(int(t));
    for (int y = p.y0; y < p.y1; ++y)
      for (int x = p.x0; x < p.x1; ++x) {
        const size_t i = size_t(y) * w + size_t(x);
        c.sums[i] = film.sums()[i];
        if (ghost) c.ghost_sums[i] = film.ghostSums()[i];
      }
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

namespace {

/// What the integrators read of the world, as the render's options ask (the media fields are
/// the integrator's: makeIntegrator sets them).
SceneContext sceneContext(const scene::Scene& scene, const RenderWorld& world,
                          bool pbrt_v2_quirks) {
  SceneContext sc;
  sc.scene = &scene;
  sc.accel = &world.accel;
  sc.textures = &world.textures;
  sc.materials = &world.materials;
  sc.lights = &world.lights;
  sc.max_depth = scene.integrator.max_depth;
  sc.regularize = scene.integrator.regularize;
  sc.pbrt_v2_epsilon = pbrt_v2_quirks;
  sc.camera_from_world = scene.camera.camera_from_world;
  for (const scene::Material& m : scene.materials)
    sc.has_interfaces = sc.has_interfaces || m.kind() == scene::MaterialKind::Interface;
  for (const scene::Shape& s : scene.shapes) sc.has_alpha = sc.has_alpha || s.alpha.has_value();
  return sc;
}

/// The render setting that rules out a splatting integrator (its samples splat anywhere in the
/// image, so a tile's pixels are not its own), or nullptr.
const char* splatRefusal(const RenderOptions& opt) {
  return opt.tile            ? "--tile"
         : opt.keep_sums     ? "parts (exact sums)"
         : opt.on_checkpoint ? "checkpoints"
         : opt.resume        ? "resuming"
                             : nullptr;
}

/// Takes the finished tiles of checkpoint `r` into the film and marks them done; returns their
/// number. Throws lensim::Error when the checkpoint covers other pixels.
int resumeTiles(const RenderCheckpoint& r, const TileGrid& grid, Film& film,
                std::vector<std::atomic<uint8_t>>& done) {
  const PixelBounds& bounds = grid.bounds;
  if (!(r.bounds == bounds) || r.tile_done.size() != size_t(grid.count()) ||
      r.sums.size() != film.sums().size())
    throw Error(
        fmt::format("cannot resume: the checkpoint covers pixels [{}, {}) x [{}, {}), "
                    "this render [{}, {}) x [{}, {})",
                    r.bounds.x0, r.bounds.x1, r.bounds.y0, r.bounds.y1, bounds.x0, bounds.x1,
                    bounds.y0, bounds.y1));
  // A flare render's checkpoint carries its ghost layer (a scene with flare has another identity
  // than one without, so this differs only for a checkpoint written without the layer).
  if (r.ghost_sums.size() != film.ghostSums().size())
    throw Error(film.ghostLayer()
                    ? "cannot resume: the render has lens flare's ghost layer and the "
                      "checkpoint does not hold it"
                    : "cannot resume: the checkpoint holds a ghost layer and the render has none");
  const size_t w = size_t(bounds.width());
  int resumed = 0;
  for (int t = 0; t < grid.count(); ++t) {
    if (!r.tile_done[size_t(t)]) continue;
    done[size_t(t)].store(1);
    ++resumed;
    const PixelBounds p = grid.local(t);
    for (int y = p.y0; y < p.y1; ++y)
      for (int x = p.x0; x < p.x1; ++x) {
        const size_t i = size_t(y) * w + size_t(x);
        film.sums()[i] = r.sums[i];
        if (film.ghostLayer()) film.ghostSums()[i] = r.ghost_sums[i];
      }
  }
  return resumed;
}

/// The threads beside the tile loop: the progress bar (RenderOptions::progress) and the
/// checkpoint writer (RenderOptions::on_checkpoint). A checkpoint that throws sets `abort` and
/// its exception is kept (error()). stop() (or the destructor) ends and joins both.
class BackgroundThreads {
 public:
  BackgroundThreads(const RenderOptions& opt, const Film& film,
                    const std::vector<std::atomic<uint8_t>>& done, const TileGrid& grid,
                    const std::atomic<int>& tiles_done, std::atomic<bool>& abort)
      : t0_(Clock::now()) {
    const int n_tiles = int(done.size());
    if (opt.progress)
      progress_ = std::thread([this, &tiles_done, n_tiles] { reportProgress(tiles_done, n_tiles); });
    if (opt.on_checkpoint)
      checkpointer_ = std::thread([this, &opt, &film, &done, &grid, &abort] {
        std::unique_lock lock(m_);
        while (!finished_) {
          cv_.wait_for(lock, std::chrono::duration<double>(std::max(opt.checkpoint_every_s, 1e-3)));
          if (finished_) break;
          lock.unlock();
          try {
            opt.on_checkpoint(snapshot(film, done, grid));
          } catch (...) {
            error_ = std::current_exception();
            abort = true;
            lock.lock();
            break;
          }
          lock.lock();
        }
      });
  }
  ~BackgroundThreads() { stop(); }
  BackgroundThreads(const BackgroundThreads&) = delete;
  BackgroundThreads& operator=(const BackgroundThreads&) = delete;

  void stop() {
    {
      std::lock_guard lock(m_);
      finished_ = true;
    }
    cv_.notify_all();
    if (progress_.joinable()) progress_.join();
    if (checkpointer_.joinable()) checkpointer_.join();
  }
  /// The exception a checkpoint threw (after stop()).
  std::exception_ptr error() const { return error_; }
  Clock::time_point start() const { return t0_; }

 private:
  void reportProgress(const std::atomic<int>& tiles_done, int n_tiles) {
    const bool tty = isatty(STDERR_FILENO);
    int last_reported = -1;
    std::unique_lock lock(m_);
    while (!finished_) {
      cv_.wait_for(lock, std::chrono::milliseconds(tty ? 250 : 1000));
      const int done = tiles_done.load();
      const double el = std::chrono::duration<double>(Clock::now() - t0_).count();
      const double frac = double(done) / n_tiles;
      const std::string eta = done > 0 ? fmtDuration(el / frac - el) : "?";
      if (tty) {
        const int w = 40, fill = int(frac * w);
        std::fprintf(stderr, "\r[%s%s] %5.1f%%  elapsed %s  ETA %s ",
                     std::string(fill, '=').c_str(), std::string(w - fill, ' ').c_str(),
                     100 * frac, fmtDuration(el).c_str(),
                     finished_ || done == n_tiles ? "0.0s" : eta.c_str());
      } else if (int(frac * 10) != last_reported) {
        last_reported = int(frac * 10);
        std::fprintf(stderr, "render: %3.0f%% of %d tiles, elapsed %s, ETA %s\n", 100 * frac,
                     n_tiles, fmtDuration(el).c_str(), eta.c_str());
      }
      std::fflush(stderr);
    }
    if (tty) std::fprintf(stderr, "\n");
  }

  Clock::time_point t0_;
  std::mutex m_;
  std::condition_variable cv_;
  bool finished_ = false;
  std::thread progress_, checkpointer_;
  std::exception_ptr error_;
};

/// Camera samples, their outcomes and the rays traced, summed over tiles.
struct SampleTally {
  uint64_t samples = 0, rays = 0, no_ray = 0, outside = 0, nonfinite = 0, ghost_rays = 0;
  RayCounts counts;
};
struct SharedTally {
  std::atomic<uint64_t> samples{0}, rays{0}, no_ray{0}, outside{0}, nonfinite{0}, traced{0},
      ghost_rays{0}, ghost_connections{0};
  void add(const SampleTally& t) {
    samples += t.samples;
    ghost_rays += t.ghost_rays;
    rays += t.rays;
    no_ray += t.no_ray;
    outside += t.outside;
    nonfinite += t.nonfinite;
    traced += t.counts.intersect + t.counts.shadow;
    ghost_connections += t.counts.ghost_connections;
  }
};

/// Renders the pixel samples of one tile into the film: one per thread at a time (it holds the
/// thread's sampler and the batch of camera samples).
///
/// A pixel's samples go in batches: first the camera dimensions of each sample, then the camera
/// rays of the batch together (the realistic camera traces them through the lens side by side),
/// then each sample's estimate, the sampler restarted at the dimension after the camera's. The
/// values are those of one sample at a time. The light tracer's pixel samples are light paths
/// instead (camera rays only for a gbuffer film's channels).
class TileRenderer {
 public:
  /// What every tile shares (all of it outlives the tile loop).
  struct Job {
    const SceneContext* sc;
    const camera::Camera* cam;
    const Integrator* integrator;
    const Filter* filter;
    const Sampler* proto;
    Film* film;
    const TileGrid* grid;
    const GBufferFrame* gbuffer_frame;
    double gbuffer_diff_scale;  ///< pbrt-v4's max(1/8, 1/sqrt(samples per pixel))
    double shutter_open, shutter_length;
    bool dispersion_hero_only;  ///< RenderOptions::dispersion_hero_only
    std::function<bool()> stop_requested;
  };
  explicit TileRenderer(const Job& job) : j_(job), sampler_(job.proto->clone()) {}

  /// Samples [pass_begin, pass_end) of every pixel of tile `tile`, counted into `tally`.
  /// Returns false when a stop request cut the tile short.
  bool render(int tile, int pass_begin, int pass_end, SampleTally& tally) {
    const PixelBounds p = j_.grid->local(tile);
    const int x0 = j_.grid->bounds.x0 + p.x0, y0 = j_.grid->bounds.y0 + p.y0;
    const int x1 = j_.grid->bounds.x0 + p.x1, y1 = j_.grid->bounds.y0 + p.y1;
    const bool light_paths = j_.integrator->tracesLightPaths();
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        if (light_paths) {
          if (j_.stop_requested()) return false;
          lightPathPixel(x, y, pass_begin, pass_end, tally);
          continue;
        }
        for (int i0 = pass_begin; i0 < pass_end; i0 += kB) {
          if (((i0 - pass_begin) & 63) == 0 && j_.stop_requested()) return false;
          cameraBatch(x, y, i0, std::min(kB, pass_end - i0), tally);
        }
      }
    return true;
  }

 private:
  static constexpr int kB = camera::Camera::kMaxBatch;

  /// Draws the camera dimensions of sample i of pixel (x, y) as sample k of the batch. Dimension
  /// order: wavelength, film (filter), lens, time, then the path (path_dimension_).
  void cameraSample(int x, int y, int i, int k) {
    sampler_->startPixelSample({x, y}, i);
    const double u_lambda = sampler_->get1D();
    fs_[k] = j_.filter->sample(sampler_->getPixel2D());
    cs_[k].lens = sampler_->get2D();
    cs_[k].time = sampler_->get1D();
    cs_[k].film_raster = {x + 0.5 + fs_[k].p.x, y + 0.5 + fs_[k].p.y};
    lambdas_[k] = SampledWavelengths::sampleVisible(u_lambda);
    static_assert(camera::kCameraWavelengths == kSpectrumSamples);
    static_assert(camera::kRenderedMin_nm == kLambdaMin_nm &&
                  camera::kRenderedMax_nm == kLambdaMax_nm);
    for (int c = 0; c < kSpectrumSamples; ++c) cs_[k].lambda_nm[size_t(c)] = lambdas_[k].lambda(c);
    cs_[k].pixel_centre = {x + 0.5, y + 0.5};
    // bdpt keeps a dispersive lens's hero wavelength only (as pbrt-v4 does): its light
    // subpaths share the camera path's wavelengths.
    cs_[k].filter =
        j_.dispersion_hero_only || j_.integrator->heroWavelengthOnly() ? nullptr : j_.filter;
    cs_[k].filter_weight = fs_[k].weight;
    if (flare_) {  // the ghost path's pair and direction (realistic_flare.cpp)
      cs_[k].ghost_u[0] = sampler_->get1D();
      const Vec2 u = sampler_->get2D();
      cs_[k].ghost_u[1] = u.x, cs_[k].ghost_u[2] = u.y;
    }
    path_dimension_ = sampler_->dimension();
  }

  /// Film "gbuffer": the first visible surface of camera ray k of the batch (its differentials
  /// from the rays of film points kDifferentialEpsilon pixel to the right and below).
  std::optional<VisibleSurface> visible(int k, RayCounts& counts) {
    return visibleSurface(
        *j_.sc, differential(*cam_rays_[k], dx_rays_[k], dy_rays_[k]), lambdas_[k],
        j_.gbuffer_frame->outputFromWorld(cam_rays_[k]->time, gbuffer_scratch_),
        j_.gbuffer_diff_scale, counts);
  }

  /// The light tracer's samples of pixel (x, y): a light path each. Dimension order:
  /// wavelength, then the light path.
  void lightPathPixel(int x, int y, int pass_begin, int pass_end, SampleTally& tally) {
    for (int i = pass_begin; i < pass_end; ++i) {
      sampler_->startPixelSample({x, y}, i);
      SampledWavelengths lambda = SampledWavelengths::sampleVisible(sampler_->get1D());
      tally.nonfinite +=
          uint64_t(j_.integrator->traceLightPath(lambda, *sampler_, *j_.film, tally.counts));
      ++tally.samples;
    }
    // Film "gbuffer": the light tracer traces no camera rays, so the auxiliary channels get
    // camera rays of their own, sampled as path's are (the same sampler dimensions: the same
    // rays and wavelengths as path's for the same pixel sample).
    if (!j_.film->gbuffer()) return;
    for (int i0 = pass_begin; i0 < pass_end; i0 += kB) {
      const int m = std::min(kB, pass_end - i0);
      for (int k = 0; k < m; ++k) cameraSample(x, y, i0 + k, k);
      j_.cam->generateRays(cs_, m, cam_rays_);
      gbufferDifferentials(*j_.cam, cs_, m, cs_shift_, dx_rays_, dy_rays_);
      for (int k = 0; k < m; ++k) {
        const auto vs = cam_rays_[k] ? visible(k, tally.counts) : std::nullopt;
        j_.film->addVisibleSurface(x, y, fs_[k].weight, vs ? &*vs : nullptr);
      }
    }
  }

  /// Samples i0 .. i0 + m - 1 of pixel (x, y): their camera rays, then each one's estimate.
  void cameraBatch(int x, int y, int i0, int m, SampleTally& tally) {
    const bool gbuffer = j_.film->gbuffer();
    for (int k = 0; k < m; ++k) cameraSample(x, y, i0 + k, k);
    j_.cam->generateRays(cs_, m, cam_rays_);
    if (gbuffer) gbufferDifferentials(*j_.cam, cs_, m, cs_shift_, dx_rays_, dy_rays_);
    for (int k = 0; k < m; ++k) {
      ++tally.samples;
      SampledWavelengths& lambda = lambdas_[k];
      const std::optional<camera::CameraRay>& ray = cam_rays_[k];
      // A dispersive lens refracted the ray at the hero wavelength only.
      if (ray && ray->hero_only) lambda.terminateSecondary();
      if (ray) {
        ++tally.rays;
      } else {
        ++tally.no_ray;
        tally.outside += !j_.cam->reachesFilm(cs_[k]);
      }
      // Lens flare: the sample's ghost path, with the wavelengths as drawn.
      if (flare_) ghostPath(x, y, i0 + k, k, lambda, tally);
      SampledSpectrum L(0.0);
      if (ray || j_.integrator->estimatesWithoutCameraRay()) {
        sampler_->startPixelSample({x, y}, i0 + k, path_dimension_);
        const double time = ray ? ray->time : j_.shutter_open + cs_[k].time * j_.shutter_length;
        L = j_.integrator->Li(ray ? &*ray : nullptr, time, lambda, *sampler_, tally.counts,
                              *j_.film, tally.nonfinite);
      }
      bool finite = true;
      for (int c = 0; c < kSpectrumSamples; ++c) finite = finite && std::isfinite(L[c]);
      if (!finite) {
        ++tally.nonfinite;
        continue;
      }
      // Film "gbuffer" (also with bdpt, whose camera subpath starts with the same camera ray
      // and first surface as path's).
      if (gbuffer && ray) {
        const auto vs = visible(k, tally.counts);
        j_.film->addSample(x, y, L, lambda, fs_[k].weight, vs ? &*vs : nullptr);
        continue;
      }
      j_.film->addSample(x, y, L, lambda, fs_[k].weight);
    }
  }

  /// Lens flare (camera::Camera::flare): the ghost path of sample i of pixel (x, y), batch
  /// entry k, its radiance added to the film's pixel and ghost layer. Its scene path takes the
  /// same sampler dimensions as the direct path's (each is an unbiased estimate on its own).
  void ghostPath(int x, int y, int i, int k, SampledWavelengths lambda, SampleTally& tally) {
    const std::optional<camera::CameraRay> g = j_.cam->generateGhostRay(cs_[k]);
    if (!g) return;
    ++tally.ghost_rays;
    // A dispersive lens traced the ghost path at the hero wavelength only.
    if (g->hero_only) lambda.terminateSecondary();
    sampler_->startPixelSample({x, y}, i, path_dimension_);
    const SampledSpectrum L =
        j_.integrator->Li(&*g, g->time, lambda, *sampler_, tally.counts, *j_.film, tally.nonfinite);
    for (int c = 0; c < kSpectrumSamples; ++c)
      if (!std::isfinite(L[c])) {
        ++tally.nonfinite;
        return;
      }
    j_.film->addGhost(x, y, L, lambda, fs_[k].weight);
  }

  const Job& j_;
  const bool flare_ = j_.cam->flare();
  std::unique_ptr<Sampler> sampler_;
  camera::CameraSample cs_[kB];
  FilterSample fs_[kB];
  SampledWavelengths lambdas_[kB];
  std::optional<camera::CameraRay> cam_rays_[kB];
  camera::CameraSample cs_shift_[kB];
  std::optional<camera::CameraRay> dx_rays_[kB], dy_rays_[kB];
  Transform gbuffer_scratch_;
  int path_dimension_ = 0;
};

/// The last pass end of the passes over sample indices [spp_begin, spp_end) (see render()):
/// one pass over all of them, or, progressive, 1, 1, 2, 4, ... samples (the total doubling).
int passEnd(int pass_begin, int spp_begin, int spp_end, bool progressive) {
  if (!progressive) return spp_end;
  return pass_begin == spp_begin ? spp_begin + 1
                                 : std::min(spp_end, spp_begin + 2 * (pass_begin - spp_begin));
}

/// Writes non-finite pixel values as 0 (counted in the stats), warns of dropped rays and such
/// pixels, and sets the image's metadata.
void finishImage(const RenderOptions& opt, const scene::Scene& scene, RenderResult& result) {
  RenderStats& st = result.stats;
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
  const PixelBounds& bounds = result.bounds;
  auto& md = result.image.metadata;
  md["lensim:spp"] = std::to_string(st.spp);
  md["lensim:setup_seconds"] = fmt::format("{:.3f}", st.load_s + st.setup_s);
  md["lensim:camera"] = st.camera;
  md["lensim:pixelbounds"] = fmt::format("{} {} {} {}", bounds.x0, bounds.x1, bounds.y0, bounds.y1);
  md["lensim:resolution"] =
      fmt::format("{} {}", scene.film.x_resolution, scene.film.y_resolution);
  md["lensim:colorspace"] = "linear sRGB (Rec. 709 primaries, D65)";
  if (opt.spp_range) md["lensim:spp_range"] = fmt::format("{}:{}", st.spp_begin, st.spp_end);
  if (opt.tile) md["lensim:tile"] = fmt::format("{}/{}", opt.tile->first, opt.tile->second);
  if (st.partial) md["lensim:partial"] = "true";
}

/// Lens flare (docs/flare.md, "Rendering ghosts"): checks that the render can carry it and
/// turns on the film's ghost layer.
void enableFlare(const scene::Scene& scene, const Integrator& integrator, const camera::Camera& cam,
                 Film& film) {
  // Every integrator, into the ghost layer of an RGB or raw film; as parts and checkpoints too
  // (the ghost layer's sums are exact like the pixels', RenderResult::ghost_sums). A raw film
  // adds the ghost paths' expected electrons to its pixels' like the direct paths' (Film::addGhost
  // records what addSample does), so the sensor's noise and ADC see them once, with the rest of
  // the light.
  const FileLoc& loc = scene.camera.loc;
  if ((integrator.splats() || integrator.tracesLightPaths()) && !cam.flareInLightPaths())
    throw Error(loc, fmt::format("realistic camera: \"flare\" through a dispersive lens is "
                                 "rendered by the path, volpath and directlighting integrators, "
                                 "not \"{}\"",
                                 scene.integrator.type));
  if (scene.film.type != "rgb" && scene.film.type != "raw")
    throw Error(loc, fmt::format("realistic camera: \"flare\" needs Film \"rgb\" or \"raw\" "
                                 "(its ghost layer), not \"{}\"",
                                 scene.film.type));
  film.enableGhostLayer();
}

/// The sample and ray counts of the render into its statistics.
void addCounts(RenderStats& st, const SharedTally& tally) {
  st.camera_samples = tally.samples;
  st.camera_rays = tally.rays;
  st.ghost_rays = tally.ghost_rays;
  st.ghost_connections = tally.ghost_connections;
  st.no_ray_samples = tally.no_ray;
  st.outside_samples = tally.outside;
  st.nonfinite_samples = tally.nonfinite;
  st.rays = tally.traced;
}

}  // namespace

RenderResult render(const scene::Scene& scene, const RenderOptions& opt) {
  const auto t_setup = Clock::now();
  camera::CameraOptions camera_options;
  camera_options.pbrt_v2_quirks = opt.pbrt_v2_quirks;
  std::shared_ptr<const camera::Camera> cam = opt.camera;
  if (!cam) cam = camera::makeCamera(scene, camera_options);
  const int x_res = scene.film.x_resolution, y_res = scene.film.y_resolution;
  const RenderPlan plan = planRender(scene, opt);
  const PixelBounds bounds = plan.bounds;

  const std::shared_ptr<const RenderWorld> world = opt.world ? opt.world : prepareWorld(scene);
  SceneContext sc = sceneContext(scene, *world, opt.pbrt_v2_quirks);

  // A camera sensor lensim does not bundle is warned once, at its parameter, by the builder
  // (scene/sensor_settings.cpp).
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
  if (film.rawSensor()) film.addRawMetadata(rawLensMetadata(*cam));
  IntegratorSetup setup;
  setup.scene = &scene;
  setup.sc = &sc;
  setup.media = &world->media;
  setup.camera = cam.get();
  setup.pbrt_v2_quirks = opt.pbrt_v2_quirks;
  setup.refuses_splats = splatRefusal(opt);
  const std::unique_ptr<Integrator> integrator = makeIntegrator(setup);
  if (integrator->splats()) film.enableSplats(*filter);
  if (cam->flare()) enableFlare(scene, *integrator, *cam, film);
  // Film "gbuffer" (pbrt-v4's GBufferFilm): its coordinate system and the differential scale
  // pbrt-v4 applies to camera rays, max(1/8, 1/sqrt(samples per pixel)).
  const GBufferFrame gbuffer_frame(scene);

  RenderResult result;
  result.bounds = bounds;
  result.full_bounds = plan.full_bounds;
  RenderStats& st = result.stats;
  st.spp = spp;
  st.spp_begin = spp_begin, st.spp_end = spp_end;
  st.camera = cam->describe();
  st.camera_startup_s = cam->startupSeconds();
  st.camera_startup_cpu_s = cam->startupCpuSeconds();
  st.setup_s = std::chrono::duration<double>(Clock::now() - t_setup).count();
  st.load_s = opt.scene_load_s;

  const TileGrid grid(bounds);
  const int n_tiles = grid.count();
  std::atomic<int> tiles_done{0};
  // Finished tiles (for checkpoints), and those taken from the state resumed.
  std::vector<std::atomic<uint8_t>> done(static_cast<size_t>(n_tiles));
  for (auto& d : done) d.store(0);
  if (opt.resume) {
    tiles_done = resumeTiles(*opt.resume, grid, film, done);
    st.tiles_resumed = tiles_done.load();
  }
  // A failing checkpoint stops the render.
  std::atomic<bool> abort_render{false};
  std::atomic<bool> cancelled{false};
  SharedTally tally;
  const int threads =
      opt.threads > 0 ? opt.threads : std::max(1, int(std::thread::hardware_concurrency()));
  st.threads = threads;
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));

  const TileRenderer::Job job{
      .sc = &sc,
      .cam = cam.get(),
      .integrator = integrator.get(),
      .filter = filter.get(),
      .proto = proto.get(),
      .film = &film,
      .grid = &grid,
      .gbuffer_frame = &gbuffer_frame,
      .gbuffer_diff_scale = std::max(0.125, 1 / std::sqrt(double(spp))),
      .shutter_open = scene.camera.shutter_open,
      .shutter_length = scene.camera.shutter_close - scene.camera.shutter_open,
      .dispersion_hero_only = opt.dispersion_hero_only,
      .stop_requested =
          [&] { return (opt.cancel && opt.cancel->load()) || abort_render.load(); },
  };
  BackgroundThreads background(opt, film, done, grid, tiles_done, abort_render);
  // Passes over sample indices [pass_begin, pass_end) of every pixel (within the render's
  // [spp_begin, spp_end)): one pass over all of them, or, with RenderOptions::on_pass, 1, 1, 2,
  // 4, ... samples (the total doubling), the image handed out after each. Each pixel's samples
  // are the same and added in the same order. A tile is "done" (for checkpoints) when its last
  // pass is, so progressive passes clear the flags between passes.
  if (opt.on_pass && (opt.resume || opt.on_checkpoint))
    throw Error("progressive passes (on_pass) do not combine with checkpoints or resume");
  int pass_begin = spp_begin, pass_end = spp_begin, passes = 0;
  for (; pass_begin < spp_end && !cancelled.load(); pass_begin = pass_end, ++passes) {
    pass_end = passEnd(pass_begin, spp_begin, spp_end, bool(opt.on_pass));
    if (opt.on_pass && passes > 0) {
      for (auto& d : done) d.store(0, std::memory_order_relaxed);
      tiles_done = 0;
    }
    tbb::parallel_for(
        tbb::blocked_range<int>(0, n_tiles, 1), [&](const tbb::blocked_range<int>& r) {
          TileRenderer renderer(job);
          for (int tile = r.begin(); tile != r.end(); ++tile) {
            if (job.stop_requested()) {
              cancelled = true;
              return;
            }
            if (done[size_t(tile)].load()) continue;  // resumed
            SampleTally t;
            const bool finished = renderer.render(tile, pass_begin, pass_end, t);
            tally.add(t);
            if (finished) {
              done[size_t(tile)].store(1, std::memory_order_release);
              ++tiles_done;
            } else {
              cancelled = true;
            }
          }
        });
    // The splats' scale for the samples per pixel taken: one light path per sample of every
    // pixel rendered, the image normalised per pixel of the full image (camera.h).
    const int n = pass_end - spp_begin;
    film.setSplatScale(
        double(x_res) * double(y_res) / (double(std::max(n, 1)) * double(bounds.area())), n);
    if (opt.on_pass && !cancelled.load() && (opt.cancel == nullptr || !opt.cancel->load()) &&
        !opt.on_pass(film.image(), pass_end - spp_begin))
      cancelled = true;
  }
  background.stop();
  if (background.error()) std::rethrow_exception(background.error());
  if (opt.on_checkpoint) opt.on_checkpoint(snapshot(film, done, grid));

  st.wall_s = std::chrono::duration<double>(Clock::now() - background.start()).count();
  addCounts(st, tally);
  st.partial = cancelled.load() || tiles_done.load() < n_tiles || pass_begin < spp_end;
  st.invalid_rays = world->accel.invalidRays();
  result.image = film.image();
  finishImage(opt, scene, result);
  if (opt.keep_sums) {
    result.sums = film.sums();
    result.ghost_sums = film.ghostSums();
  }
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
  if (s.ghost_rays > 0)
    out += fmt::format("ghost rays           {} (lens flare: ghost paths through the lens)\n",
                       s.ghost_rays);
  if (s.ghost_connections > 0)
    out += fmt::format(
        "ghost connections    {} (lens flare: light-side connections through ghost paths)\n",
        s.ghost_connections);
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
