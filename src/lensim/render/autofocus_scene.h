// Autofocus of a scene's realistic camera through the renderer: the zones are rendered at
// candidate film distances (same seed every time) and the sharpest film distance is kept.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lensim/camera/focus_search.h"
#include "lensim/scene/description.h"

namespace lensim::render {

struct SceneAutofocusOptions {
  std::string zones_file;  ///< empty: the camera's `af_zones`
  int spp = 8;             ///< samples per pixel for each zone render
  int threads = 0;
  int seed = 7;
};

struct SceneAutofocusResult {
  double film_distance_mm = 0;
  double focus_distance_m = 0;  ///< from the film; infinity if focused at or beyond infinity
  std::vector<camera::AfZone> zones;
  std::vector<double> zone_film_distance_mm;  ///< the best film distance of each zone alone
  int renders = 0;
  double seconds = 0;
};

/// Finds the film distance that makes the zones sharpest (the sum of their sharpness), and the
/// best one of each zone. Throws lensim::Error if the camera is not realistic or has no zones.
SceneAutofocusResult autofocusScene(const scene::Scene& scene,
                                    const SceneAutofocusOptions& options);

/// Sets the scene's realistic camera to a film distance (v1/v2 `filmdistance`, or lensim's
/// `filmdistance` for v3/v4 in place of `focusdistance`).
void setFilmDistance(scene::Scene& scene, double film_distance_mm);

}  // namespace lensim::render
