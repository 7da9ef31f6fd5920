// `lensim serve`: the lens explorer, a local web page over lensim's optics and renderer.
#include <fmt/format.h>
#include <pthread.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "commands.h"
#include "lensim/serve/server.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

namespace {

/// `relative` in the working directory if it is there, else in the source tree lensim was built
/// from (so `build/lensim serve` works from anywhere on a developer's machine).
std::string defaultPath(const std::string& relative) {
  if (std::filesystem::exists(relative)) return relative;
  return std::string(LENSIM_SOURCE_DIR) + "/" + relative;
}

}  // namespace

void registerServeCommand(CLI::App& app, Action& action) {
  struct Options {
    int port = 8080;
    std::string host = "127.0.0.1";
    std::string scene;
    std::vector<std::string> lenses;
    int max_previews = 4;
  };
  auto o = std::make_shared<Options>();
  CLI::App* s = app.add_subcommand(
      "serve", "Lens explorer: a local web page with lens diagrams, plots and a live preview");
  s->add_option("--port", o->port, "TCP port (default 8080; 0: any free port)")
      ->check(CLI::Range(0, 65535));
  s->add_option("--host", o->host,
                "Address to listen on (default 127.0.0.1: this machine only; the server has no "
                "authentication)");
  s->add_option("--scene", o->scene,
                "Scene previewed through the lens (default scenes/demo/demo.pbrt); the page may "
                "choose other scenes of its folder");
  s->add_option("--lenses", o->lenses,
                "Lens folder (repeatable; default lenses/): every .dat, .zmx and .json file under "
                "it is listed");
  s->add_option("--max-previews", o->max_previews, "Previews rendering at once (default 4)")
      ->check(CLI::Range(1, 64));
  s->callback([o, &action] {
    action = [o]() -> int {
      serve::ServerConfig c;
      c.host = o->host;
      c.port = o->port;
      c.scene = o->scene.empty() ? defaultPath("scenes/demo/demo.pbrt") : o->scene;
      c.lens_folders = o->lenses;
      if (c.lens_folders.empty()) c.lens_folders.push_back(defaultPath("lenses"));
      c.max_previews = o->max_previews;
      // Ctrl-C and SIGTERM stop the server cleanly: the signals are blocked in every thread and
      // taken by one that stops the server.
      sigset_t set;
      sigemptyset(&set);
      sigaddset(&set, SIGINT);
      sigaddset(&set, SIGTERM);
      pthread_sigmask(SIG_BLOCK, &set, nullptr);
      serve::Server server(c);
      if (c.host != "127.0.0.1" && c.host != "localhost" && c.host != "::1")
        logWarning(
            fmt::format("listening on {}: anyone who can reach it can use the server", c.host));
      std::printf("lensim serve: http://%s:%d/\n", c.host.c_str(), server.port());
      std::fflush(stdout);
      std::thread([set, &server] {
        int sig = 0;
        sigwait(&set, &sig);
        server.stop();
      }).detach();
      server.run();
      return 0;
    };
  });
}

}  // namespace lensim::cmd
