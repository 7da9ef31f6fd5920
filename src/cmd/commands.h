// Registration of the command groups of the `lensim` tool. Each group lives in its own file and
// adds its subcommands to the application; the callback a subcommand sets runs after parsing and
// returns the process exit status.
#pragma once

#include <functional>

namespace CLI {
class App;
}

namespace lensim::cmd {

/// What main runs once the command line has been parsed: returns the exit status.
using Action = std::function<int()>;

/// `lensim lens ...`: lens analysis (info, trace).
void registerLensCommands(CLI::App& app, Action& action);
/// `lensim lens optimise|tolerance JOB`: lens design (cmd_design.cpp), under `lens`.
void registerDesignCommands(CLI::App* lens, Action& action);

/// `lensim check SCENE [--format]`: parse and build a pbrt scene, print a summary.
void registerCheckCommand(CLI::App& app, Action& action);

/// `lensim render SCENE [--spp N] [--outfile F] ...`: render a pbrt scene to an image.
void registerRenderCommand(CLI::App& app, Action& action);

/// `lensim autofocus SCENE`.
void registerAutofocusCommand(CLI::App& app, Action& action);

/// `lensim compare IMAGE REFERENCE [--second IMAGE2] ...`: agreement within noise.
void registerCompareCommand(CLI::App& app, Action& action);

/// `lensim serve [--port N] [--scene S] [--lenses DIR]`: the lens explorer web page.
void registerServeCommand(CLI::App& app, Action& action);
/// `lensim merge OUT PART...`: merge the parts of a distributed render exactly.
void registerMergeCommand(CLI::App& app, Action& action);

/// `lensim develop RAW.dng -o OUT`: a raw DNG developed to an image (docs/sensor.md).
void registerDevelopCommand(CLI::App& app, Action& action);

/// `lensim dispatch SCENE --engine slurm|kubernetes --jobs N`: cluster job files.
void registerDispatchCommand(CLI::App& app, Action& action);

}  // namespace lensim::cmd
