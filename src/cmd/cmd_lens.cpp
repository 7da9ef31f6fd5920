// `lensim lens info|trace`: first-order data, focus and single exact rays from a prescription.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <CLI/CLI.hpp>
#include <array>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "commands.h"
#include "flare_report.h"
#include "lens_analysis.h"
#include "lens_info_unfocused.h"
#include "lens_info_placed.h"
#include "lens_options.h"
#include "lens_tilt.h"
#include "lensim/optics/absorption.h"
#include "lensim/optics/anamorphic.h"
#include "lensim/optics/chief_ray.h"
#include "lensim/optics/chromatic.h"
#include "lensim/optics/configurations.h"
#include "lensim/optics/diagram.h"
#include "lensim/optics/file_fields.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_report.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/plots.h"
#include "lensim/util/file.h"
#include "lensim/util/log.h"
#include "lensim/util/plot.h"
#include "lensim/util/svg.h"

namespace lensim::cmd {

using namespace lensim::optics;
using nlohmann::json;

namespace {

json vec3Json(const Vec3& v) {
  return json::array({v.x, v.y, v.z});
}

json numberOrNull(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

// The lens's internal transmittance on the axis (optics/absorption.h) at these wavelengths.
constexpr std::array<double, 3> kTransmittanceWavelengths_nm{400, 550, 700};

std::vector<std::string> elementsWithoutTransmittance(const LensAbsorption& a) {
  std::vector<std::string> names;
  for (int i : a.mediaWithoutData()) names.push_back(fmt::format("{}-{}", i, i + 1));
  return names;
}

json transmittanceJson(const LensSystem& lens) {
  const LensAbsorption a(lens);
  json on_axis = json::array();
  for (double l : kTransmittanceWavelengths_nm) on_axis.push_back(a.axial(l));
  return {{"wavelengths_nm", kTransmittanceWavelengths_nm},
          {"on_axis", on_axis},
          {"has_data", a.any()},
          {"elements_without_data", elementsWithoutTransmittance(a)}};
}

std::string transmittanceText(const LensSystem& lens) {
  const LensAbsorption a(lens);
  const std::vector<std::string> missing = elementsWithoutTransmittance(a);
  if (!a.any())
    return missing.empty() ? "no glass elements"
                           : "1 (no glass has internal transmittance data; taken as 1)";
  std::string s = "on axis";
  for (double l : kTransmittanceWavelengths_nm)
    s += fmt::format("{} {:.4f} at {:.0f} nm", l == kTransmittanceWavelengths_nm[0] ? "" : ",",
                     a.axial(l), l);
  s += " (internal, the catalogues' IT data)";
  if (!missing.empty())
    s += fmt::format("; element{} {} without data taken as 1", missing.size() == 1 ? "" : "s",
                     fmt::join(missing, ", "));
  return s;
}

// The largest of the file's design fields (Zemax FTYP/XFLN/YFLN, per configuration XFIE/YFIE)
// and its paraxial image height; unset when the file lists none.
std::optional<FileFieldSummary> fileField(const FocusedLens& fl) {
  const LensPrescription& pr = fl.lens->prescription();
  if (!pr.fields || pr.fields->xy.empty()) return std::nullopt;
  return largestFileField(*pr.fields, fl.paraxial, pr.object_distance_mm);
}

json fileFieldJson(const std::optional<FileFieldSummary>& f) {
  if (!f) return nullptr;
  return {{"kind", f->kind},
          {"unit", f->unit},
          {"field", f->field},
          {"value", f->value},
          {"paraxial_image_height_mm", f->paraxial_image_height_mm
                                           ? json(*f->paraxial_image_height_mm)
                                           : json(nullptr)}};
}

std::string fileFieldText(const FileFieldSummary& f) {
  return fmt::format("{:.4f} {} ({} {}){}", f.value, f.unit, f.kind, f.field,
                     f.paraxial_image_height_mm
                         ? fmt::format(", paraxial image height {:.4f} mm",
                                       *f.paraxial_image_height_mm)
                         : std::string());
}

// `lens info --configs`: first-order data of every configuration, each set up (focus, film)
// as the other options say.
int runConfigs(const LensArgs& args, bool as_json) {
  if (args.configuration || args.zoom_focal_length_mm)
    throw Error("--configs lists every configuration; it takes neither --config nor --focal-length");
  applyGlassOptions(args);
  const LensPrescription file = readLensFile(args.lens_path);
  if (file.noncoaxial_loc)  // refused before anything is printed
    throw Error(*file.noncoaxial_loc,
                fmt::format("{}: --configs lists first-order data, which a lens with tilted or "
                            "decentred surfaces does not have",
                            file.noncoaxial_reason));
  const int count = configurationCount(file);
  bool any_fields = file.fields.has_value();
  for (const LensConfiguration& c : file.configurations) any_fields = any_fields || c.fields;
  json arr = json::array();
  if (!as_json)
    std::cout << fmt::format("{:>6} {:>12} {:>9} {:>11} {:>11} {:>13}{}\n", "config", "EFL mm",
                             "f-number", "BFL mm", "field deg", "track mm",
                             any_fields ? "  file's largest field" : "");
  for (int n = 1; n <= count; ++n) {
    LensArgs one = args;
    one.configuration = n;
    std::optional<FocusedLens> set_up;
    try {
      set_up.emplace(setUpLens(one));
    } catch (const LensSetupError& e) {
      // A configuration that cannot be focused (afocal, no real ray through, film inside the
      // lens) is listed with its reason, as `lens info --config N` shows it; a focus or film
      // distance the user gave that cannot be honoured stays an error.
      if (!args.focus_distance.empty() || args.film_distance_mm) throw;
      logDiagnostic({Severity::Warning, e.loc().valid() ? e.loc() : FileLoc{args.lens_path},
                     fmt::format("configuration {}: {}", n, e.message())});
      arr.push_back({{"configuration", n}, {"focused", false}, {"not_focused_reason", e.message()}});
      if (!as_json) std::cout << fmt::format("{:>6}   not focused: {}\n", n, e.message());
      continue;
    }
    const FocusedLens& fl = *set_up;
    const ParaxialData& p = fl.paraxial;
    const FieldOfView fov = fieldOfView(*fl.lens, p, args.film_diagonal_mm);
    const double field = fov.real_deg ? *fov.real_deg : fov.paraxial_deg;
    arr.push_back({{"configuration", n},
                   {"focused", true},
                   {"effective_focal_length_mm", p.effective_focal_length_mm},
                   {"f_number", p.f_number},
                   {"back_focal_length_mm", p.back_focal_length_mm},
                   {"field_of_view_deg", field},
                   {"field_of_view_is_real", fov.real_deg.has_value()},
                   {"total_track_mm", totalTrack(*fl.lens)}});
    const std::optional<FileFieldSummary> file_field = fileField(fl);
    if (file_field) arr.back()["file_field"] = fileFieldJson(file_field);
    if (!as_json)
      std::cout << fmt::format("{:>6} {:>12.4f} {:>9.3f} {:>11.4f} {:>11.3f}{} {:>12.4f}{}\n", n,
                               p.effective_focal_length_mm, p.f_number, p.back_focal_length_mm,
                               field, fov.real_deg ? " " : "p", totalTrack(*fl.lens),
                               file_field ? "  " + fileFieldText(*file_field) : "");
  }
  if (as_json)
    std::cout << json{{"lens", args.lens_path}, {"film_diagonal_mm", args.film_diagonal_mm},
                      {"configurations", arr}}
                     .dump(2)
              << "\n";
  else
    std::cout << fmt::format("field: real chief ray to the corner of a {:.2f} mm diagonal (p: "
                             "paraxial, the corner sees nothing); track: front vertex to film\n",
                             args.film_diagonal_mm);
  return 0;
}

// Where the film focuses, beyond what the first-order keys say: the film in front of the
// infinity focus (if it is), the object vergence and the magnification.
struct InfoFocus {
  std::optional<double> beyond_infinity_mm;
  double vergence_dpt = 0;
  std::optional<double> magnification;
};

InfoFocus infoFocus(const LensArgs& args, const FocusedLens& fl) {
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  const bool at_inf = std::isinf(fl.focus_distance_m);
  std::optional<double> object_z;
  if (!at_inf) object_z = lens.filmZ_mm() - fl.focus_distance_m * 1000;
  InfoFocus f;
  // Where the film sits relative to the infinity focus (same method): a film in front of it
  // focuses "beyond infinity" (no real object is sharp), which `focus infinity` would hide.
  if (at_inf) {
    try {
      const double inf_film = filmDistanceForFocus(lens, p, fl.focus_distance_m, args.focus_method);
      const double offset = lens.filmDistance_mm() - inf_film;
      if (offset < -1e-6 * std::max(1.0, std::abs(p.effective_focal_length_mm)))
        f.beyond_infinity_mm = -offset;
    } catch (const Error&) {
      // no infinity focus behind the rear vertex: nothing to compare with
    }
  }
  // 1/s_o (dioptres) of the film's conjugate, thick-lens model: 0 at infinity, negative beyond
  // it (the film is focused for a beam converging toward a point behind the lens).
  const double s_i = lens.filmZ_mm() - p.principal_plane_back_z_mm;
  f.vergence_dpt = 1000 * (1 / p.effective_focal_length_mm - 1 / s_i);
  // Paraxial lateral magnification at the focused distance (object and image in air): -s_i/s_o
  // from the principal planes.
  if (object_z) f.magnification = -s_i / (p.principal_plane_front_z_mm - *object_z);
  return f;
}

// `lens info --json` of a focused lens.
void printInfoJson(const LensArgs& args, const FocusedLens& fl, const TiltShift& tilt_shift,
                   const InfoFocus& focus) {
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  const auto& pr = lens.prescription();
  const bool at_inf = std::isinf(fl.focus_distance_m);
  const FieldOfView fov = fieldOfView(lens, p, args.film_diagonal_mm);
  const std::optional<double>& beyond_infinity_mm = focus.beyond_infinity_mm;
  const std::optional<double>& magnification = focus.magnification;
  const double vergence_dpt = focus.vergence_dpt;
  json j = firstOrderJson(fl, args.film_diagonal_mm);
  j["lens"]["path"] = pr.path;
  j["lens"]["format"] = pr.format;
  if (!pr.aperture_spec.empty()) j["lens"]["aperture_spec"] = pr.aperture_spec;
  if (pr.object_distance_mm) j["lens"]["object_distance_mm"] = *pr.object_distance_mm;
  j["lens"]["configurations"] = configurationCount(readLensFile(args.lens_path));
  if (args.configuration) j["lens"]["configuration"] = *args.configuration;
  j["front_focal_point_z_mm"] = p.front_focal_point_z_mm;
  j["back_focal_point_z_mm"] = p.back_focal_point_z_mm;
  j["principal_plane_front_z_mm"] = p.principal_plane_front_z_mm;
  j["principal_plane_back_z_mm"] = p.principal_plane_back_z_mm;
  j["nodal_point_front_z_mm"] = p.nodal_point_front_z_mm;
  j["nodal_point_back_z_mm"] = p.nodal_point_back_z_mm;
  j["aperture_stop_is_file_stop"] = p.stop_is_file_stop;
  j["paraxial_limit_surface"] = p.paraxial_limit_surface;
  j["paraxial_limit_f_number"] = p.paraxial_limit_f_number;
  j["paraxial_f_number"] = p.f_number;
  j["real_f_number"] = p.real_f_number;
  j["real_image_space_f_number"] = p.real_image_space_f_number;
  j["real_marginal_ray_height_mm"] = p.real_marginal_height_mm;
  j["real_limit_surface"] = p.real_limit_surface;
  if (lens.mirrorCount() > 0) j["mirrors"] = lens.mirrorCount();
  j["focus_at_infinity"] = at_inf && !beyond_infinity_mm;
  j["focus_beyond_infinity"] = beyond_infinity_mm.has_value();
  j["film_in_front_of_infinity_focus_mm"] =
      beyond_infinity_mm ? json(*beyond_infinity_mm) : json(nullptr);
  j["object_vergence_dpt"] = vergence_dpt;
  j["magnification"] = magnification ? json(*magnification) : json(nullptr);
  if (!pr.focus_group.empty() || pr.floating_focus) j["group_focusing"] = true;
  if (pr.floating_focus) j["floating_focus"] = true;
  j["focus_method"] = focusMethodName(args.focus_method);
  if (fov.image_circle_diameter_mm) j["field_of_view_max_deg"] = *fov.real_max_deg;
  if (!isRotationallySymmetric(pr)) {
    const AnamorphicData ad = anamorphicData(lens);
    j["anamorphic"] = {
        {"effective_focal_length_x_mm",
         ad.x ? json(ad.x->effective_focal_length_mm) : json(nullptr)},
        {"effective_focal_length_y_mm",
         ad.y ? json(ad.y->effective_focal_length_mm) : json(nullptr)},
        {"back_focal_length_x_mm", ad.x ? json(ad.x->back_focal_length_mm) : json(nullptr)},
        {"back_focal_length_y_mm", ad.y ? json(ad.y->back_focal_length_mm) : json(nullptr)},
        {"squeeze", ad.squeeze}};
  }
  j["surfaces"] = surfacesJson(lens);
  j["wavelength_nm"] = lens.wavelength_nm();
  j["primary_wavelength_nm"] = primaryWavelength_nm(pr);
  j["dispersive"] = lens.dispersive();
  j["elements"] = elementsJson(lens);
  j["internal_transmittance"] = transmittanceJson(lens);
  j["coatings"] = coatingsJson(lens);
  if (tilt_shift.any())
    j["tilt_shift"] = optics::tiltShiftJson(fl, tilt_shift, args.film_diagonal_mm);
  if (const auto f = fileField(fl)) j["file_field"] = fileFieldJson(f);
  std::cout << j.dump(2) << "\n";
}

int runInfo(const LensArgs& args, bool as_json) {
  const TiltShift tilt_shift = parseTiltShift(args.tilt, args.shift);
  if (const auto status = runInfoIfNonCoaxial(args, tilt_shift.any(), as_json)) return *status;
  std::optional<FocusedLens> set_up;
  try {
    set_up.emplace(setUpLens(args));
  } catch (const LensSetupError& e) {
    // The lens was read but cannot be focused: shown, unless the focus or film distance the
    // user gave is what cannot be honoured (a refusal naming it).
    if (!args.focus_distance.empty() || args.film_distance_mm) throw;
    return runInfoUnfocused(args, as_json, e);
  }
  FocusedLens& fl = *set_up;
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  logDiagnostics(fl.allDiagnostics());

  const bool at_inf = std::isinf(fl.focus_distance_m);
  std::optional<double> object_z;
  if (!at_inf) object_z = lens.filmZ_mm() - fl.focus_distance_m * 1000;
  const double working_f = workingFNumber(lens, p, object_z);
  const FieldOfView fov = fieldOfView(lens, p, args.film_diagonal_mm);
  const double closest = closestFocusDistance_m(lens, p);
  const auto& pr = lens.prescription();
  const InfoFocus focus = infoFocus(args, fl);
  const std::optional<double>& beyond_infinity_mm = focus.beyond_infinity_mm;
  const std::optional<double>& magnification = focus.magnification;
  const double vergence_dpt = focus.vergence_dpt;

  if (as_json) {
    printInfoJson(args, fl, tilt_shift, focus);
    return 0;
  }

  auto line = [](const std::string& k, const std::string& v) {
    std::cout << fmt::format("  {:<26}{}\n", k, v);
  };
  std::cout << fmt::format("{}\n", pr.name);
  if (pr.format == "dat")
    line("file", fmt::format("{} ({} layout, {} surfaces)", pr.path, layoutName(pr.layout),
                             lens.surfaceCount()));
  else
    line("file", fmt::format("{} ({}, {} surfaces{})", pr.path, pr.format, lens.surfaceCount(),
                             pr.aperture_spec.empty() ? "" : ", aperture " + pr.aperture_spec));
  if (const int count = configurationCount(readLensFile(args.lens_path)); count > 1)
    line("configurations",
         args.configuration ? fmt::format("{} of {}", *args.configuration, count)
         : args.zoom_focal_length_mm
             ? fmt::format("{}; zoomed to {} mm between two of them (see the log)", count,
                           *args.zoom_focal_length_mm)
             : fmt::format("{} (showing the file's surface data; --config N, --configs for all)",
                           count));
  if (pr.nominal_focal_length_mm)
    line("stated focal length", fmt::format("{:.3f} mm", *pr.nominal_focal_length_mm));
  line("effective focal length", fmt::format("{:.4f} mm", p.effective_focal_length_mm));
  if (!isRotationallySymmetric(pr)) {
    const AnamorphicData ad = anamorphicData(lens);
    line("anamorphic (x / y)",
         fmt::format("EFL_x {} mm, EFL_y {:.4f} mm, squeeze {:.4f}; BFL_x {} mm (the other data "
                     "below are the y-z section's)",
                     ad.x ? fmt::format("{:.4f}", ad.x->effective_focal_length_mm) : "afocal",
                     p.effective_focal_length_mm, ad.squeeze,
                     ad.x ? fmt::format("{:.4f}", ad.x->back_focal_length_mm) : "-"));
  }
  line("back focal length", fmt::format("{:.4f} mm (rear focal point z = {:.4f})",
                                        p.back_focal_length_mm, p.back_focal_point_z_mm));
  line("front focal length", fmt::format("{:.4f} mm (front focal point z = {:.4f})",
                                         p.front_focal_length_mm, p.front_focal_point_z_mm));
  line("principal planes z",
       fmt::format("front {:.4f}, back {:.4f} mm", p.principal_plane_front_z_mm,
                   p.principal_plane_back_z_mm));
  line("nodal points z", fmt::format("front {:.4f}, back {:.4f} mm", p.nodal_point_front_z_mm,
                                     p.nodal_point_back_z_mm));
  line("aperture stop",
       fmt::format("surface {} (line {}), diameter {:.3f} mm{}", p.aperture_stop_surface,
                   pr.surfaces[p.aperture_stop_surface].loc.line, p.aperture_stop_diameter_mm,
                   p.stop_is_file_stop ? ""
                   : lens.stopIndex()
                       ? fmt::format(" (the stop row at line {} does not limit the beam; this "
                                     "element does)",
                                     pr.surfaces[*lens.stopIndex()].loc.line)
                       : std::string(" (the file has no stop: this element limits the beam)")));
  const double real_f = p.real_f_number;
  if (p.real_limit_surface != p.aperture_stop_surface && p.stop_is_file_stop)
    line("real axial limit",
         fmt::format("surface {} (line {}) clips the real axial beam more than the stop: f/{:.3f}",
                     p.real_limit_surface, pr.surfaces[p.real_limit_surface].loc.line, real_f));
  line("entrance pupil", fmt::format("diameter {:.4f} mm at z = {:.4f} mm",
                                     p.entrance_pupil_diameter_mm, p.entrance_pupil_z_mm));
  line("exit pupil", fmt::format("diameter {:.4f} mm at z = {:.4f} mm", p.exit_pupil_diameter_mm,
                                 p.exit_pupil_z_mm));
  line("f-number", fmt::format("f/{:.3f} paraxial (infinity), working f/{:.3f} at this focus",
                               p.f_number, working_f));
  line("real f-number",
       fmt::format("f/{:.3f} (marginal ray from infinity at {:.4f} mm, stopped by surface {} "
                   "line {}; 1/(2 sin u') f/{:.3f})",
                   real_f, p.real_marginal_height_mm, p.real_limit_surface,
                   pr.surfaces[p.real_limit_surface].loc.line, p.real_image_space_f_number));
  const std::string focus_text =
      beyond_infinity_mm
          ? fmt::format(
                "beyond infinity: the film is {:.4f} mm in front of the infinity focus "
                "(object conjugate 1/s = {:.4f} dioptres; no real object is sharp)",
                *beyond_infinity_mm, vergence_dpt)
      : at_inf ? std::string("infinity")
               : fmt::format("{:.6g} m from the film", fl.focus_distance_m);
  line("focus", fmt::format("{} ({} method); closest {:.4f} m", focus_text,
                            focusMethodName(args.focus_method), closest));
  if (magnification)
    line("magnification", fmt::format("{:.6f} (paraxial, at the focused distance){}",
                                      *magnification,
                                      pr.floating_focus ? "; floating focus"
                                      : pr.focus_group.empty() ? ""
                                                               : "; focused by the focus group"));
  line("film distance",
       fmt::format("{:.4f} mm {} the rear vertex", lens.filmDistance_mm(),
                   lens.imageSpaceReversed() ? "in front of (image space reversed by the mirrors)"
                                             : "behind"));
  line("wavelength",
       fmt::format("{:.2f} nm{} (focus solved at the primary wavelength, {:.2f} nm){}",
                   lens.wavelength_nm(),
                   lens.wavelength_nm() == primaryWavelength_nm(pr) ? " (primary)" : "",
                   primaryWavelength_nm(pr), lens.dispersive() ? "" : "; no element disperses"));
  line("glass transmittance", transmittanceText(lens));
  line("lens length / total track",
       fmt::format("{:.4f} mm / {:.4f} mm{}", lensLength(lens), totalTrack(lens),
                   lens.mirrorCount() > 0 ? " (folded: the axial extent of the surfaces / of "
                                            "the surfaces and the film)"
                                          : ""));
  if (fov.real_deg)
    line("field of view", fmt::format("{:.3f} deg on a {:.2f} mm diagonal (paraxial {:.3f} deg)",
                                      *fov.real_deg, args.film_diagonal_mm, fov.paraxial_deg));
  else
    line("field of view",
         fmt::format("image circle {:.3f} mm is smaller than the {:.2f} mm diagonal; {:.3f} deg "
                     "across it (paraxial {:.3f} deg)",
                     *fov.image_circle_diameter_mm, args.film_diagonal_mm, *fov.real_max_deg,
                     fov.paraxial_deg));
  if (const auto f = fileField(fl)) line("file's largest field", fileFieldText(*f));
  if (tilt_shift.any()) printTiltShift(fl, tilt_shift, args.film_diagonal_mm);
  printCoatings(lens);
  printSurfaceTables(lens);
  return 0;
}

int runConvert(const std::string& in, const std::string& out) {
  const LensPrescription p = readLensFile(in);
  logDiagnostics(p.diagnostics);
  std::string ext = std::filesystem::path(out).extension().string();
  std::string text;
  if (ext == ".json")
    text = writeLensJson(p);
  else if (ext == ".dat")
    text = writeLensDat(p);
  else if (ext == ".zmx")
    text = writeLensZmx(p);
  else
    throw Error(
        fmt::format("cannot write '{}': lensim writes lenses as .json (any coaxial lens), .dat "
                    "(spherical lenses) or .zmx",
                    out));
  writeFileAtomically(out, text);
  logInfo(fmt::format("wrote {} ({} surfaces)", out, p.surfaces.size()));
  return 0;
}

int runTrace(const LensArgs& args, const std::string& film_s, const std::string& rear_s,
             bool as_json) {
  FocusedLens fl = setUpLens(args);
  logDiagnostics(fl.allDiagnostics());
  const Vec2 film = parsePair(film_s, "--film");
  const Vec2 rear = parsePair(rear_s, "--rear");
  std::vector<Vec3> path;
  TraceResult r = fl.lens->traceFromFilmPoint(film, rear, {}, &path);
  if (as_json) {
    json j{{"film_mm", {film.x, film.y}},
           {"rear_mm", {rear.x, rear.y}},
           {"film_distance_mm", fl.lens->filmDistance_mm()},
           {"wavelength_nm", fl.lens->wavelength_nm()}};
    if (r.ok()) {
      j["origin_mm"] = vec3Json(r.ray.origin);
      j["direction"] = vec3Json(r.ray.direction);
    } else {
      j["blocked_at_surface"] = r.blocked_surface;
      j["reason"] = blockReasonName(r.reason);
    }
    json pts = json::array();
    for (const Vec3& v : path) pts.push_back(vec3Json(v));
    j["path_mm"] = pts;
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  if (r.ok()) {
    std::cout << fmt::format("leaves the front surface at ({:.9f}, {:.9f}, {:.9f}) mm\n",
                             r.ray.origin.x, r.ray.origin.y, r.ray.origin.z);
    std::cout << fmt::format("direction ({:.12f}, {:.12f}, {:.12f})\n", r.ray.direction.x,
                             r.ray.direction.y, r.ray.direction.z);
  } else {
    const auto& row = fl.lens->prescription().surfaces[r.blocked_surface];
    std::cout << fmt::format("blocked at surface {} ({}): {}\n", r.blocked_surface, row.loc.str(),
                             blockReasonName(r.reason));
  }
  return 0;
}

std::vector<double> parseList(const std::string& text, const std::string& option) {
  std::vector<double> out;
  size_t start = 0;
  while (start <= text.size()) {
    size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    const std::string item = text.substr(start, comma - start);
    try {
      size_t used = 0;
      double v = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(v)) throw std::invalid_argument(item);
      out.push_back(v);
    } catch (const std::exception&) {
      throw Error(fmt::format("{} '{}': expected comma-separated numbers", option, text));
    }
    start = comma + 1;
  }
  return out;
}

struct DrawArgs {
  std::vector<std::string> lenses;
  std::string output;
  std::string fields;  ///< empty: 0,0.7,1 (tilted or shifted: -1,0,1)
  int rays = 11;
  std::string from = "film";
  bool same_scale = false;
  std::string wavelengths;  ///< --wavelengths: bundles at each, in their colours
  std::string ghost;        ///< --ghost I,J: the rays of that ghost (cmd_flare.cpp)
};

int runDraw(const LensArgs& common, const DrawArgs& args) {
  if (!args.ghost.empty()) {
    if (!common.tilt.empty() || !common.shift.empty())
      throw Error(fmt::format("--ghost {}: draws the lens untilted and unshifted (no --tilt, "
                              "--shift)",
                              args.ghost));
    if (args.lenses.size() != 1 || !args.wavelengths.empty())
      throw Error(fmt::format(
          "--ghost {}: draws one lens at its primary wavelength (got {} "
          "lenses{})",
          args.ghost, args.lenses.size(), args.wavelengths.empty() ? "" : " and --wavelengths"));
    LensArgs one = common;
    one.lens_path = args.lenses.front();
    return runGhostDraw(one, args.ghost, args.rays, args.output);
  }
  DiagramOptions opts;
  // Tilted or shifted: the film where it crosses the section through the lens axis (fields are
  // signed fractions of that chord's half-length).
  opts.tilt_shift = parseTiltShift(common.tilt, common.shift);
  const bool placed = opts.tilt_shift.any();
  const std::string fields = !args.fields.empty() ? args.fields : placed ? "-1,0,1" : "0,0.7,1";
  opts.fields = parseList(fields, "--fields");
  for (double f : opts.fields)
    if (f < (placed ? -1.5 : 0) || f > 1.5)
      throw Error(fmt::format("--fields {}: each field is a fraction in [{}, 1.5]", fields,
                              placed ? "-1.5" : "0"));
  if (args.rays < 1 || args.rays > 1000)
    throw Error(fmt::format("--rays {}: expected 1 to 1000", args.rays));
  opts.rays = args.rays;
  opts.film_diagonal_mm = common.film_diagonal_mm;
  opts.source = args.from == "scene" ? DiagramSource::Scene : DiagramSource::Film;
  std::vector<LensDiagram> diagrams;
  int columns = 0;
  bool same_scale = args.same_scale;
  for (const std::string& path : args.lenses) {
    LensArgs one = common;
    one.lens_path = path;
    // A zoom lens without --config/--focal-length: every configuration, stacked at one scale.
    if (!one.configuration && !one.zoom_focal_length_mm && args.lenses.size() == 1 &&
        args.wavelengths.empty()) {
      applyGlassOptions(one);
      const int count = configurationCount(readLensFile(path));
      if (count > 1) {
        for (int n = 1; n <= count; ++n) {
          one.configuration = n;
          FocusedLens fc = setUpLens(one);
          LensDiagram d = buildLensDiagram(fc, opts);
          d.annotations.push_back(fmt::format("configuration {} of {}: EFL {:.2f} mm", n, count,
                                              fc.paraxial.effective_focal_length_mm));
          diagrams.push_back(std::move(d));
        }
        columns = 1, same_scale = true;
        continue;
      }
    }
    FocusedLens fl = setUpLens(one);
    logDiagnostics(fl.allDiagnostics());
    if (placed && !isRotationallySymmetric(fl.lens->prescription()))
      throw Error(fmt::format("{}: --tilt/--shift draws rotationally symmetric lenses (the "
                              "explorer draws an anamorphic one tilted about y and shifted "
                              "along x)",
                              path));
    if (args.wavelengths.empty()) {
      if (isRotationallySymmetric(fl.lens->prescription())) {
        diagrams.push_back(buildLensDiagram(fl, opts));
        continue;
      }
      // Anamorphic: the y-z and x-z sections, each as the rotational lens whose meridional rays
      // are the lens's rays in that plane (a biconic's or toroid's section profile), with the
      // same film plane. A section without power (a cylinder's flat one) has no focus to draw
      // bundles to: it is left out, and the note says so.
      for (bool x_section : {false, true}) {
        LensPrescription sec =
            x_section ? xSection(fl.lens->prescription()) : ySection(fl.lens->prescription());
        const LensSystem probe(sec);
        if (std::abs(systemMatrix(probe, 0, probe.surfaceCount() - 1).c) < 1e-12) {
          logInfo(fmt::format("{}: the {} section has no optical power (a cylindrical lens's "
                              "flat section): only the other section is drawn",
                              path, x_section ? "x-z" : "y-z"));
          continue;
        }
        sec.name += x_section ? " (x-z section)" : " (y-z section)";
        LensSetup setup;
        setup.film_distance_mm = fl.lens->filmDistance_mm();
        if (fl.lens->stopDiameter_mm()) setup.aperture_diameter_mm = fl.lens->stopDiameter_mm();
        FocusedLens fs = focusLens(std::move(sec), setup);
        diagrams.push_back(buildLensDiagram(fs, opts));
      }
      continue;
    }
    // One bundle set per wavelength, drawn in its colour, on the lens focused at the primary.
    LensDiagram d = buildLensDiagram(fl, opts);
    d.rays.clear();
    std::string names;
    for (double l : parseList(args.wavelengths, "--wavelengths")) {
      checkWavelength(l, "--wavelengths");
      const FocusedLens at = focusedAtWavelength(fl, l);
      LensDiagram dl = buildLensDiagram(at, opts);
      for (DiagramRay& r : dl.rays) r.color = wavelengthColor(l);
      names += fmt::format("{}{:.1f}", names.empty() ? "" : ", ", l);
      d.rays.insert(d.rays.end(), dl.rays.begin(), dl.rays.end());
    }
    d.annotations.push_back(fmt::format("wavelengths {} nm (in their colours)", names));
    diagrams.push_back(std::move(d));
  }
  writeFileAtomically(args.output, lensDiagramSheet(diagrams, same_scale, columns));
  logInfo(fmt::format("wrote {} ({} lens{})", args.output, diagrams.size(),
                      diagrams.size() == 1 ? "" : "es"));
  return 0;
}

struct PlotArgs {
  std::string kind;
  std::string output;
  std::string fields = "0,0.5,0.7,1";
  bool fields_given = false;
  bool as_json = false;
  AnalysisArgs analysis;  ///< also holds --wavelengths (spot: one spot per wavelength)
  std::optional<double> ghost_angle_deg;  ///< ghosts: the light's angle off axis (--angle)
  bool ghost_image = false;               ///< ghosts --image: the film image (ghost_image.cpp)
  GhostImageArgs image;                   ///< --image's own options
  std::vector<std::string> image_options;  ///< --image's options given (refused without it)
};

json pairsJson(const std::vector<double>& a, const std::vector<double>& b) {
  json arr = json::array();
  for (size_t i = 0; i < a.size(); ++i)
    arr.push_back({a[i], std::isfinite(b[i]) ? json(b[i]) : json(nullptr)});
  return arr;
}

json finiteOrNull(const std::vector<double>& v) {
  json arr = json::array();
  for (double x : v) arr.push_back(std::isfinite(x) ? json(x) : json(nullptr));
  return arr;
}

// `lens plot breathing`: the field of view against the focus distance (log-spaced from the
// closest focus to 100 m) for unit focusing (the whole lens moves) and, when the lens has a
// focus group, group focusing; the film stays the same size.
std::string breathingPlot(const LensArgs& args, json& j) {
  applyGlassOptions(args);
  const LensPrescription p = applyConfigurationArgs(args, readLensFile(args.lens_path));
  LensSetup setup;
  setup.aperture_diameter_mm = args.aperture_diameter_mm;
  setup.focus_method = args.focus_method;
  LensPrescription unit = p;
  unit.focus_group.clear();
  unit.floating_focus.reset();
  const FocusedLens at_inf = focusLens(unit, setup);
  const double closest = closestFocusDistance_m(*at_inf.lens, at_inf.paraxial);
  plot::Chart chart;
  chart.title = fmt::format("Focus breathing: {}", p.name);
  chart.x_label = "focus distance from the film (m)";
  chart.y_label = fmt::format("field of view on a {:.1f} mm diagonal (deg)", args.film_diagonal_mm);
  chart.x_log = true;
  std::vector<std::pair<std::string, const LensPrescription*>> kinds = {{"unit", &unit}};
  if (!p.focus_group.empty() || p.floating_focus) kinds.push_back({"group", &p});
  const double lo = std::max(closest * 1.02, 1e-3), hi = 100;
  for (size_t k = 0; k < kinds.size(); ++k) {
    plot::Series series;
    series.name = kinds[k].first + " focusing";
    series.color = plot::paletteColor(int(k));
    json arr = json::array();
    for (int i = 0; i <= 40; ++i) {
      const double d = lo * std::pow(hi / lo, i / 40.0);
      LensSetup at = setup;
      at.focus_distance_m = d;
      try {
        const FocusedLens fl = focusLens(*kinds[k].second, at);
        const FieldOfView fov = fieldOfView(*fl.lens, fl.paraxial, args.film_diagonal_mm);
        const double deg = fov.real_deg ? *fov.real_deg : fov.paraxial_deg;
        series.points.push_back({d, deg});
        arr.push_back({{"focus_distance_m", d},
                       {"field_of_view_deg", deg},
                       {"effective_focal_length_mm", fl.paraxial.effective_focal_length_mm}});
      } catch (const Error&) {
        // this focusing cannot reach d: no point
      }
    }
    j[kinds[k].first] = arr;
    chart.series.push_back(std::move(series));
  }
  const FieldOfView f_inf = fieldOfView(*at_inf.lens, at_inf.paraxial, args.film_diagonal_mm);
  j["field_of_view_at_infinity_deg"] = f_inf.real_deg ? *f_inf.real_deg : f_inf.paraxial_deg;
  chart.notes.push_back(fmt::format("at infinity: {:.3f} deg", j["field_of_view_at_infinity_deg"]
                                                                  .get<double>()));
  svg::Document doc(640, 440);
  doc.rect(0, 0, 640, 440, {{"fill", "#ffffff"}});
  chart.render(doc, 0, 0, 640, 440);
  return doc.str();
}

int runPlot(const LensArgs& args, const PlotArgs& pa) {
  if (pa.ghost_angle_deg && pa.kind != "ghosts")
    throw Error(fmt::format("--angle applies to 'ghosts', not to '{}'", pa.kind));
  if (!pa.image_options.empty() && !pa.ghost_image)
    throw Error(fmt::format("{} applies to 'ghosts --image' only", pa.image_options.front()));
  if (pa.ghost_image && pa.kind != "ghosts")
    throw Error(fmt::format("--image applies to 'ghosts', not to '{}'", pa.kind));
  if (pa.ghost_image) {  // ghost_image.cpp
    if (!pa.analysis.wavelengths.empty() && pa.analysis.wavelengths.find(':') != std::string::npos)
      throw Error(
          fmt::format("--wavelengths {}: ghosts --image takes plain wavelengths (nm, "
                      "comma-separated), no weights",
                      pa.analysis.wavelengths));
    GhostImageArgs ga = pa.image;
    ga.output = pa.output;
    ga.as_json = pa.as_json;
    ga.angle_deg = pa.ghost_angle_deg.value_or(0.0);
    ga.wavelengths = pa.analysis.wavelengths;
    return runGhostImage(args, ga);
  }
  if (pa.kind == "ghosts")  // cmd_flare.cpp
    return runGhostPlot(args, pa.output, pa.as_json, pa.ghost_angle_deg);
  if (pa.kind == "breathing") {
    json j{{"kind", pa.kind}, {"lens", args.lens_path}};
    const std::string svg_text = breathingPlot(args, j);
    writeFileAtomically(pa.output, svg_text);
    if (pa.as_json) std::cout << j.dump(2) << "\n";
    logInfo(fmt::format("wrote {}", pa.output));
    return 0;
  }
  FocusedLens fl = setUpLens(args);
  logDiagnostics(fl.allDiagnostics());
  std::string svg_text;
  json j{{"kind", pa.kind},
         {"lens", fl.lens->prescription().path},
         {"wavelength_nm", fl.lens->wavelength_nm()}};
  if (!pa.analysis.wavelengths.empty() && pa.kind != "spot" && !isAnalysisKind(pa.kind))
    throw Error(
        fmt::format("--wavelengths applies to spot, mtf, mtf-focus, fans, field and psf (use "
                    "--wavelength for one wavelength), not to '{}'",
                    pa.kind));
  if (pa.kind == "spot" && !pa.analysis.wavelengths.empty()) {
    std::vector<double> ls = parseList(pa.analysis.wavelengths, "--wavelengths");
    for (double l : ls) checkWavelength(l, "--wavelengths");
    auto spots =
        computeSpotsAtWavelengths(fl, parseList(pa.fields, "--fields"), args.film_diagonal_mm, ls);
    svg_text = colorSpotSvg(fl, spots);
    json arr = json::array();
    for (const ColorSpotField& s : spots) {
      json per = json::array();
      for (size_t w = 0; w < s.wavelength_nm.size(); ++w)
        per.push_back(
            {{"wavelength_nm", s.wavelength_nm[w]},
             {"centroid_mm", {numberOrNull(s.centroid_mm[w].x), numberOrNull(s.centroid_mm[w].y)}},
             {"rms_radius_mm", numberOrNull(s.rms_radius_mm[w])},
             {"rays_through", s.points_mm[w].size()}});
      arr.push_back({{"film_height_mm", s.film_height_mm},
                     {"field_angle_deg", s.field_angle_deg},
                     {"wavelengths", per}});
    }
    j["fields"] = arr;
  } else if (pa.kind == "chromatic") {
    ChromaticFocus c = computeChromaticFocus(fl);
    svg_text = chromaticFocusSvg(fl, c);
    j["primary_wavelength_nm"] = c.primary_nm;
    j["wavelength_nm"] = c.wavelength_nm;
    j["paraxial_film_distance_mm"] = c.paraxial_mm;
    j["real_film_distance_mm"] = finiteOrNull(c.real_mm);
    j["paraxial_primary_mm"] = c.paraxial_primary_mm;
    j["paraxial_f_minus_c_mm"] = c.paraxial_F_mm - c.paraxial_C_mm;
    j["real_primary_mm"] = numberOrNull(c.real_primary_mm);
  } else if (pa.kind == "lateral-color") {
    LateralColor c = computeLateralColor(fl, args.film_diagonal_mm);
    svg_text = lateralColorSvg(fl, c);
    j["short_nm"] = c.short_nm;
    j["long_nm"] = c.long_nm;
    j["primary_wavelength_nm"] = c.primary_nm;
    j["field_deg"] = c.field_deg;
    j["height_primary_mm"] = c.height_primary_mm;
    j["short_minus_primary_mm"] = finiteOrNull(c.short_minus_primary_mm);
    j["long_minus_primary_mm"] = finiteOrNull(c.long_minus_primary_mm);
  } else if (isAnalysisKind(pa.kind)) {
    // mtf, fans and psf default to three fields (axis, 70%, corner).
    const std::string fields = pa.fields_given ? pa.fields : std::string("0,0.7,1");
    runAnalysis(pa.kind, fl, args.film_diagonal_mm, parseList(fields, "--fields"), pa.analysis,
                svg_text, j);
  } else if (pa.kind == "spot") {
    auto spots = computeSpots(fl, parseList(pa.fields, "--fields"), args.film_diagonal_mm);
    svg_text = spotSvg(fl, spots);
    json arr = json::array();
    for (const SpotField& s : spots)
      arr.push_back({{"film_height_mm", s.film_height_mm},
                     {"field_angle_deg", s.field_angle_deg},
                     {"rms_radius_mm", s.rms_radius_mm},
                     {"centroid_mm", {s.centroid_mm.x, s.centroid_mm.y}},
                     {"rays_through", s.points_mm.size()},
                     {"hexapolar_rings", s.rings},
                     {"rays_traced", s.rays_traced}});
    j["fields"] = arr;
  } else if (pa.kind == "distortion") {
    DistortionData d = computeDistortion(fl, args.film_diagonal_mm);
    const bool fisheye = !d.angle_deg.empty() && d.angle_deg.back() > 45;
    svg_text = distortionSvg(fl, d, fisheye);
    j["f_reference_mm"] = d.f_reference_mm;
    j["angle_deg"] = d.angle_deg;
    j["height_mm"] = d.height_mm;
    j["percent_tan"] = finiteOrNull(d.percent_tan);
    j["percent_equidistant"] = finiteOrNull(d.percent_equidistant);
    j["percent_equisolid"] = finiteOrNull(d.percent_equisolid);
  } else if (pa.kind == "vignetting") {
    VignettingData v = computeVignetting(fl, args.film_diagonal_mm);
    svg_text = vignettingSvg(fl, v);
    j["film_radius_mm"] = v.film_radius_mm;
    j["unobstructed"] = v.unobstructed;
    j["cos4"] = finiteOrNull(v.cos4);
    j["relative_illumination"] = v.relative_illumination;
  } else {
    FocusCurve c = computeFocusCurve(fl);
    svg_text = focusSvg(fl, c);
    j["closest_focus_distance_m"] = c.closest_m;
    j["thick"] = pairsJson(c.focus_distance_m, c.film_distance_thick_mm);
    j["exact"] = pairsJson(c.focus_distance_m, c.film_distance_exact_mm);
    j["infinity_thick_mm"] = c.infinity_thick_mm;
    j["infinity_exact_mm"] =
        std::isfinite(c.infinity_exact_mm) ? json(c.infinity_exact_mm) : json(nullptr);
  }
  writeFileAtomically(pa.output, svg_text);
  if (pa.as_json) std::cout << j.dump(2) << "\n";
  logInfo(fmt::format("wrote {}", pa.output));
  return 0;
}

}  // namespace

void registerLensCommands(CLI::App& app, Action& action) {
  CLI::App* lens =
      app.add_subcommand("lens", "Analyse a lens prescription (.dat, .zmx, .json, lentil:KEY)");
  lens->require_subcommand(1);

  {
    auto* info = lens->add_subcommand("info", "First-order data, pupils, focus and field of view");
    auto args = std::make_shared<LensArgs>();
    auto as_json = std::make_shared<bool>(false);
    addLensOptions(info, *args);
    info->add_flag("--json", *as_json, "Print one JSON object");
    auto configs = std::make_shared<bool>(false);
    info->add_flag("--configs", *configs,
                   "Table of every configuration of a zoom lens: EFL, f-number, BFL, field of "
                   "view, total track");
    info->add_option("--tilt", args->tilt,
                     "X,Y: the lens tilted against the film about its x and y axes (degrees): "
                     "reports the hinge line and the plane of focus (docs/zoom.md)");
    info->add_option("--shift", args->shift, "X,Y: the lens axis shifted to this film point (mm)");
    info->add_option("--field", args->fields,
                     "X,Y (repeatable): a field of a lens with tilted or decentred surfaces: "
                     "angles in degrees (object at infinity) or the object point in mm");
    info->callback([&action, args, as_json, configs] {
      action = [args, as_json, configs] {
        return *configs ? runConfigs(*args, *as_json) : runInfo(*args, *as_json);
      };
    });
  }
  registerLensGhostsCommand(*lens, action);
  {
    auto* trace = lens->add_subcommand(
        "trace", "Trace one exact ray from a film point toward a point on the rear-vertex plane");
    auto args = std::make_shared<LensArgs>();
    auto film = std::make_shared<std::string>();
    auto rear = std::make_shared<std::string>();
    auto as_json = std::make_shared<bool>(false);
    addLensOptions(trace, *args);
    trace->add_option("--film", *film, "Film point X,Y (mm)")->required();
    trace->add_option("--rear", *rear, "Aim point X,Y on the plane of the rear vertex (mm)")
        ->required();
    trace->add_flag("--json", *as_json, "Print one JSON object");
    trace->callback([&action, args, film, rear, as_json] {
      action = [args, film, rear, as_json] { return runTrace(*args, *film, *rear, *as_json); };
    });
  }
  {
    auto* draw = lens->add_subcommand(
        "draw", "Draw lens cross-sections with exactly traced ray bundles (SVG)");
    auto args = std::make_shared<LensArgs>();
    auto d = std::make_shared<DrawArgs>();
    draw->add_option("LENS", d->lenses, "Lens prescriptions; several make a sheet (2 columns)")
        ->required();
    addLensSetupOptions(draw, *args);
    draw->add_option("-o,--output", d->output, "Output SVG file")->required();
    draw->add_option("--fields", d->fields,
                     "Bundle fields: fractions of the film half-diagonal (--from film) or of the "
                     "half field of view (--from scene); default 0,0.7,1");
    draw->add_option("--rays", d->rays, "Rays per bundle (default 11)");
    draw->add_option("--from", d->from, "Trace bundles from the film or from the scene")
        ->check(CLI::IsMember({"film", "scene"}));
    draw->add_option("--ghost", d->ghost,
                     "Draw the ghost that reflects at surface I, then at J < I (I,J as `lens "
                     "ghosts` lists them): an axial bundle from infinity, traced exactly");
    draw->add_flag("--same-scale", d->same_scale, "Draw every lens of a sheet at one scale");
    draw->add_option("--tilt", args->tilt,
                     "X,Y: the lens tilted against the film (degrees, as `lens info --tilt`): "
                     "the section through the lens axis holding the film's normal");
    draw->add_option("--shift", args->shift, "X,Y: the lens axis shifted to this film point (mm)");
    draw->add_option("--wavelengths", d->wavelengths,
                     "Trace the bundles at each wavelength (nm, comma-separated), drawn in their "
                     "colours, e.g. 486.1,587.6,656.3");
    draw->callback([&action, args, d] { action = [args, d] { return runDraw(*args, *d); }; });
  }
  {
    auto* plot = lens->add_subcommand(
        "plot",
        "Plot spot diagrams, distortion, relative illumination, the focus curve, MTF, "
        "through-focus MTF, ray fans, field curvature or the PSF (SVG)");
    auto args = std::make_shared<LensArgs>();
    auto pa = std::make_shared<PlotArgs>();
    plot->add_option("KIND", pa->kind,
                     "spot, distortion, vignetting, focus, chromatic (focal shift against "
                     "wavelength), lateral-color (F and C image height minus d), mtf, mtf-focus, "
                     "fans, field, psf, breathing (field of view against focus distance) or ghosts "
                     "(the brightest ghosts' intensities; with --image a point light's film image, "
                     "issue 31)")
        ->required()
        ->check(
            CLI::IsMember({"spot", "distortion", "vignetting", "focus", "breathing", "chromatic",
                           "lateral-color", "mtf", "mtf-focus", "fans", "field", "psf", "ghosts"}));
    addLensOptions(plot, *args);
    plot->add_option("-o,--output", pa->output,
                     "Output SVG file (ghosts --image: an image, .exr unscaled, .png ...)")
        ->required();
    plot->add_option("--fields", pa->fields,
                     "spot, mtf, mtf-focus, fans, psf: fields as fractions of the film "
                     "half-diagonal (default 0,0.5,0.7,1 for spot, else 0,0.7,1)")
        ->each([pa](const std::string&) { pa->fields_given = true; });
    addAnalysisOptions(plot, pa->analysis);
    plot->add_flag("--json", pa->as_json, "Also print the plotted numbers as JSON");
    plot->add_option("--angle", pa->ghost_angle_deg,
                     "ghosts: the intensities traced for a point light this far off axis (deg, "
                     "as lens ghosts --angle) instead of the axial ones");
    plot->add_flag("--image", pa->ghost_image,
                   "ghosts: the film image of a point light at --angle (direct and ghosts, "
                   "traced, in colour); -o .exr unscaled, other formats log tone-mapped");
    auto imageOption = [plot, pa](const std::string& name, auto& value, const std::string& help) {
      plot->add_option(name, value, help)->each([pa, name](const std::string&) {
        pa->image_options.push_back(name);
      });
    };
    imageOption("--size", pa->image.size, "ghosts --image: pixels across (default 600; 3:2)");
    imageOption("--grid", pa->image.grid,
                "ghosts --image: rays across the entrance per path (default 256)");
    imageOption("--ghost", pa->image.ghost, "ghosts --image: the ghost I,J only (and the direct)");
    imageOption("--decades", pa->image.decades,
                "ghosts --image: decades of luminance the tone map shows (default 8)");
    imageOption("--exr", pa->image.exr, "ghosts --image: also write the unscaled EXR here");
    imageOption("--coating", pa->image.coating,
                "ghosts --image: lens-wide coating of the air-glass surfaces that name none "
                "(uncoated, single, multi, ...), as lens ghosts --coating");
    plot->callback([&action, args, pa] { action = [args, pa] { return runPlot(*args, *pa); }; });
  }
  {
    auto* convert = lens->add_subcommand(
        "convert", "Convert a lens between formats by extension (.json always; .dat spherical)");
    auto in = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    convert->add_option("IN", *in, "Lens file (.dat, .zmx, .json) or name (lentil:0003)")
        ->required();
    convert->add_option("OUT", *out, "Output .json or .dat")->required();
    auto glass = std::make_shared<LensArgs>();
    convert->add_option("--glass-catalog", glass->glass_catalogs,
                        "Glass catalogue file (.agf or .csv) searched first; repeatable");
    convert->add_flag("--model-glass", glass->model_glass,
                      "A glass in no catalogue becomes a model glass from its n_d and V_d");
    convert->callback([&action, in, out, glass] {
      action = [in, out, glass] {
        applyGlassOptions(*glass);
        return runConvert(*in, *out);
      };
    });
  }
  registerDesignCommands(lens, action);
}

}  // namespace lensim::cmd
