#include "lensim/serve/server.h"

#include <fmt/format.h>
#include <httplib.h>
#include <sys/socket.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <future>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "lensim/scene/description.h"
#include "lensim/serve/catalog.h"
#include "lensim/serve/lens_view.h"
#include "lensim/serve/preview.h"
#include "lensim/serve/web_assets.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::serve {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

/// A request the server refuses: answered with `status` and a JSON {"error": message}.
struct ApiError {
  int status;
  std::string message;
};

// The page reads the PNG frames from JSON text, so they go as base64. cpp-httplib keeps its
// encoder in its private detail namespace, hence these few lines.
std::string base64(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8) | uint8_t(in[i + 2]);
    out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += t[v & 63];
  }
  if (i + 1 == in.size()) {
    const uint32_t v = uint8_t(in[i]) << 16;
    out += t[v >> 18], out += t[(v >> 12) & 63], out += "==";
  } else if (i + 2 == in.size()) {
    const uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8);
    out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += '=';
  }
  return out;
}

std::optional<std::string> param(const httplib::Request& rq, const char* name) {
  if (!rq.has_param(name)) return std::nullopt;
  return rq.get_param_value(name);
}

std::optional<double> number(const httplib::Request& rq, const char* name, double lo, double hi) {
  auto s = param(rq, name);
  if (!s) return std::nullopt;
  double v = 0;
  auto [ptr, ec] = std::from_chars(s->data(), s->data() + s->size(), v);
  if (s->empty() || ec != std::errc() || ptr != s->data() + s->size() || !std::isfinite(v) ||
      v < lo || v > hi)
    throw ApiError{400, fmt::format("parameter {}='{}': expected a number from {:g} to {:g}", name,
                                    s->substr(0, 64), lo, hi)};
  return v;
}

int integer(const httplib::Request& rq, const char* name, int lo, int hi, int fallback) {
  auto v = number(rq, name, lo, hi);
  if (!v) return fallback;
  if (*v != std::floor(*v))
    throw ApiError{400, fmt::format("parameter {}={}: expected a whole number", name, *v)};
  return int(*v);
}

/// "inf"/"infinity" or metres (> 0); nullopt when absent.
std::optional<double> focusParam(const httplib::Request& rq) {
  auto s = param(rq, "focus");
  if (!s) return std::nullopt;
  if (*s == "inf" || *s == "infinity") return std::numeric_limits<double>::infinity();
  auto v = number(rq, "focus", 1e-4, 1e6);
  if (*v <= 0) throw ApiError{400, "parameter focus: expected metres > 0 or 'inf'"};
  return v;
}

json entryJson(const LensEntry& e) {
  json j{{"id", e.id}, {"name", e.name}, {"format", e.format}, {"folder", e.folder}};
  if (e.error.empty()) {
    j["focal_length_mm"] = *e.focal_length_mm;
    j["f_number"] = *e.f_number;
    j["stop_diameter_mm"] = *e.stop_diameter_mm;
    j["surface_count"] = e.surface_count;
  } else {
    j["error"] = e.error;
  }
  return j;
}

bool isLoopback(const std::string& host) {
  return host == "127.0.0.1" || host == "localhost" || host == "::1" || host == "[::1]";
}

bool looksLikeScene(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::string head(1 << 16, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  return head.find("WorldBegin") != std::string::npos || head.find("Camera") != std::string::npos;
}

}  // namespace

struct Server::Impl {
  ServerConfig config;
  LensCatalog catalog;
  fs::path scene_folder;
  std::string default_scene_id;
  PreviewRenderer previews;
  PreviewViews views;
  httplib::Server http;
  int port = 0;
  int listen_socket = -1;

  explicit Impl(ServerConfig c) : config(std::move(c)), catalog(config.lens_folders) {
    std::error_code ec;
    const fs::path scene = fs::canonical(config.scene, ec);
    if (ec || !fs::is_regular_file(scene))
      throw Error(fmt::format("scene '{}' does not exist", config.scene));
    scene_folder = scene.parent_path();
    default_scene_id = scene.filename().string();
    previews.scene(scene.string());  // parse and build now: errors show at start, not in the page
    routes();
    http.new_task_queue = [n = config.threads] { return new httplib::ThreadPool(size_t(n)); };
    http.set_payload_max_length(1 << 16);
    // cpp-httplib 0.11 listens with a backlog of 5, compiled into Debian's library: a burst of
    // connections beyond that waits for the client's SYN retry (1 s, then 3 s). The socket is
    // recorded when it is made, and listen() is called again with a deeper queue once bound.
    http.set_socket_options([this](int sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
      listen_socket = sock;
    });
    port = config.port == 0 ? http.bind_to_any_port(config.host)
                            : (http.bind_to_port(config.host, config.port) ? config.port : -1);
    if (port < 0)
      throw Error(fmt::format("cannot listen on {}:{} (in use, or not an address of this machine)",
                              config.host, config.port));
    if (listen_socket >= 0) ::listen(listen_socket, SOMAXCONN);
  }

