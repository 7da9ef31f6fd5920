// `lensim render SCENE`: renders a pbrt scene to an image (EXR, TIFF or PNG by extension).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "lensim/io/image.h"
#include "lensim/optics/glass/library.h"
#include "lensim/render/autofocus_scene.h"
#include "lensim/render/parts.h"
#include "lensim/render/renderer.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "lensim/util/interrupt.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

namespace {

/// The command line of `lensim render`.
struct Options {
  std::string scene;
  std::vector<std::string> outfiles;
  int spp = 0, threads = 0, seed = 0;
  bool has_seed = false;
  std::vector<double> crop;
  std::vector<int> pixelbounds;
  bool quiet = false, stats = false;
  bool autofocus = false;
  bool pbrt_v2_quirks = false;
  std::string zones;
  // Distributed renders and checkpoints (docs/cluster.md).
  std::string tile, spp_range, checkpoint, checkpoint_every = "60s", resume;
  bool part = false;
  // Glass look-up (docs/glass.md).
  std::vector<std::string> glass_catalogs;
  bool model_glass = false;
  bool glass_extrapolate = false;
};

/// Declares the options of `lensim render` on r; returns --seed and --checkpoint-every, whose
/// presence the callback checks.
std::pair<CLI::Option*, CLI::Option*> addRenderOptions(CLI::App* r, Options* o) {
  r->add_option("scene", o->scene, "Scene file (.pbrt)")->required();
  r->add_option("--spp", o->spp, "Samples per pixel (overrides the scene's sampler)")
      ->check(CLI::PositiveNumber);
  r->add_option("--outfile,-o", o->outfiles,
                "Output image (.exr: 32-bit float RGB; .tif/.tiff: 32-bit float; .png: 8-bit "
                "sRGB); default: the film's filename. Repeat to write several files")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  r->add_option("--threads,--nthreads", o->threads, "Worker threads (default: all cores)")
      ->check(CLI::NonNegativeNumber);
  auto* seed = r->add_option("--seed", o->seed, "Sampler seed (overrides the scene's)");
  r->add_option("--cropwindow", o->crop, "Crop window x0 x1 y0 y1 (fractions of the image)")
      ->expected(4);
  r->add_option("--pixelbounds", o->pixelbounds, "Pixel bounds x0 x1 y0 y1 (half-open)")
      ->expected(4);
  r->add_flag("--quiet", o->quiet, "No progress bar or statistics");
  r->add_flag("--stats", o->stats, "Print render statistics (also printed unless --quiet)");
  r->add_flag("--autofocus", o->autofocus,
              "Focus the realistic camera on its autofocus zones first (see lensim autofocus)");
  r->add_option("--zones", o->zones, "Zone file for --autofocus (default: the camera's af_zones)");
  r->add_flag("--pbrt-v2-quirks", o->pbrt_v2_quirks,
              "Reproduce two artefacts of pbrt-v2 that old reference images carry: its ray "
              "epsilon of 1e-3 x the camera-ray parameter (loses shadows and light hits under a "
              "scaled camera transform) and its realistic camera's zero-weight samples next to "
              "vignetting edges. For comparing with such references; physically wrong");
  r->add_option("--tile", o->tile,
                "Render only tile I of N (0 <= I < N, row by row) and write it as an EXR part for "
                "lensim merge");
  r->add_option("--spp-range", o->spp_range,
                "Take only the sample indices A..B-1 of every pixel and write an EXR part for "
                "lensim merge");
  r->add_flag("--part", o->part,
              "Write the output as an EXR part (exact sums and render identity) even when whole");
  r->add_option("--checkpoint", o->checkpoint,
                "Write the finished tiles to this EXR file every --checkpoint-every, and at the "
                "end or on interruption (atomically)");
  auto* every = r->add_option("--checkpoint-every", o->checkpoint_every,
                              "Checkpoint interval, e.g. 60s, 500ms, 5m (default 60s)");
  r->add_option("--resume", o->resume,
                "Continue the render saved in this checkpoint (it must be of the same scene, "
                "seed, samples, tile and sample range); checkpoints go on to it unless "
                "--checkpoint names another file");
  r->add_option("--glass-catalog", o->glass_catalogs,
                "Glass catalogue file (.agf or .csv) searched before the scene's and the "
                "built-in ones; repeatable (docs/glass.md)");
  r->add_flag("--model-glass", o->model_glass,
              "A lens glass in no catalogue becomes a model glass from the n_d and V_d its lens "
              "file gives; without it such a glass is an error");
  r->add_flag("--glass-extrapolate", o->glass_extrapolate,
              "A lens glass whose formula is not valid over 405-700 nm is used there anyway, "
              "with a warning; without it such a glass is an error at the Camera line");
  return {seed, every};
}

/// The render options set directly by the command line: samples, seed, threads, crop window
/// (checked finite), pixel bounds, progress and quirks.
render::RenderOptions renderOptionsFrom(const Options& o, bool quiet) {
  render::RenderOptions ro;
  if (o.spp > 0) ro.spp = o.spp;
  if (o.has_seed) ro.seed = o.seed;
  ro.threads = o.threads;
  if (o.crop.size() == 4) {
    // pbrt-v4 orders and clamps each pair to [0, 1]; a value that is not a number cannot be.
    static const char* const kCropNames[4] = {"x0", "x1", "y0", "y1"};
    for (int i = 0; i < 4; ++i)
      if (!std::isfinite(o.crop[size_t(i)]))
        throw Error(
            fmt::format("--cropwindow: {} is {}; expected a finite fraction of the "
                        "image, in [0, 1] (--cropwindow x0 x1 y0 y1)",
                        kCropNames[i], o.crop[size_t(i)]));
    ro.crop = std::array<double, 4>{o.crop[0], o.crop[1], o.crop[2], o.crop[3]};
  }
  if (o.pixelbounds.size() == 4)
    ro.pixelbounds = std::array<int, 4>{o.pixelbounds[0], o.pixelbounds[1], o.pixelbounds[2],
                                        o.pixelbounds[3]};
  ro.progress = !quiet;
  ro.pbrt_v2_quirks = o.pbrt_v2_quirks;
  return ro;
}

/// Loads the checkpoint at `path` into `resume_state` after checking that it is of the same
/// render (its identity metadata, other than the scene's path, and its pixel bounds).
void loadResumeState(const std::string& path, const std::map<std::string, std::string>& identity,
                     const render::RenderPlan& plan, render::RenderCheckpoint& resume_state) {
  render::Part ck = render::readPart(path);
  for (const auto& [key, value] : identity) {
    if (key == "lensim:scene") continue;
    auto it = ck.metadata.find(key);
    const std::string theirs = it == ck.metadata.end() ? "(none)" : it->second;
    if (theirs != value)
      throw Error(FileLoc{path},
                  fmt::format("cannot resume: the checkpoint is of another render ({} "
                              "\"{}\", this render \"{}\")",
                              key, theirs, value));
  }
  if (!(ck.bounds == plan.bounds) || ck.tile_done.empty())
    throw Error(FileLoc{path},
                "cannot resume: not a checkpoint of this render's pixels");
  resume_state.bounds = ck.bounds;
  resume_state.tile_done = std::move(ck.tile_done);
  resume_state.sums = std::move(ck.sums);
  resume_state.ghost_sums = std::move(ck.ghost_sums);
}

/// Refuses, before rendering, outputs the film or the mode cannot write: layered films (spectral,
/// gbuffer) write whole EXRs only, Film "raw" a DNG or an EXR, parts and checkpoints EXRs.
void checkOutputs(const scene::Scene& s, const std::vector<std::string>& outs, bool part_mode,
                  const std::string& checkpoint) {
  // pbrt-v4's spectral and gbuffer films write EXR only (SpectralFilm::Create,
  // GBufferFilm::Create); their extra channels are not the exact fixed-point sums that parts,
  // checkpoints and lensim merge need.
  const bool layered = s.film.type == "spectral" || s.film.type == "gbuffer";
  if (layered && (part_mode || !checkpoint.empty()))
    throw Error(s.film.loc,
                fmt::format("Film \"{}\" cannot be rendered as parts or checkpointed "
                            "(--tile, --spp-range, --part, --checkpoint, --resume): its extra "
                            "channels are not kept as exact sums for lensim merge; render it "
                            "whole, or use Film \"rgb\"",
                            s.film.type));
  for (const std::string& out : outs)
    if (layered && io::imageFormatFromPath(out) != io::ImageFormat::Exr)
      throw Error(FileLoc{out}, fmt::format("Film \"{}\" writes EXR only (as pbrt-v4): use "
                                            "an .exr output",
                                            s.film.type));
  // Film "raw" (docs/sensor.md): a DNG raw file or an EXR of its electrons and DN.
  const bool raw = s.film.type == "raw";
  for (const std::string& out : outs)
    if (raw && !part_mode && !render::isDngPath(out) &&
        io::imageFormatFromPath(out) != io::ImageFormat::Exr)
      throw Error(FileLoc{out}, "Film \"raw\" writes a .dng raw file or an .exr of its "
                                "electrons and raw values: use a .dng or .exr output");
  for (const std::string& out : outs)  // a CFA tile a DNG cannot carry, before rendering
    if (raw && !part_mode && render::isDngPath(out))
      scene::checkDngCfa(scene::parseCfa(s.film.raw_sensor.cfa, s.film.loc), FileLoc{out},
                         s.film.raw_sensor.dng_cfa);
  for (const std::string& out : outs) {  // fail early (an unknown extension too)
    const bool exr = !(raw && render::isDngPath(out)) &&
                     io::imageFormatFromPath(out) == io::ImageFormat::Exr;
    if (part_mode && !exr)
      throw Error(FileLoc{out},
                  "--tile, --spp-range and --part write EXR parts (exact sums for lensim "
                  "merge): use an .exr output");
  }
}

/// Renders the scene `s` and writes the outputs; returns the exit status (130 or 143 when
/// interrupted).
int renderAndWrite(const Options& o, const scene::Scene& s, const render::RenderOptions& ro,
                   const std::vector<std::string>& outs, bool part_mode,
                   const std::string& checkpoint,
                   const std::map<std::string, std::string>& identity, bool quiet) {
  const bool raw = s.film.type == "raw";
  render::RenderResult res = render::render(s, ro);
  io::ImageWriteOptions wo;
  wo.tiff_format = io::TiffSampleFormat::Float32;
  wo.exr_half = s.film.save_fp16;  // Film "bool savefp16" true
  if (part_mode && res.stats.partial && !checkpoint.empty()) {
    // An interrupted part is not written: a part file that exists is complete (merge jobs
    // wait for them); the finished tiles are in the checkpoint.
    std::fprintf(stderr,
                 "lensim: interrupted; the finished tiles are in %s (continue with "
                 "--resume %s)\n",
                 checkpoint.c_str(), checkpoint.c_str());
    return interrupted() ? interruptExitStatus() : 130;
  }
  if (part_mode) {
    render::Part p;
    p.metadata = res.image.metadata;
    for (const auto& [key, value] : identity) p.metadata[key] = value;
    p.x_res = s.film.x_resolution, p.y_res = s.film.y_resolution;
    p.bounds = res.bounds;
    p.sums = std::move(res.sums);
    p.ghost_sums = std::move(res.ghost_sums);
    for (const std::string& out : outs) render::writePart(out, p);
  } else {
    for (const std::string& out : outs)
      if (raw)
        render::writeRawImage(out, res.image, res.bounds.x0, res.bounds.y0);
      else
        io::writeImage(out, res.image, wo);
  }
  if (res.stats.tiles_resumed > 0 && !quiet)
    logInfo(
        fmt::format("resumed {} finished tiles from {}", res.stats.tiles_resumed, o.resume));
  if (!quiet || o.stats) std::fputs(render::formatStats(res.stats).c_str(), stderr);
  for (const std::string& out : outs) {
    if (!quiet || o.stats)
      std::fprintf(stderr, "wrote %s (%dx%d%s)\n", out.c_str(), res.image.width,
                   res.image.height, res.stats.partial ? ", partial" : "");
    if (res.stats.partial)
      std::fprintf(stderr, "lensim: interrupted; the partial image was written to %s\n",
                   out.c_str());
  }
  if (interrupted()) return interruptExitStatus();
  if (res.stats.partial) return 130;
  return 0;
}

/// `lensim render`: loads the scene (after the glass catalogues), focuses it if asked, sets up
/// parts, checkpoints and resuming, checks the outputs, renders and writes.
int runRender(const Options& o) {
  const bool quiet = o.quiet || lensim::quiet();
  const auto t_load = std::chrono::steady_clock::now();
  optics::setModelGlassAllowed(o.model_glass);
  optics::setGlassExtrapolationAllowed(o.glass_extrapolate);
  for (const std::string& f : o.glass_catalogs) optics::addGlassCatalogFile(f, FileLoc{f});
  scene::Scene s = scene::loadScene(o.scene);
  const double load_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_load).count();
  logDiagnostics(s.diagnostics);
  if (o.autofocus) {
    render::SceneAutofocusOptions af;
    af.zones_file = o.zones;
    af.threads = o.threads;
    const render::SceneAutofocusResult f = render::autofocusScene(s, af);
    // A lens that focuses by a group keeps its film: the group is set as focusdistance sets it.
    if (f.group_focusing)
      render::setFocusDistance(s, f.focus_distance_m);
    else
      render::setFilmDistance(s, f.film_distance_mm);
    if (!quiet)
      logInfo(f.group_focusing
                  ? fmt::format("autofocus: group focusing, focus distance {:.4g} m ({} zone "
                                "renders, {:.1f} s)",
                                f.focus_distance_m, f.renders, f.seconds)
                  : fmt::format("autofocus: film distance {:.4f} mm ({} zone renders, {:.1f} s)",
                                f.film_distance_mm, f.renders, f.seconds));
  }
  render::RenderOptions ro = renderOptionsFrom(o, quiet);
  // The first SIGINT or SIGTERM stops the render, which writes what it has (a part with a
  // checkpoint: the checkpoint) and exits 130 or 143; a second one ends lensim at once
  // (util/interrupt.h).
  CancellableScope cancellable;
  ro.cancel = &interruptFlag();
  // Distributed renders: parts with exact sums, checkpoints, resuming.
  if (!o.tile.empty()) ro.tile = render::parseTile(o.tile);
  if (!o.spp_range.empty()) ro.spp_range = render::parseSppRange(o.spp_range);
  const bool part_mode = ro.tile || ro.spp_range || o.part;
  ro.keep_sums = part_mode;
  const std::string checkpoint = o.checkpoint.empty() ? o.resume : o.checkpoint;
  std::map<std::string, std::string> identity;
  render::RenderPlan plan;
  if (part_mode || !checkpoint.empty()) {
    plan = render::planRender(s, ro);
    identity = render::renderIdentity(s, ro, plan, LENSIM_VERSION);
  }
  render::RenderCheckpoint resume_state;
  if (!o.resume.empty()) {
    loadResumeState(o.resume, identity, plan, resume_state);
    ro.resume = &resume_state;
  }
  if (!checkpoint.empty()) {
    if (io::imageFormatFromPath(checkpoint) != io::ImageFormat::Exr)
      throw Error(FileLoc{checkpoint}, "a checkpoint must be an .exr file");
    ro.checkpoint_every_s = render::parseDuration(o.checkpoint_every);
    ro.on_checkpoint = [checkpoint, identity, &s](const render::RenderCheckpoint& c) {
      render::Part p;
      p.metadata = identity;
      if (!c.complete()) p.metadata["lensim:partial"] = "true";
      p.x_res = s.film.x_resolution, p.y_res = s.film.y_resolution;
      p.bounds = c.bounds;
      p.sums = c.sums;
      p.ghost_sums = c.ghost_sums;
      p.tile_done = c.tile_done;
      render::writePart(checkpoint, p);
    };
  }
  ro.scene_load_s = load_s;
  // The film's filename is relative to the directory lensim runs in, as in pbrt.
  std::vector<std::string> outs = o.outfiles;
  if (outs.empty()) outs.push_back(s.film.filename);
  checkOutputs(s, outs, part_mode, checkpoint);
  return renderAndWrite(o, s, ro, outs, part_mode, checkpoint, identity, quiet);
}

}  // namespace

void registerRenderCommand(CLI::App& app, Action& action) {
  auto o = std::make_shared<Options>();
  CLI::App* r = app.add_subcommand("render", "Render a pbrt scene (v4, or the v1–v3 syntax)");
  auto [seed, every] = addRenderOptions(r, o.get());
  r->callback([o, seed, every, &action]() {
    o->has_seed = seed->count() > 0;
    if (every->count() > 0 && o->checkpoint.empty() && o->resume.empty())
      throw CLI::ValidationError("--checkpoint-every",
                                 "needs --checkpoint FILE (or --resume FILE)");
    action = [o]() -> int { return runRender(*o); };
  });
}

}  // namespace lensim::cmd
