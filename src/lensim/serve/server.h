// `lensim serve`: the lens explorer's HTTP server (cpp-httplib). It serves the page (embedded in
// the binary, see web_assets.h) and the JSON API of docs/serve.md, and streams previews.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace lensim::serve {

struct ServerConfig {
  std::string host = "127.0.0.1";
  int port = 8080;                        ///< 0: any free port (see Server::port())
  std::vector<std::string> lens_folders;  ///< at least one
  std::string scene;                      ///< the default scene; its folder is the scene folder
  int max_previews = 4;                   ///< previews rendering at once; more get 503
  int threads = 16;                       ///< HTTP worker threads
};

class Server {
 public:
  /// Checks the folders and the scene (throws lensim::Error) and binds the socket (throws if the
  /// port is taken).
  explicit Server(ServerConfig config);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// The bound port.
  int port() const;
  /// Serves until stop() (from another thread or a signal handler's thread).
  void run();
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lensim::serve
