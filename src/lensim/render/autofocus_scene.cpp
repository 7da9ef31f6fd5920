#include "lensim/render/autofocus_scene.h"

#include <fmt/format.h>

#include <chrono>
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
  const auto* coaxial = dynamic_cast<const camera::RealisticCamera*>(probe.get());
  if (!coaxial)  // camera/realistic_placed.h: no paraxial data to bound the search with
    throw Error(scene.camera.loc,
                "autofocus: not supported for a lens with tilted or decentred surfaces (give "
                "focusdistance: the film moves to the best focus of real rays)");
  const auto& real = *coaxial;
  const optics::FocusedLens& fl = real.lens();
  const optics::LensSystem& lens = *fl.lens;
  const double s_inf = optics::filmDistanceForFocus(
      lens, fl.paraxial, std::numeric_limits<double>::infinity(), optics::FocusMethod::Thick);
  const double near_m = std::max(1.5 * optics::closestFocusDistance_m(lens, fl.paraxial),
                                 10 * fl.paraxial.effective_focal_length_mm / 1000);
  const double s_near =
      optics::filmDistanceForFocus(lens, fl.paraxial, near_m, optics::FocusMethod::Thick);
  const double diag = scene.camera.legacy_realistic
                          ? scene.camera.legacy_realistic->film_diagonal_mm
                          : scene.film.diagonal_mm;
  const double aspect = double(scene.film.y_resolution) / scene.film.x_resolution;
  const double pitch = diag / std::sqrt(1 + aspect * aspect) / scene.film.x_resolution;
  camera::AutofocusOptions af;
  af.film_min_mm = 0.995 * s_inf;
  af.film_max_mm = s_near;
  af.max_step_mm = fl.paraxial.f_number * 2 * pitch;

  scene::Scene work = scene;
  RenderOptions ro;
  ro.spp = options.spp;
  ro.seed = options.seed;
  ro.threads = options.threads;
  auto zoneScore = [&](double film_mm, const std::vector<camera::AfZone>& zones) {
    setFilmDistance(work, film_mm);
    double sum = 0;
    for (const camera::AfZone& z : zones) {
      ro.crop = std::array<double, 4>{z.left, z.right, z.top, z.bottom};
      sum += camera::sharpness(grey(render(work, ro).image));
      ++result.renders;
    }
    return sum;
  };
  const camera::AutofocusResult best =
      camera::autofocus([&](double s) { return zoneScore(s, result.zones); }, af);
  result.film_distance_mm = best.film_distance_mm;
  if (result.zones.size() > 1)
    for (const camera::AfZone& z : result.zones)
      result.zone_film_distance_mm.push_back(
          camera::autofocus([&](double s) { return zoneScore(s, {z}); }, af).film_distance_mm);
  result.focus_distance_m = optics::focusDistanceForFilm(lens, fl.paraxial, result.film_distance_mm,
                                                         optics::FocusMethod::Thick);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace lensim::render
