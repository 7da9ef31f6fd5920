#include "lensim/serve/lens_view.h"

#include <fmt/format.h>

#include <cmath>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/chromatic.h"
#include "lensim/optics/diagram.h"
#include "lensim/optics/lens_report.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/plots.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"

namespace lensim::serve {

using nlohmann::json;
using namespace lensim::optics;

SetUpLens setUpLens(const LensSettings& st) {
  if (!(st.film_diagonal_mm > 0) || st.film_diagonal_mm > 1000)
    throw Error(fmt::format("film diagonal {} mm: expected 0 to 1000 mm", st.film_diagonal_mm));
  LensPrescription pr = readLensFile(st.path);
  SetUpLens out;
  out.configuration_count = configurationCount(pr);
  out.tilt_shift = st.tilt_shift;
  if (st.configuration && st.zoom_focal_length_mm)
    throw Error("give a configuration or a focal length, not both");
  if (out.configuration_count > 1) {
    out.zoom_min_efl_mm = out.zoom_max_efl_mm = configurationEfl_mm(pr, 1);
    for (int n = 2; n <= out.configuration_count; ++n) {
      const double efl = configurationEfl_mm(pr, n);
      out.zoom_min_efl_mm = std::min(out.zoom_min_efl_mm, efl);
      out.zoom_max_efl_mm = std::max(out.zoom_max_efl_mm, efl);
    }
  }
  if (st.configuration) {
    pr = selectConfiguration(pr, *st.configuration);
    out.configuration = st.configuration;
  } else if (st.zoom_focal_length_mm) {
    out.zoom = zoomToFocalLength(pr, *st.zoom_focal_length_mm);
    pr = out.zoom->prescription;
  }
  // Wide open first: the file's stop, its f-number at infinity.
  LensSetup open;
  open.focus_distance_m = std::numeric_limits<double>::infinity();
  FocusedLens wide = focusLens(pr, open);
  out.max_stop_diameter_mm = wide.paraxial.aperture_stop_diameter_mm;
  out.min_f_number = wide.paraxial.f_number;
  out.stop_diameter_mm = out.max_stop_diameter_mm;
  if (st.aperture_diameter_mm) {
    if (!(*st.aperture_diameter_mm > 0))
      throw Error(fmt::format("aperture {} mm: expected > 0", *st.aperture_diameter_mm));
    out.stop_diameter_mm = std::min(*st.aperture_diameter_mm, out.max_stop_diameter_mm);
  } else if (st.f_number) {
    if (!(*st.f_number > 0)) throw Error(fmt::format("f-number {}: expected > 0", *st.f_number));
    out.stop_diameter_mm = std::min(out.max_stop_diameter_mm,
                                    out.max_stop_diameter_mm * out.min_f_number / *st.f_number);
  }
  LensSetup setup;
  setup.aperture_diameter_mm = out.stop_diameter_mm;
  setup.focus_distance_m = st.focus_distance_m;
  out.lens = focusLens(std::move(pr), setup);
  return out;
}

json firstOrderJson(const SetUpLens& s, double film_diagonal_mm) {
  json j = optics::firstOrderJson(s.lens, film_diagonal_mm);
  // The explorer's own: the stop it set for the requested f-number, and the range.
  j["stop_diameter_mm"] = s.stop_diameter_mm;
  j["max_stop_diameter_mm"] = s.max_stop_diameter_mm;
  j["min_f_number"] = s.min_f_number;
  if (s.configuration_count > 1) {
    json z{{"configurations", s.configuration_count},
           {"min_effective_focal_length_mm", s.zoom_min_efl_mm},
           {"max_effective_focal_length_mm", s.zoom_max_efl_mm}};
    if (s.configuration) z["configuration"] = *s.configuration;
    if (s.zoom) {
      z["requested_focal_length_mm"] = s.zoom->requested_efl_mm;
      z["achieved_effective_focal_length_mm"] = s.zoom->achieved_efl_mm;
      z["configuration_a"] = s.zoom->config_a;
      z["configuration_b"] = s.zoom->config_b;
      z["t"] = s.zoom->t;
    }
    j["zoom"] = z;
  }
  if (s.tilt_shift.any())
    j["tilt_shift"] = optics::tiltShiftJson(s.lens, s.tilt_shift, film_diagonal_mm);
  return j;
}

std::string diagramSvg(const SetUpLens& s, double film_diagonal_mm, int rays, bool from_scene) {
  DiagramOptions opts;
  opts.rays = rays;
  opts.film_diagonal_mm = film_diagonal_mm;
  opts.source = from_scene ? DiagramSource::Scene : DiagramSource::Film;
  // Tilted or shifted: the film in the section through the lens axis, both ends and the middle.
  opts.tilt_shift = s.tilt_shift;
  if (s.tilt_shift.any() && !from_scene) opts.fields = {-1.0, 0.0, 1.0};
  try {
    return lensDiagramSheet({buildLensDiagram(s.lens, opts)}, false);
  } catch (const Error& e) {
    // A section the lens cannot be drawn in (an anamorphic lens tilted about x): the lens as it
    // is on its axis, saying why, so that the numbers and plots of the view still come.
    if (!s.tilt_shift.any()) throw;
    opts.tilt_shift = {};
    opts.fields = DiagramOptions{}.fields;
    LensDiagram d = buildLensDiagram(s.lens, opts);
    d.annotations.push_back("drawn untilted and unshifted: " + e.message());
    return lensDiagramSheet({d}, false);
  }
}

const std::vector<PlotKind>& plotKinds() {
  // The sample counts are lower than `lensim lens plot` uses so that every plot of a classic
  // lens is drawn within the page's 150 ms budget; the curves are the same functions.
  static const std::vector<PlotKind> kinds = {
      {"spot", "Spot diagrams",
       [](const FocusedLens& fl, double diag) {
         return spotSvg(fl, computeSpots(fl, {0, 0.5, 0.7, 1}, diag, 32));
       }},
      {"distortion", "Distortion",
       [](const FocusedLens& fl, double diag) {
         DistortionData d = computeDistortion(fl, diag, 40);
         return distortionSvg(fl, d, !d.angle_deg.empty() && d.angle_deg.back() > 45);
       }},
      {"vignetting", "Relative illumination",
       [](const FocusedLens& fl, double diag) {
         return vignettingSvg(fl, computeVignetting(fl, diag, 16, 36));
       }},
      {"focus", "Focus curve",
       [](const FocusedLens& fl, double) { return focusSvg(fl, computeFocusCurve(fl, 32)); }},
      {"chromatic", "Chromatic focal shift",
       [](const FocusedLens& fl, double) {
         return chromaticFocusSvg(fl, computeChromaticFocus(fl, 400, 700, 16));
       }},
      {"lateral-color", "Lateral colour",
       [](const FocusedLens& fl, double diag) {
         return lateralColorSvg(fl, computeLateralColor(fl, diag, 16));
       }},
  };
  return kinds;
}

const PlotKind* findPlotKind(const std::string& name) {
  for (const PlotKind& k : plotKinds())
    if (k.name == name) return &k;
  return nullptr;
}

}  // namespace lensim::serve
