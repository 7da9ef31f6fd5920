// lensim: a physically based renderer built around real camera lenses.
// This file only parses the command line and reports errors; the work is in the library.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <string>

#include "commands.h"
#include "lensim/util/error.h"
#include "lensim/util/interrupt.h"
#include "lensim/util/limits.h"
#include "lensim/util/log.h"
#include "lensim/util/text.h"

int main(int argc, char** argv) {
  CLI::App app{"lensim: a physically based renderer built around real camera lenses"};
  app.set_version_flag("--version", std::string("lensim ") + LENSIM_VERSION);
  app.require_subcommand(1);
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "Print no progress or information (warnings still appear)");
  std::string memory_limit;
  app.add_option("--memory-limit", memory_limit,
                 "Refuse inputs whose estimated memory exceeds SIZE (e.g. 4G, 512M; default: half "
                 "the physical memory)");
  // Options of the main command (--memory-limit, -q) may also follow the subcommand.
  app.fallthrough();
  lensim::installInterruptHandlers();

  lensim::cmd::Action action;
  lensim::cmd::registerLensCommands(app, action);
  lensim::cmd::registerCheckCommand(app, action);
  lensim::cmd::registerRenderCommand(app, action);
  lensim::cmd::registerAutofocusCommand(app, action);
  lensim::cmd::registerCompareCommand(app, action);
  lensim::cmd::registerServeCommand(app, action);
  lensim::cmd::registerMergeCommand(app, action);
  lensim::cmd::registerDispatchCommand(app, action);
  lensim::cmd::registerDevelopCommand(app, action);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; usage errors exit 1 as every other error does.
    int status = app.exit(e);
    return status == 0 ? 0 : 1;
  }
  lensim::setQuiet(quiet);
  if (!memory_limit.empty()) {
    auto bytes = lensim::parseMemorySize(memory_limit);
    if (!bytes) {
      std::fprintf(stderr,
                   "lensim: error: --memory-limit: expected a size such as 4G or 512M, "
                   "found '%s'\n",
                   lensim::shortToken(memory_limit).c_str());
      return 1;
    }
    lensim::setMemoryBudgetBytes(*bytes);
  }

  try {
    return action ? action() : 1;
  } catch (const lensim::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "lensim: error: out of memory (see --memory-limit)\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lensim: error: %s\n", lensim::sanitizeMessage(e.what()).c_str());
    return 1;
  }
}
