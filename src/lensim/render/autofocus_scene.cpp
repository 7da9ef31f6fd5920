#include "lensim/render/autofocus_scene.h"

#include <fmt/format.h>

#include <chrono>
#include <functional>
#include <memory>
#include <cmath>
#include <limits>

#include "lensim/camera/realistic.h"
#include "lensim/optics/focus.h"
#include "lensim/render/renderer.h"
#include "lensim/util/error.h"

namespace lensim::render {

void setFilmDistance(scene::Scene& s, double film_distance_mm) {
  if (s.camera.legacy_realistic) {
    s.camera.legacy_realistic->film_distance_mm = film_distance_mm;
  } else if (s.camera.realistic) {
    s.camera.realistic->film_distance_mm = film_distance_mm;
  } else {
    throw Error(s.camera.loc, "autofocus needs a realistic camera");
  }
}

void setFocusDistance(scene::Scene& s, double focus_distance_m) {
  if (!s.camera.realistic) throw Error(s.camera.loc, "autofocus needs a realistic camera");
  s.camera.realistic->film_distance_mm.reset();
  s.camera.realistic->focus_distance_m = focus_distance_m;
  s.camera.realistic->focus_given = true;
}

namespace {

// Grey image of a rendered zone (mean of R, G, B).
camera::ZoneImage grey(const io::Image& im) {
  camera::ZoneImage z;
  z.width = im.width;
  z.height = im.height;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      z.pixels.push_back((im.at(x, y, 0) + im.at(x, y, 1) + im.at(x, y, 2)) / 3);
  return z;
}

}  // namespace

namespace {

// The focused lens of the scene's coaxial realistic camera; refuses a placed one.
const optics::FocusedLens& coaxialLens(const scene::Scene& scene,
                                       const std::unique_ptr<camera::Camera>& probe) {
  const auto* coaxial = dynamic_cast<const camera::RealisticCamera*>(probe.get());
  if (!coaxial)  // camera/realistic_placed.h: no paraxial data to bound the search with
    throw Error(scene.camera.loc,
                "autofocus: not supported for a lens with tilted or decentred surfaces (give "
                "focusdistance: the film moves to the best focus of real rays)");
  return coaxial->lens();
}

// Group focusing: the film stays; the zones are scored at focus distances 1 / w for object
// vergences w from 0 (infinity) to the nearest distance the group reaches (at most the unit
// search's near end), in steps of about the depth of focus (w = s / f^2 for an image shift s).
void autofocusByGroup(const scene::Scene& scene, const optics::FocusedLens& fl, double pitch_mm,
                      double near_m,
                      const std::function<double(const std::vector<camera::AfZone>&)>& score,
                      scene::Scene& work, SceneAutofocusResult& result) {
  if (scene.camera.legacy_realistic)
    throw Error(scene.camera.loc, "autofocus: the lens focuses by moving a group, which the "
                                  "pbrt-v1/v2 camera (film distance only) cannot do; use a "
                                  "pbrt-v3/v4 realistic camera");
  result.group_focusing = true;
  // The nearest distance the group reaches (focusdistance refuses one it cannot).
  bool reached = false;
  for (int k = 0; k < 40 && !reached; ++k, near_m *= 1.25) {
    setFocusDistance(work, near_m);
    try {
      camera::makeRealisticCamera(work);
      reached = true;
    } catch (const Error&) {
    }
  }
  if (!reached)
    throw Error(scene.camera.loc, "autofocus: the focus group reaches no finite distance");
  near_m /= 1.25;
  const double f = fl.paraxial.effective_focal_length_mm;
  camera::AutofocusOptions af;
  af.film_min_mm = 0;
  af.film_max_mm = 1 / near_m;
  af.max_step_mm = fl.paraxial.f_number * 2 * pitch_mm / (f * f) * 1000;
  auto at = [&](double w, const std::vector<camera::AfZone>& zones) {
    setFocusDistance(work, w > 0 ? 1 / w : std::numeric_limits<double>::infinity());
    return score(zones);
  };
  const double w = camera::autofocus([&](double v) { return at(v, result.zones); }, af)
                       .film_distance_mm;
  result.focus_distance_m = w > 0 ? 1 / w : std::numeric_limits<double>::infinity();
  if (result.zones.size() > 1)
    for (const camera::AfZone& z : result.zones) {
      const double wz = camera::autofocus([&](double v) { return at(v, {z}); }, af)
                            .film_distance_mm;
      result.zone_focus_distance_m.push_back(wz > 0 ? 1 / wz
                                                    : std::numeric_limits<double>::infinity());
    }
  // The lens at the found focus, and at rest (infinity) for the group's travel.
  auto lensAt = [&](double d_m) {
    setFocusDistance(work, d_m);
    const auto cam = camera::makeRealisticCamera(work);
    return dynamic_cast<const camera::RealisticCamera&>(*cam).lens().lens->prescription();
  };
  const optics::LensPrescription found = lensAt(result.focus_distance_m);
  const optics::LensPrescription rest = lensAt(std::numeric_limits<double>::infinity());
  setFocusDistance(work, result.focus_distance_m);
  {
    const auto cam = camera::makeRealisticCamera(work);
    result.film_distance_mm =
        dynamic_cast<const camera::RealisticCamera&>(*cam).lens().lens->filmDistance_mm();
  }
  std::vector<int> rows;
  if (found.floating_focus) rows = found.floating_focus->rows;
  for (const auto& [row, rate] : found.focus_group) rows.push_back(row);
  for (int row : rows)
    result.moved_thickness_mm.push_back({row, found.surfaces[size_t(row)].thickness_mm});
  if (!found.focus_group.empty()) {
    const auto& [row, rate] = found.focus_group.front();
    result.group_travel_mm =
        (found.surfaces[size_t(row)].thickness_mm - rest.surfaces[size_t(row)].thickness_mm) /
        rate;
  }
}

}  // namespace

SceneAutofocusResult autofocusScene(const scene::Scene& scene,
                                    const SceneAutofocusOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (scene.camera.type != "realistic")
    throw Error(scene.camera.loc, "autofocus needs a realistic camera");
  SceneAutofocusResult result;
  std::string zones_file = options.zones_file;
  if (zones_file.empty() && scene.camera.legacy_realistic)
    zones_file = scene.camera.legacy_realistic->af_zones_file;
  if (zones_file.empty())
    throw Error(scene.camera.loc,
                "autofocus: no zones (give --zones FILE, or \"string af_zones\" in the camera)");
  result.zones = camera::readAfZones(zones_file);

  // The search range, from the lens: infinity focus to a near distance, in steps of about the
  // depth of focus (f-number x 2 pixels).
  const auto probe = camera::makeRealisticCamera(scene);
  const optics::FocusedLens& fl = coaxialLens(scene, probe);
  const optics::LensSystem& lens = *fl.lens;
  const double near_m = std::max(1.5 * optics::closestFocusDistance_m(lens, fl.paraxial),
                                 10 * fl.paraxial.effective_focal_length_mm / 1000);
  const double diag = scene.camera.legacy_realistic
                          ? scene.camera.legacy_realistic->film_diagonal_mm
                          : scene.film.diagonal_mm;
  const double aspect = double(scene.film.y_resolution) / scene.film.x_resolution;
  const double pitch = diag / std::sqrt(1 + aspect * aspect) / scene.film.x_resolution;

  scene::Scene work = scene;
  RenderOptions ro;
  ro.spp = options.spp;
  ro.seed = options.seed;
  ro.threads = options.threads;
  auto score = [&](const std::vector<camera::AfZone>& zones) {
    double sum = 0;
    for (const camera::AfZone& z : zones) {
      ro.crop = std::array<double, 4>{z.left, z.right, z.top, z.bottom};
      sum += camera::sharpness(grey(render(work, ro).image));
      ++result.renders;
    }
    return sum;
  };
  const optics::LensPrescription& pr = lens.prescription();
  if (!pr.focus_group.empty() || pr.floating_focus) {
    autofocusByGroup(scene, fl, pitch, near_m, score, work, result);
  } else {
    const double s_inf = optics::filmDistanceForFocus(
        lens, fl.paraxial, std::numeric_limits<double>::infinity(), optics::FocusMethod::Thick);
    const double s_near =
        optics::filmDistanceForFocus(lens, fl.paraxial, near_m, optics::FocusMethod::Thick);
    camera::AutofocusOptions af;
    af.film_min_mm = 0.995 * s_inf;
    af.film_max_mm = s_near;
    af.max_step_mm = fl.paraxial.f_number * 2 * pitch;
    auto zoneScore = [&](double film_mm, const std::vector<camera::AfZone>& zones) {
      setFilmDistance(work, film_mm);
      return score(zones);
    };
    const camera::AutofocusResult best =
        camera::autofocus([&](double s) { return zoneScore(s, result.zones); }, af);
    result.film_distance_mm = best.film_distance_mm;
    if (result.zones.size() > 1)
      for (const camera::AfZone& z : result.zones)
        result.zone_film_distance_mm.push_back(
            camera::autofocus([&](double s) { return zoneScore(s, {z}); }, af).film_distance_mm);
    result.focus_distance_m = optics::focusDistanceForFilm(
        lens, fl.paraxial, result.film_distance_mm, optics::FocusMethod::Thick);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace lensim::render
