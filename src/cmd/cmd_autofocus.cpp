// `lensim autofocus SCENE`: the film distance at which the autofocus zones are sharpest.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "lensim/render/autofocus_scene.h"
#include "lensim/scene/description.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

void registerAutofocusCommand(CLI::App& app, Action& action) {
  struct Options {
    std::string scene;
    render::SceneAutofocusOptions af;
    bool json = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "autofocus", "Find the film distance at which the autofocus zones are sharpest");
  cmd->add_option("scene", opts->scene, "Scene file with a realistic camera")->required();
  cmd->add_option("--zones", opts->af.zones_file,
                  "Zone file (lines 'left right top bottom' in [0,1], y down); default: the "
                  "camera's af_zones");
  cmd->add_option("--spp", opts->af.spp, "Samples per pixel for each zone render (default 8)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--threads,--nthreads", opts->af.threads, "Worker threads (default: all cores)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--json", opts->json, "Print one JSON object");
  cmd->callback([opts, &action] {
    action = [opts]() -> int {
      const scene::Scene s = scene::loadScene(opts->scene);
      logDiagnostics(s.diagnostics);
      const render::SceneAutofocusResult r = render::autofocusScene(s, opts->af);
      const bool inf = std::isinf(r.focus_distance_m);
      if (opts->json) {
        nlohmann::json j{{"film_distance_mm", r.film_distance_mm},
                         {"focus_distance_m",
                          inf ? nlohmann::json(nullptr) : nlohmann::json(r.focus_distance_m)},
                         {"focus_at_infinity", inf},
                         {"group_focusing", r.group_focusing},
                         {"zone_film_distance_mm", r.zone_film_distance_mm},
                         {"renders", r.renders},
                         {"seconds", r.seconds}};
        if (r.group_focusing) {
          nlohmann::json moved = nlohmann::json::object();
          for (const auto& [row, t] : r.moved_thickness_mm) moved[std::to_string(row)] = t;
          j["moved_thickness_mm"] = moved;
          j["group_travel_mm"] =
              r.group_travel_mm ? nlohmann::json(*r.group_travel_mm) : nlohmann::json(nullptr);
          nlohmann::json zones = nlohmann::json::array();
          for (double d : r.zone_focus_distance_m)
            zones.push_back(std::isinf(d) ? nlohmann::json(nullptr) : nlohmann::json(d));
          j["zone_focus_distance_m"] = zones;
        }
        std::cout << j.dump(2) << "\n";
        return 0;
      }
      const std::string at = inf ? std::string("infinity")
                                 : fmt::format("{:.4g} m from the film", r.focus_distance_m);
      if (r.group_focusing) {
        std::string moved;
        for (const auto& [row, t] : r.moved_thickness_mm)
          moved += fmt::format("{}surface {} {:.4f} mm", moved.empty() ? "" : ", ", row, t);
        std::cout << fmt::format(
            "group focusing: in focus at {} ({} zone{}); {}gaps {}; film fixed, {:.4f} mm behind "
            "the rear vertex\n",
            at, r.zones.size(), r.zones.size() == 1 ? "" : "s",
            r.group_travel_mm ? fmt::format("group moved {:.4f} mm; ", *r.group_travel_mm) : "",
            moved, r.film_distance_mm);
      } else {
        std::cout << fmt::format("film distance {:.4f} mm ({} zone{}), in focus at {}\n",
                                 r.film_distance_mm, r.zones.size(),
                                 r.zones.size() == 1 ? "" : "s", at);
      }
      for (size_t k = 0; k < r.zone_film_distance_mm.size(); ++k)
        std::cout << fmt::format("  zone {} ({}): {:.4f} mm\n", k + 1, r.zones[k].loc.str(),
                                 r.zone_film_distance_mm[k]);
      for (size_t k = 0; k < r.zone_focus_distance_m.size(); ++k)
        std::cout << fmt::format("  zone {} ({}): in focus at {:.4g} m\n", k + 1,
                                 r.zones[k].loc.str(), r.zone_focus_distance_m[k]);
      std::cout << fmt::format("{} zone renders in {:.1f} s\n", r.renders, r.seconds);
      return 0;
    };
  });
}

}  // namespace lensim::cmd
