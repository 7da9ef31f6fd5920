// `lensim check SCENE`: parses and builds a pbrt scene and prints what it contains.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "lensim/camera/realistic.h"
#include "lensim/render/materials/measured_rgl.h"
#include "lensim/scene/description.h"
#include "lensim/scene/format.h"
#include "lensim/scene/parser.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

void registerCheckCommand(CLI::App& app, Action& action) {
  struct Options {
    std::string scene;
    bool format = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* check = app.add_subcommand(
      "check", "Parse and build a pbrt scene (v4, or the v1–v3 syntax); print a summary");
  check->add_option("scene", opts->scene, "Scene file (.pbrt)")->required();
  check->add_flag("--format", opts->format,
                  "Print the scene in normalised pbrt-v4 syntax instead of the summary");
  check->callback([opts, &action]() {
    action = [opts]() -> int {
      scene::SceneDesc desc = scene::parseFile(opts->scene);
      scene::Scene s = scene::build(desc);
      // Errors (with the warnings) go to stderr; a clean scene's warnings are part of the
      // summary, or go to stderr with --format so that stdout stays a scene file.
      if (s.hasErrors() || opts->format) logDiagnostics(s.diagnostics);
      if (s.hasErrors()) return 1;
      // RGL measured BSDF files are read as the renderer will (cheap: no table is fitted), so
      // that check reports a truncated or corrupt one.
      for (const scene::Material& m : s.materials)
        if (const auto* measured = std::get_if<scene::MeasuredParams>(&m.params))
          if (measured->rgl) (void)render::RGLMeasuredBRDF::loadCached(measured->file);
      std::string text = opts->format ? scene::formatPbrtV4(desc) : scene::summary(s);
      // A realistic camera is set up as the renderer will (lens file, focus, pupil bounds), so
      // that check reports a bad lens or an unreachable focus too.
      if (!opts->format && s.camera.type == "realistic") {
        auto camera = camera::makeRealisticCamera(s);
        text += "lens set-up: " + camera->describe() + "\n";
      }
      std::fwrite(text.data(), 1, text.size(), stdout);
      return 0;
    };
  });
}

}  // namespace lensim::cmd