  fs::path lensPath(const httplib::Request& rq) {
    auto id = param(rq, "lens");
    if (!id) throw ApiError{400, "parameter lens is missing (an id from /api/lenses)"};
    auto r = catalog.resolve(*id);
    if (auto* e = std::get_if<PathError>(&r)) throw ApiError{e->status, e->message};
    return std::get<fs::path>(r);
  }

  fs::path scenePath(const httplib::Request& rq) {
    const std::string id = param(rq, "scene").value_or(default_scene_id);
    auto r = resolveInside(scene_folder, id, {".pbrt"});
    if (auto* e = std::get_if<PathError>(&r)) throw ApiError{e->status, "scene " + e->message};
    return std::get<fs::path>(r);
  }

  LensSettings lensSettings(const httplib::Request& rq) {
    LensSettings s;
    s.path = lensPath(rq).string();
    s.f_number = number(rq, "fnumber", 0.1, 1000);
    s.aperture_diameter_mm = number(rq, "aperture", 1e-3, 1000);
    if (s.f_number && s.aperture_diameter_mm)
      throw ApiError{400, "give fnumber or aperture, not both"};
    s.focus_distance_m = focusParam(rq);
    s.film_diagonal_mm = number(rq, "diagonal", 0.1, 1000).value_or(35.0);
    // A zoom lens: a configuration (1-based) or a focal length between the configurations.
    if (param(rq, "config")) s.configuration = integer(rq, "config", 1, 1000, 1);
    s.zoom_focal_length_mm = number(rq, "focal", 0.01, 1e5);
    if (s.configuration && s.zoom_focal_length_mm)
      throw ApiError{400, "give config or focal, not both"};
    // Tilt (degrees about the film's x and y axes, within +-45) and shift (mm), as `lens info`.
    s.tilt_shift.tilt_deg = {number(rq, "tiltx", -44.99, 44.99).value_or(0.0),
                             number(rq, "tilty", -44.99, 44.99).value_or(0.0)};
    s.tilt_shift.shift_mm = {number(rq, "shiftx", -1000, 1000).value_or(0.0),
                             number(rq, "shifty", -1000, 1000).value_or(0.0)};
    return s;
  }

  json sceneJson(const std::string& id) {
    auto s = previews.scene((scene_folder / id).string());
    json j{{"id", id},
           {"width", s->film.x_resolution},
           {"height", s->film.y_resolution},
           {"film_diagonal_mm", s->film.diagonal_mm},
           {"camera", s->camera.type}};
    if (s->camera.realistic) {
      const auto& r = *s->camera.realistic;
      j["focus_distance_m"] = r.focus_distance_m;
      j["aperture_diameter_mm"] = r.aperture_diameter_mm;
      if (auto lens = catalog.idOf(r.lens_file)) j["lens"] = *lens;
    }
    return j;
  }

  static void sendJson(httplib::Response& res, const json& j, int status = 200) {
    res.status = status;
    res.set_header("Cache-Control", "no-store");
    res.set_content(j.dump(-1, ' ', false, json::error_handler_t::replace), "application/json");
  }

  /// Wraps a handler: ApiError -> its status, lensim::Error (a lens or scene that cannot be used
  /// as asked) -> 422, anything else -> 500; always a JSON message.
  template <class F>
  httplib::Server::Handler guard(F f) {
    return [f](const httplib::Request& rq, httplib::Response& res) {
      try {
        f(rq, res);
      } catch (const ApiError& e) {
        sendJson(res, {{"error", e.message}}, e.status);
      } catch (const Error& e) {
        sendJson(res, {{"error", e.what()}}, 422);
      } catch (const std::exception& e) {
        sendJson(res, {{"error", fmt::format("internal error: {}", e.what())}}, 500);
      }
    };
  }

