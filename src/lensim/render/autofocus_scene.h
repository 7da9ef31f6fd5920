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
  double film_distance_mm = 0;  ///< rear vertex to film (group focusing: of the moved lens)
  double focus_distance_m = 0;  ///< from the film; infinity if focused at or beyond infinity
  /// The lens focuses by moving a group (a focus group or floating focus): the film stays and
  /// the search runs over the camera's focus distance (the group positions focusdistance gives).
  bool group_focusing = false;
  /// The moved gaps' thicknesses at the found focus (row, mm) and, for a focus group, its
  /// travel from the infinity position (mm).
  std::vector<std::pair<int, double>> moved_thickness_mm;
  std::optional<double> group_travel_mm;
  std::vector<camera::AfZone> zones;
  std::vector<double> zone_film_distance_mm;  ///< the best film distance of each zone alone
  std::vector<double> zone_focus_distance_m;  ///< group focusing: each zone's focus distance
  int renders = 0;
  double seconds = 0;
};

/// Finds the film distance that makes the zones sharpest (the sum of their sharpness), and the
/// best one of each zone. A lens that focuses by a group (focus group, floating focus) keeps its
/// film and is searched over the focus distance instead, in steps of object vergence, the group
/// placed as `focusdistance` places it. Throws lensim::Error if the camera is not realistic or
/// has no zones.
SceneAutofocusResult autofocusScene(const scene::Scene& scene,
                                    const SceneAutofocusOptions& options);

/// Sets the scene's pbrt-v3/v4 realistic camera to a focus distance from the film (m; infinity
/// allowed), in place of any film distance.
void setFocusDistance(scene::Scene& scene, double focus_distance_m);

/// Sets the scene's realistic camera to a film distance (v1/v2 `filmdistance`, or lensim's
/// `filmdistance` for v3/v4 in place of `focusdistance`).
void setFilmDistance(scene::Scene& scene, double film_distance_mm);

}  // namespace lensim::render
