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
  // Wide open first: the file's stop, its f-number at infinity.
  LensSetup open;
  open.focus_distance_m = std::numeric_limits<double>::infinity();
  FocusedLens wide = focusLens(pr, open);
  SetUpLens out;
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
  return j;
}

std::string diagramSvg(const SetUpLens& s, double film_diagonal_mm, int rays, bool from_scene) {
  DiagramOptions opts;
  opts.rays = rays;
  opts.film_diagonal_mm = film_diagonal_mm;
  opts.source = from_scene ? DiagramSource::Scene : DiagramSource::Film;
  return lensDiagramSheet({buildLensDiagram(s.lens, opts)}, false);
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