  void startPreview(const httplib::Request& rq, httplib::Response& res, const std::string& view,
                    const PreviewViews::Ticket& ticket) {
    LensSettings ls = lensSettings(rq);
    // The preview renders the lens as the optics show it: zoomed, tilted and shifted as asked.
    const fs::path scene_path = scenePath(rq);
    auto shown = previews.scene(scene_path.string());
    if (!param(rq, "diagonal")) ls.film_diagonal_mm = shown->film.diagonal_mm;
    if (!ls.focus_distance_m)
      ls.focus_distance_m =
          shown->camera.realistic ? shown->camera.realistic->focus_distance_m : 10.0;
    const SetUpLens lens = setUpLens(ls);  // a lens that cannot focus there fails here, as 422
    PreviewRequest pr;
    pr.scene_path = scene_path.string();
    pr.lens_path = ls.path;
    pr.aperture_diameter_mm = lens.stop_diameter_mm;
    pr.focus_distance_m = *ls.focus_distance_m;
    pr.tilt_shift = ls.tilt_shift;
    pr.configuration = ls.configuration;
    pr.zoom_focal_length_mm = ls.zoom_focal_length_mm;
    pr.width = integer(rq, "width", 16, 1920, 320);
    pr.max_spp = integer(rq, "spp", 1, 4096, 64);
    pr.seed = integer(rq, "seed", 0, 1 << 30, 0);
    if (param(rq, "exposure").value_or("") == "auto")
      pr.auto_exposure = true;
    else
      pr.exposure_stops = number(rq, "exposure", -20, 20).value_or(0.0);
    auto prepared = std::make_shared<scene::Scene>(previews.previewScene(pr));
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, pr, prepared, ticket, view](size_t, httplib::DataSink& sink) {
          // The render runs on a thread of its own (at a lower priority, see
          // PreviewRenderer::run); this thread writes its events, and cancels the render when
          // the client has gone.
          struct Queue {
            std::mutex m;
            std::condition_variable cv;
            std::deque<std::string> events;
            bool end = false;
          };
          auto q = std::make_shared<Queue>();
          auto push = [q](const std::string& event, const json& data) {
            {
              std::lock_guard lock(q->m);
              q->events.push_back(
                  fmt::format("event: {}\ndata: {}\n\n", event,
                              data.dump(-1, ' ', false, json::error_handler_t::replace)));
            }
            q->cv.notify_one();
          };
          std::thread worker([this, pr, prepared, ticket, q, push] {
            const auto t_start = std::chrono::steady_clock::now();
            try {
              const bool finished =
                  previews.run(*prepared, pr, *ticket.cancel, [&](const PreviewFrame& f) {
                    push("frame", {{"pass", f.pass},
                                   {"spp", f.spp},
                                   {"width", f.width},
                                   {"height", f.height},
                                   {"render_ms", f.render_ms},
                                   {"elapsed_ms", f.elapsed_ms},
                                   {"exposure_stops", f.exposure_stops},
                                   {"png", base64(f.png)}});
                    return !ticket.cancel->load();
                  });
              if (finished)
                push("done", {{"elapsed_ms", std::chrono::duration<double, std::milli>(
                                                 std::chrono::steady_clock::now() - t_start)
                                                 .count()}});
              else
                push("cancelled", {{"cancel_latency_ms", ticket.msSinceCancel()}});
            } catch (const std::exception& e) {
              push("error", {{"error", e.what()}});
            }
            ticket.stopped->store(true);
            {
              std::lock_guard lock(q->m);
              q->end = true;
            }
            q->cv.notify_one();
          });
          bool gone = false;
          for (;;) {
            std::unique_lock lock(q->m);
            q->cv.wait_for(lock, std::chrono::milliseconds(50),
                           [&] { return !q->events.empty() || q->end; });
            if (!q->events.empty()) {
              const std::string msg = std::move(q->events.front());
              q->events.pop_front();
              lock.unlock();
              if (!gone && !sink.write(msg.data(), msg.size())) gone = true;
            } else if (q->end) {
              break;
            } else {
              lock.unlock();
              if (!gone && sink.is_writable && !sink.is_writable()) gone = true;
            }
            if (gone) ticket.cancel->store(true);
          }
          worker.join();
          views.finish(view, ticket);
          if (!gone) sink.done();
          return !gone;
        },
        [this, view, ticket](bool) { views.finish(view, ticket); });
  }

  /// Bound to a loopback address, the server answers only requests addressed to it by a
  /// loopback name: a web page elsewhere cannot reach it through a DNS name that resolves to
  /// 127.0.0.1.
  void refuseForeignHosts() {
    const bool loopback = isLoopback(config.host);
    http.set_pre_routing_handler([loopback](const httplib::Request& rq, httplib::Response& res) {
      if (!loopback) return httplib::Server::HandlerResponse::Unhandled;
      std::string host = rq.get_header_value("Host");
      if (host.starts_with("["))
        host = host.substr(0, host.find(']') + 1);
      else
        host = host.substr(0, host.find(':'));
      if (host.empty() || isLoopback(host)) return httplib::Server::HandlerResponse::Unhandled;
      sendJson(res,
               {{"error", fmt::format("Host '{}' refused: this server answers only to "
                                      "127.0.0.1, localhost and [::1]",
                                      host.substr(0, 64))}},
               403);
      return httplib::Server::HandlerResponse::Handled;
    });
  }

  /// The explorer's web page and its scripts, styles and images.
  void assetRoutes() {
    size_t n = 0;
    const WebAsset* assets = webAssets(&n);
    for (size_t i = 0; i < n; ++i) {
      const WebAsset a = assets[i];
      std::string type = "text/plain";
      if (a.path.ends_with(".html")) type = "text/html; charset=utf-8";
      if (a.path.ends_with(".js")) type = "text/javascript; charset=utf-8";
      if (a.path.ends_with(".css")) type = "text/css; charset=utf-8";
      if (a.path.ends_with(".svg")) type = "image/svg+xml";
      auto handler = [a, type](const httplib::Request&, httplib::Response& res) {
        res.set_content(a.content.data(), a.content.size(), type.c_str());
      };
      http.Get(std::string(a.path), handler);
      if (a.path == "/index.html") http.Get("/", handler);
    }
  }

  /// The server, its lenses and its scenes: /api/info, /api/lenses, /api/scenes, /api/scene.
  void catalogueRoutes() {
    http.Get("/api/info", guard([this](const httplib::Request&, httplib::Response& res) {
               json kinds = json::array();
               for (const PlotKind& k : plotKinds())
                 kinds.push_back({{"name", k.name}, {"title", k.title}});
               json folders = json::array();
               for (const fs::path& f : catalog.folders()) folders.push_back(f.string());
               sendJson(res, {{"version", LENSIM_VERSION_STRING},
                              {"lens_folders", folders},
                              {"scene_folder", scene_folder.string()},
                              {"scene", sceneJson(default_scene_id)},
                              {"plot_kinds", kinds},
                              {"max_previews", config.max_previews}});
             }));

    http.Get("/api/lenses", guard([this](const httplib::Request&, httplib::Response& res) {
               json arr = json::array();
               for (const LensEntry& e : catalog.list()) arr.push_back(entryJson(e));
               sendJson(res, {{"lenses", arr}});
             }));

    http.Get("/api/scenes", guard([this](const httplib::Request&, httplib::Response& res) {
               json arr = json::array();
               std::error_code ec;
               std::vector<std::string> ids;
               for (const auto& e : fs::directory_iterator(scene_folder, ec))
                 if (e.is_regular_file(ec) && e.path().extension() == ".pbrt" &&
                     looksLikeScene(e.path()))
                   ids.push_back(e.path().filename().string());
               std::sort(ids.begin(), ids.end());
               for (const std::string& id : ids)
                 arr.push_back({{"id", id}, {"default", id == default_scene_id}});
               sendJson(res, {{"scenes", arr}});
             }));

    http.Get("/api/scene", guard([this](const httplib::Request& rq, httplib::Response& res) {
               const fs::path p = scenePath(rq);
               sendJson(res, sceneJson(p.lexically_relative(scene_folder).generic_string()));
             }));
  }

  /// One lens as set up by the request: /api/lens, /api/diagram, /api/plot, /api/view.
  void lensRoutes() {
    http.Get("/api/lens", guard([this](const httplib::Request& rq, httplib::Response& res) {
               const LensSettings s = lensSettings(rq);
               json j = firstOrderJson(setUpLens(s), s.film_diagonal_mm);
               j["id"] = *param(rq, "lens");
               sendJson(res, j);
             }));

    http.Get("/api/diagram", guard([this](const httplib::Request& rq, httplib::Response& res) {
               const LensSettings s = lensSettings(rq);
               const int rays = integer(rq, "rays", 1, 101, 11);
               const std::string from = param(rq, "from").value_or("film");
               if (from != "film" && from != "scene")
                 throw ApiError{400, "parameter from: expected 'film' or 'scene'"};
               res.set_header("Cache-Control", "no-store");
               res.set_content(diagramSvg(setUpLens(s), s.film_diagonal_mm, rays, from == "scene"),
                               "image/svg+xml");
             }));

    http.Get("/api/plot", guard([this](const httplib::Request& rq, httplib::Response& res) {
               const std::string kind = param(rq, "kind").value_or("");
               const PlotKind* k = findPlotKind(kind);
               if (!k) {
                 std::string names;
                 for (const PlotKind& p : plotKinds())
                   names += (names.empty() ? "" : ", ") + p.name;
                 throw ApiError{400, fmt::format("parameter kind='{}': expected one of {}",
                                                 kind.substr(0, 64), names)};
               }
               const LensSettings s = lensSettings(rq);
               res.set_header("Cache-Control", "no-store");
               res.set_content(k->svg(setUpLens(s).lens, s.film_diagonal_mm), "image/svg+xml");
             }));

    // Everything a slider move redraws, in one request: the numbers, the diagram and every plot,
    // computed in parallel (one lens set-up shared by all).
    http.Get("/api/view", guard([this](const httplib::Request& rq, httplib::Response& res) {
               const LensSettings s = lensSettings(rq);
               const SetUpLens lens = setUpLens(s);
               std::vector<std::future<std::string>> plots;
               for (const PlotKind& k : plotKinds())
                 plots.push_back(std::async(std::launch::async, [&lens, &k, &s] {
                   return k.svg(lens.lens, s.film_diagonal_mm);
                 }));
               json j;
               j["lens"] = firstOrderJson(lens, s.film_diagonal_mm);
               j["lens"]["id"] = *param(rq, "lens");
               j["diagram"] = diagramSvg(lens, s.film_diagonal_mm, 11, false);
               j["plots"] = json::object();
               for (size_t i = 0; i < plots.size(); ++i)
                 j["plots"][plotKinds()[i].name] = plots[i].get();
               sendJson(res, j);
             }));
  }

  /// Scene previews, streamed as server-sent events: /api/preview, /api/cancel.
  void previewRoutes() {
    http.Get("/api/preview", guard([this](const httplib::Request& rq, httplib::Response& res) {
               const std::string view = param(rq, "view").value_or("default");
               if (view.empty() || view.size() > 32 ||
                   !std::all_of(view.begin(), view.end(), [](char c) {
                     return std::isalnum(uint8_t(c)) || c == '-' || c == '_';
                   }))
                 throw ApiError{400, "parameter view: 1 to 32 letters, digits, '-' or '_'"};
               // A new preview of a view cancels the view's old one at once, before anything else.
               auto ticket = views.start(view);
               try {
                 if (views.running() > config.max_previews)
                   throw ApiError{503, fmt::format("{} previews are rendering; try again",
                                                   config.max_previews)};
                 startPreview(rq, res, view, ticket);
               } catch (...) {
                 views.finish(view, ticket);
                 throw;
               }
             }));

    http.Post("/api/cancel", guard([this](const httplib::Request& rq, httplib::Response& res) {
                const std::string view = param(rq, "view").value_or("default");
                sendJson(res, {{"cancelled", views.cancel(view)}});
              }));
  }

  /// JSON messages for unknown paths and uncaught exceptions.
  void errorHandlers() {
    http.set_error_handler([](const httplib::Request& rq, httplib::Response& res) {
      if (res.body.empty())
        sendJson(res,
                 {{"error", fmt::format("{} {}: {}", rq.method, rq.path.substr(0, 200),
                                        res.status == 404 ? "not found" : "refused")}},
                 res.status);
    });
    http.set_exception_handler(
        [](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
          sendJson(res, {{"error", "internal error"}}, 500);
        });
  }

  void routes() {
    refuseForeignHosts();
    assetRoutes();
    catalogueRoutes();
    lensRoutes();
    previewRoutes();
    errorHandlers();
  }
};

Server::Server(ServerConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}
Server::~Server() {
  stop();
}
int Server::port() const {
  return impl_->port;
}
void Server::run() {
  impl_->http.listen_after_bind();
}
void Server::stop() {
  impl_->views.cancelAll();
  impl_->http.stop();
}

}  // namespace lensim::serve
