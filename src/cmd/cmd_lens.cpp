#include <CLI/CLI.hpp>

#include "commands.h"

namespace lensim::cmd {

void registerLensCommands(CLI::App& app, Action& /*action*/) {
  CLI::App* lens = app.add_subcommand("lens", "Analyse a lens prescription");
  lens->require_subcommand(1);
}

}  // namespace lensim::cmd
