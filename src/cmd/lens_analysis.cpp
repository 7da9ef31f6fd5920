#include "lens_analysis.h"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cmath>

#include "lensim/optics/fans.h"
#include "lensim/optics/field_curves.h"
#include "lensim/optics/mtf.h"
#include "lensim/optics/psf.h"

namespace lensim::cmd {

using namespace lensim::optics;
using nlohmann::json;

namespace {

json finite(const std::vector<double>& v) {
  json arr = json::array();
  for (double x : v) arr.push_back(std::isfinite(x) ? json(x) : json(nullptr));
  return arr;
}

json wavelengthsJson(const std::vector<WeightedWavelength>& wl) {
  json arr = json::array();
  for (const WeightedWavelength& w : wl) arr.push_back({{"nm", w.nm}, {"weight", w.weight}});
  return arr;
}

json fieldHead(const MtfField& f) {
  return {{"field_fraction", f.field_fraction},
          {"film_height_mm", f.film_height_mm},
          {"field_angle_deg", f.field_angle_deg}};
}

}  // namespace

bool isAnalysisKind(const std::string& kind) {
  return kind == "mtf" || kind == "mtf-focus" || kind == "fans" || kind == "field" || kind == "psf";
}

void addAnalysisOptions(CLI::App* cmd, AnalysisArgs& a) {
  cmd->add_option(
      "--wavelengths", a.wavelengths,
      "mtf, mtf-focus, fans, field, psf: wavelengths in nm with optional weights, "
      "e.g. 486.13:1,587.56:2,656.27:1 (default: --wavelength, else the lens's primary); "
      "spot: one spot per wavelength in its colour");
  cmd->add_option("--max-frequency", a.max_frequency,
                  "mtf: highest spatial frequency, cycles/mm (default: the diffraction cutoff)");
  cmd->add_option(
      "--frequency", a.frequency,
      "mtf-focus: spatial frequency, cycles/mm (default 50, or a quarter of the cutoff if lower)");
  cmd->add_option("--focus-range", a.focus_range_mm,
                  "mtf-focus: half-width of the film shift, mm (default 12 lambda N^2)");
  cmd->add_option("--pupil-cells", a.pupil_cells,
                  "mtf, mtf-focus, psf: pupil samples across (default: 64, doubled up to 512 "
                  "until the wavefront is not aliased)");
  cmd->add_flag("--geometric", a.geometric_only, "mtf: the geometric MTF only (fast)");
}

void runAnalysis(const std::string& kind, const FocusedLens& fl, double diag,
                 const std::vector<double>& fields, const AnalysisArgs& a, std::string& svg,
                 json& j) {
  if (a.max_frequency < 0 || a.frequency < 0 || a.focus_range_mm < 0)
    throw Error("--max-frequency, --frequency and --focus-range must be >= 0");
  if (a.pupil_cells != 0 && (a.pupil_cells < 8 || a.pupil_cells > 1024))
    throw Error(
        fmt::format("--pupil-cells {}: expected 8 to 1024 (or 0: automatic)", a.pupil_cells));
  for (double f : fields)
    if (!(f >= 0 && f <= 1.5))
      throw Error(
          fmt::format("--fields: {} is not a fraction of the half-diagonal in [0, 1.5]", f));
  const SpectralLens sl = a.wavelengths.empty()
                              ? spectral(fl, {{fl.lens->wavelength_nm(), 1}})
                              : spectral(fl, parseWavelengths(a.wavelengths, "--wavelengths"));
  auto need = [&](bool any) {
    if (!any)
      throw Error(fmt::format(
          "lens plot {}: no field of --fields lies inside the image circle (no ray gets through)",
          kind));
  };
  j["wavelengths"] = wavelengthsJson(sl.wavelengths);
  if (kind == "mtf") {
    MtfOptions o;
    o.fields = fields;
    o.max_frequency = a.max_frequency;
    o.pupil_cells = a.pupil_cells;
    o.diffraction = !a.geometric_only;
    const MtfData d = computeMtf(sl, diag, o);
    need(!d.fields.empty());
    svg = mtfSvg(fl, d);
    j["frequency_cycles_per_mm"] = d.frequency;
    j["diffraction_limit"] = d.diffraction_limit;
    j["image_space_na"] = d.image_space_na;
    j["working_f_number"] = d.working_f_number;
    j["cutoff_cycles_per_mm"] = d.cutoff;
    json arr = json::array();
    for (const MtfField& f : d.fields) {
      json x = fieldHead(f);
      if (o.diffraction) {
        x["diffraction_tangential"] = f.diffraction_tangential;
        x["diffraction_sagittal"] = f.diffraction_sagittal;
        x["strehl"] = f.strehl;
        x["rms_wavefront_waves"] = f.rms_opd_waves;
        x["pupil_cells"] = f.pupil_cells;
      }
      x["geometric_tangential"] = f.geometric_tangential;
      x["geometric_sagittal"] = f.geometric_sagittal;
      x["rays_traced"] = f.rays;
      arr.push_back(x);
    }
    j["fields"] = arr;
  } else if (kind == "mtf-focus") {
    double nu = a.frequency;
    if (!(nu > 0)) {
      MtfOptions o;
      o.fields = {};
      nu = std::min(50.0, std::round(computeMtf(sl, diag, o).cutoff / 4));
    }
    const ThroughFocusData d =
        computeThroughFocusMtf(sl, diag, fields, nu, a.focus_range_mm, 31, a.pupil_cells);
    need(!d.fields.empty());
    svg = throughFocusSvg(fl, d);
    j["frequency_cycles_per_mm"] = d.frequency;
    j["defocus_mm"] = d.defocus_mm;
    json arr = json::array();
    for (const MtfField& f : d.fields) {
      json x = fieldHead(f);
      x["tangential"] = f.diffraction_tangential;
      x["sagittal"] = f.diffraction_sagittal;
      x["pupil_cells"] = f.pupil_cells;
      x["rays_traced"] = f.rays;
      arr.push_back(x);
    }
    j["fields"] = arr;
  } else if (kind == "fans") {
    const std::vector<FanField> fans = computeRayFans(sl, diag, fields);
    need(!fans.empty());
    svg = rayFanSvg(fl, fans, sl.wavelengths);
    json arr = json::array();
    for (const FanField& f : fans) {
      json x{{"field_fraction", f.field_fraction},
             {"film_height_mm", f.film_height_mm},
             {"field_angle_deg", f.field_angle_deg}};
      json per = json::array();
      for (const RayFan& r : f.fans)
        per.push_back({{"wavelength_nm", r.wavelength_nm},
                       {"tangential_pupil", r.tangential_pupil},
                       {"tangential_ex_mm", r.tangential_ex_mm},
                       {"sagittal_pupil", r.sagittal_pupil},
                       {"sagittal_ey_mm", r.sagittal_ey_mm},
                       {"sagittal_ex_mm", r.sagittal_ex_mm}});
      x["fans"] = per;
      arr.push_back(x);
    }
    j["fields"] = arr;
  } else if (kind == "field") {
    const FieldCurves c = computeFieldCurves(sl, diag);
    svg = fieldCurvesSvg(fl, c);
    j["film_height_mm"] = c.film_height_mm;
    j["field_angle_deg"] = c.field_angle_deg;
    json t = json::array(), s = json::array();
    for (size_t w = 0; w < c.wavelengths.size(); ++w) {
      t.push_back(finite(c.tangential_mm[w]));
      s.push_back(finite(c.sagittal_mm[w]));
    }
    j["tangential_focus_mm"] = t;
    j["sagittal_focus_mm"] = s;
    j["distortion_angle_deg"] = c.distortion.angle_deg;
    j["distortion_percent_tan"] = finite(c.distortion.percent_tan);
  } else {  // psf
    const std::vector<PsfField> psfs = computePsf(sl, diag, fields, 0, 80, a.pupil_cells);
    need(!psfs.empty());
    svg = psfSvg(fl, psfs, sl.wavelengths);
    json arr = json::array();
    for (const PsfField& p : psfs)
      arr.push_back({{"field_fraction", p.field_fraction},
                     {"film_height_mm", p.film_height_mm},
                     {"field_angle_deg", p.field_angle_deg},
                     {"image_point_mm", {p.image_point_mm.x, p.image_point_mm.y}},
                     {"centroid_offset_mm", {p.centroid_mm.x, p.centroid_mm.y}},
                     {"strehl", p.strehl},
                     {"airy_radius_mm", p.airy_radius_mm},
                     {"pixels", p.pixels},
                     {"pixel_mm", p.pixel_mm},
                     {"pupil_cells", p.pupil_cells}});
    j["fields"] = arr;
  }
}

}  // namespace lensim::cmd
