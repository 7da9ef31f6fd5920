// `lensim render SCENE`: renders a pbrt scene to an image (EXR, TIFF or PNG by extension).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "lensim/io/image.h"
#include "lensim/render/autofocus_scene.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/builder.h"
#include "lensim/util/interrupt.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

void registerRenderCommand(CLI::App& app, Action& action) {
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
  };
  auto o = std::make_shared<Options>();
  CLI::App* r = app.add_subcommand("render", "Render a pbrt scene (v4, or the v1–v3 syntax)");
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
  r->callback([o, seed, &action]() {
    o->has_seed = seed->count() > 0;
    action = [o]() -> int {
      const bool quiet = o->quiet || lensim::quiet();
      scene::Scene s = scene::loadScene(o->scene);
      logDiagnostics(s.diagnostics);
      if (o->autofocus) {
        render::SceneAutofocusOptions af;
        af.zones_file = o->zones;
        af.threads = o->threads;
        const render::SceneAutofocusResult f = render::autofocusScene(s, af);
        render::setFilmDistance(s, f.film_distance_mm);
        if (!quiet)
          logInfo(fmt::format("autofocus: film distance {:.4f} mm ({} zone renders, {:.1f} s)",
                              f.film_distance_mm, f.renders, f.seconds));
      }
      render::RenderOptions ro;
      if (o->spp > 0) ro.spp = o->spp;
      if (o->has_seed) ro.seed = o->seed;
      ro.threads = o->threads;
      if (o->crop.size() == 4)
        ro.crop = std::array<double, 4>{o->crop[0], o->crop[1], o->crop[2], o->crop[3]};
      if (o->pixelbounds.size() == 4)
        ro.pixelbounds = std::array<int, 4>{o->pixelbounds[0], o->pixelbounds[1], o->pixelbounds[2],
                                            o->pixelbounds[3]};
      ro.progress = !quiet;
      ro.pbrt_v2_quirks = o->pbrt_v2_quirks;
      // The first SIGINT or SIGTERM stops the render, which writes what it has and exits 130 or
      // 143; a second one ends lensim at once (util/interrupt.h).
      CancellableScope cancellable;
      ro.cancel = &interruptFlag();
      // The film's filename is relative to the directory lensim runs in, as in pbrt.
      std::vector<std::string> outs = o->outfiles;
      if (outs.empty()) outs.push_back(s.film.filename);
      for (const std::string& out : outs) io::imageFormatFromPath(out);  // fail early
      render::RenderResult res = render::render(s, ro);
      io::ImageWriteOptions wo;
      wo.tiff_format = io::TiffSampleFormat::Float32;
      for (const std::string& out : outs) io::writeImage(out, res.image, wo);
      if (!quiet || o->stats) std::fputs(render::formatStats(res.stats).c_str(), stderr);
      for (const std::string& out : outs) {
        if (!quiet || o->stats)
          std::fprintf(stderr, "wrote %s (%dx%d%s)\n", out.c_str(), res.image.width,
                       res.image.height, res.stats.partial ? ", partial" : "");
        if (res.stats.partial)
          std::fprintf(stderr, "lensim: interrupted; the partial image was written to %s\n",
                       out.c_str());
      }
      if (interrupted()) return interruptExitStatus();
      if (res.stats.partial) return 130;
      return 0;
    };
  });
}

}  // namespace lensim::cmd
