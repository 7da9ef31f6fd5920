#include "lensim/optics/design/design_job.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/design/image_quality.h"
#include "lensim/optics/design/tolerance.h"
#include "lensim/optics/field_rays.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/surface_shape.h"
#include "lensim/util/file.h"

namespace lensim::optics::design {

namespace {

using nlohmann::json;
constexpr double kDeg = std::numbers::pi / 180;

// Where a top-level key is written (its opening quote), else the file's start.
FileLoc keyLoc(std::string_view text, const std::string& key, const std::string& path) {
  const size_t at = text.find("\"" + key + "\"");
  return locAt(text, at == std::string_view::npos ? 0 : at, path);
}

double number(const json& j, const char* key, const FileLoc& loc, std::optional<double> def = {}) {
  auto it = j.find(key);
  if (it == j.end()) {
    if (def) return *def;
    throw Error(loc, fmt::format("missing \"{}\" (a number)", key));
  }
  if (!it->is_number())
    throw Error(loc, fmt::format("\"{}\" is {}: expected a number", key, it->dump()));
  const double v = it->get<double>();
  if (!std::isfinite(v)) throw Error(loc, fmt::format("\"{}\" must be finite", key));
  return v;
}

int surfaceIndex(const json& j, const FileLoc& loc, const LensPrescription& p) {
  const double v = number(j, "surface", loc);
  const int n = static_cast<int>(p.surfaces.size());
  if (v != std::floor(v) || v < 0 || v >= n)
    throw Error(loc, fmt::format("\"surface\" {} is not a row of the lens: expected 0 to {} "
                                 "(0-based rows of {})",
                                 v, n - 1, p.path));
  return static_cast<int>(v);
}

std::string kindOf(const json& e, const FileLoc& loc, const std::vector<std::string>& allowed) {
  auto it = e.find("type");
  if (it == e.end() || !it->is_string())
    throw Error(loc, fmt::format("missing \"type\": expected one of {}", fmt::join(allowed, ", ")));
  const std::string t = it->get<std::string>();
  if (std::find(allowed.begin(), allowed.end(), t) == allowed.end())
    throw Error(loc, fmt::format("unknown type \"{}\": expected one of {}", t,
                                 fmt::join(allowed, ", ")));
  return t;
}

void checkKeys(const json& e, const FileLoc& loc, const std::vector<std::string>& allowed) {
  for (auto it = e.begin(); it != e.end(); ++it)
    if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end())
      throw Error(loc, fmt::format("unknown key \"{}\": expected one of {}", it.key(),
                                   fmt::join(allowed, ", ")));
}

// The operand kinds' names, in the order of Operand::Kind.
constexpr const char* kOperandNames[] = {
    "efl",       "f_number",     "bfl",           "total_track",        "rms_spot",
    "distortion", "lateral_color", "longitudinal_color", "thickness",    "image_height",
    "rms_wavefront", "mtf",      "edge_thickness", "clear_aperture"};
static_assert(std::size(kOperandNames) == static_cast<size_t>(Operand::Kind::ClearAperture) + 1);

// The stop's position between its neighbours: no "surface" (the lens's stop row).
Variable parseStopPosition(const json& e, const FileLoc& loc, const LensPrescription& p) {
  Variable v;
  v.loc = loc;
  v.kind = Variable::Kind::StopPosition;
  if (e.contains("surface") || e.contains("power"))
    throw Error(loc, "a stop_position variable moves the lens's stop row: no \"surface\" or "
                     "\"power\"");
  const std::optional<int> stop = p.stopIndex();
  if (!stop) throw Error(loc, "stop_position: the lens has no stop row (radius 0 row)");
  if (*stop == 0 || *stop + 1 >= static_cast<int>(p.surfaces.size()))
    throw Error(loc, fmt::format("stop_position: the stop is row {}, the {} row: it needs a row "
                                 "before and after it to slide between",
                                 *stop, *stop == 0 ? "first" : "last"));
  v.surface = *stop;
  const double before = p.surfaces[size_t(*stop - 1)].thickness_mm;
  v.gap_mm = before + p.surfaces[size_t(*stop)].thickness_mm;
  v.lower = number(e, "min", loc, 0.0);
  v.upper = number(e, "max", loc, v.gap_mm);
  if (!(v.lower >= 0 && v.upper <= v.gap_mm && v.lower < v.upper))
    throw Error(loc, fmt::format("stop_position: \"min\" {} and \"max\" {} must satisfy 0 <= "
                                 "min < max <= {} mm (the gap the stop slides in)",
                                 v.lower, v.upper, v.gap_mm));
  if (!(before >= v.lower && before <= v.upper))
    throw Error(loc, fmt::format("stop_position: the stop starts {} mm behind row {}, outside "
                                 "[{}, {}]",
                                 before, *stop - 1, v.lower, v.upper));
  return v;
}

Variable parseVariable(const json& e, const FileLoc& loc, const LensPrescription& p) {
  Variable v;
  v.loc = loc;
  checkKeys(e, loc, {"type", "surface", "power", "min", "max"});
  const std::string t = kindOf(e, loc, {"curvature", "thickness", "conic", "asphere", "glass_nd",
                                        "glass_vd", "stop_position"});
  if (t == "stop_position") return parseStopPosition(e, loc, p);
  v.surface = surfaceIndex(e, loc, p);
  const LensSurface& s = p.surfaces[v.surface];
  if (t == "curvature") {
    v.kind = Variable::Kind::Curvature;
    if (s.isStop()) throw Error(loc, fmt::format("surface {} is the stop: it has no curvature", v.surface));
  } else if (t == "thickness") {
    v.kind = Variable::Kind::Thickness;
    v.lower = 0;
  } else if (t == "conic") {
    v.kind = Variable::Kind::Conic;
  } else if (t == "asphere") {
    v.kind = Variable::Kind::Asphere;
    const double pw = number(e, "power", loc);
    if (pw != std::floor(pw) || pw < 2 || pw > 20)
      throw Error(loc, fmt::format("\"power\" {} is not an aspheric term: expected an integer "
                                   "from 2 to 20 (the coefficient of r^power)",
                                   pw));
    v.power = static_cast<int>(pw);
  } else {
    v.kind = t == "glass_nd" ? Variable::Kind::GlassIndex : Variable::Kind::GlassAbbe;
    const bool air = s.glass.empty() && (s.ior == 1 || s.ior == 0);
    if (air || s.mirror)
      throw Error(loc, fmt::format("surface {}: the medium after it is {}: a glass variable "
                                   "needs glass",
                                   v.surface, s.mirror ? "a mirror's" : "air"));
    if (v.kind == Variable::Kind::GlassIndex) v.lower = 1.4, v.upper = 2.0;
    else v.lower = 20, v.upper = 95;
  }
  if ((v.kind == Variable::Kind::Curvature || v.kind == Variable::Kind::Conic ||
       v.kind == Variable::Kind::Asphere) && !s.shape.isRotational())
    throw Error(loc, fmt::format("surface {} is not rotationally symmetric: only rotational "
                                 "surfaces are optimised",
                                 v.surface));
  v.lower = number(e, "min", loc, v.lower);
  v.upper = number(e, "max", loc, v.upper);
  if (!(v.lower < v.upper))
    throw Error(loc, fmt::format("\"min\" {} must be below \"max\" {}", v.lower, v.upper));
  return v;
}

Operand parseOperand(const json& e, const FileLoc& loc, const LensPrescription& p) {
  Operand o;
  o.loc = loc;
  checkKeys(e, loc,
            {"type", "target", "weight", "min", "max", "field_deg", "wavelength_nm", "surface",
             "frequency", "azimuth"});
  const std::vector<std::string> kinds(std::begin(kOperandNames), std::end(kOperandNames));
  const std::string t = kindOf(e, loc, kinds);
  o.kind = static_cast<Operand::Kind>(std::find(kinds.begin(), kinds.end(), t) - kinds.begin());
  o.weight = number(e, "weight", loc, 1.0);
  if (!(o.weight >= 0)) throw Error(loc, fmt::format("\"weight\" {} must be >= 0", o.weight));
  if (e.contains("min")) o.min = number(e, "min", loc);
  if (e.contains("max")) o.max = number(e, "max", loc);
  const bool limits = o.min || o.max;
  if (limits && e.contains("target"))
    throw Error(loc, "give either \"target\" or limits (\"min\", \"max\"), not both");
  if (o.min && o.max && !(*o.min <= *o.max))
    throw Error(loc, fmt::format("\"min\" {} must not exceed \"max\" {}", *o.min, *o.max));
  const bool zero_target =
      o.kind == Operand::Kind::RmsSpot || o.kind == Operand::Kind::RmsWavefront;
  if (o.kind == Operand::Kind::Mtf) {
    o.frequency = number(e, "frequency", loc);
    if (!(o.frequency > 0 && o.frequency <= 5000))
      throw Error(loc, fmt::format("\"frequency\" {} must be in (0, 5000] cycles/mm", o.frequency));
    const std::string az = !e.contains("azimuth")     ? "tangential"
                           : e["azimuth"].is_string() ? e["azimuth"].get<std::string>()
                                                      : e["azimuth"].dump();
    if (az != "tangential" && az != "sagittal")
      throw Error(loc, fmt::format("\"azimuth\" \"{}\": expected tangential or sagittal", az));
    o.sagittal = az == "sagittal";
  } else if (e.contains("frequency") || e.contains("azimuth")) {
    throw Error(loc, "\"frequency\" and \"azimuth\" belong to mtf operands");
  }
  if (o.kind == Operand::Kind::Thickness || o.kind == Operand::Kind::EdgeThickness) {
    if (!limits) throw Error(loc, fmt::format("a{} thickness operand needs \"min\" and/or \"max\" (mm)",
                                              o.kind == Operand::Kind::EdgeThickness ? "n edge" : ""));
    o.surface = surfaceIndex(e, loc, p);
    if (o.kind == Operand::Kind::EdgeThickness && o.surface + 1 >= static_cast<int>(p.surfaces.size()))
      throw Error(loc, fmt::format("edge_thickness: surface {} is the last row (its thickness is "
                                   "the film distance)",
                                   o.surface));
  } else if (o.kind == Operand::Kind::ClearAperture) {
    o.surface = surfaceIndex(e, loc, p);
    if (!limits) o.max = p.surfaces[size_t(o.surface)].semiAperture_mm();
  } else if (!limits) {
    o.target = number(e, "target", loc, zero_target ? std::optional<double>(0.0) : std::nullopt);
  }
  if (e.contains("field_deg")) {
    o.field_deg = number(e, "field_deg", loc);
    if (!(o.field_deg >= 0 && o.field_deg < 89))
      throw Error(loc, fmt::format("\"field_deg\" {} must be in [0, 89)", o.field_deg));
  }
  if (e.contains("wavelength_nm")) {
    o.wavelength_nm = number(e, "wavelength_nm", loc);
    if (!(o.wavelength_nm >= 200 && o.wavelength_nm <= 2500))
      throw Error(loc, fmt::format("\"wavelength_nm\" {} must be in [200, 2500]", o.wavelength_nm));
  }
  return o;
}

// A decentre (mm) or tilt (degrees) of an element (`"element": first row`, through the row after
// which the medium is air) or of one surface (`"surface": row`), along or about `"axis"` x or y.
void parseMotionTolerance(const json& e, const FileLoc& loc, const LensPrescription& p, bool tilt,
                          Tolerance& t) {
  checkKeys(e, loc, {"type", "axis", "element", "surface", "delta", "distribution"});
  const std::string axis = e.contains("axis") && e["axis"].is_string() ? e["axis"].get<std::string>()
                                                                      : std::string();
  if (axis != "x" && axis != "y")
    throw Error(loc, fmt::format("\"axis\" {}: expected \"x\" or \"y\"",
                                 e.contains("axis") ? e["axis"].dump() : "missing"));
  t.kind = tilt ? (axis == "x" ? Tolerance::Kind::TiltX : Tolerance::Kind::TiltY)
                : (axis == "x" ? Tolerance::Kind::DecentreX : Tolerance::Kind::DecentreY);
  if (e.contains("element") == e.contains("surface"))
    throw Error(loc, "a decentre or tilt names either \"element\" (its first row) or \"surface\"");
  if (p.fold_loc || p.noncoaxial_loc)
    throw Error(loc, "decentre and tilt tolerances need a coaxial lens (this one is folded or "
                     "already tilted)");
  for (const LensSurface& s : p.surfaces)
    if (s.mirror)
      throw Error(loc, "decentre and tilt tolerances are not modelled for lenses with mirrors");
  const bool element = e.contains("element");
  json row = e;
  if (element) row["surface"] = e["element"];
  t.surface = surfaceIndex(row, loc, p);
  t.last_surface = t.surface;
  auto air = [&](int i) {
    const LensSurface& s = p.surfaces[size_t(i)];
    return s.glass.empty() && (s.ior == 1 || s.ior == 0);
  };
  if (element) {
    if (air(t.surface))
      throw Error(loc, fmt::format("\"element\" {}: the medium after that row is air, so no "
                                   "element starts there (name its first surface)",
                                   t.surface));
    const int n = static_cast<int>(p.surfaces.size());
    while (t.last_surface < n - 1 && !air(t.last_surface)) ++t.last_surface;
    if (!air(t.last_surface))
      throw Error(loc, fmt::format("\"element\" {}: the glass runs to the film", t.surface));
  }
  t.delta = number(e, "delta", loc);
  const double limit = tilt ? 45 : 0.5 * p.surfaces[size_t(t.surface)].semiAperture_mm();
  if (!(t.delta > 0 && t.delta < limit))
    throw Error(loc, fmt::format("\"delta\" {} must be > 0 and below {} {}", t.delta, limit,
                                 tilt ? "degrees" : "mm (half the first surface's semi-aperture)"));
}

// Surface irregularity (`"delta"` fringes at `"test_wavelength_nm"`) of one refracting or
// reflecting rotationally symmetric surface: applyIrregularity (tolerance.h) gives the form.
void parseIrregularity(const json& e, const FileLoc& loc, const LensPrescription& p,
                       Tolerance& t) {
  checkKeys(e, loc, {"type", "surface", "delta", "distribution", "test_wavelength_nm"});
  t.kind = Tolerance::Kind::Irregularity;
  t.surface = surfaceIndex(e, loc, p);
  t.last_surface = t.surface;
  const LensSurface& s = p.surfaces[size_t(t.surface)];
  t.delta = number(e, "delta", loc);
  if (!(t.delta > 0 && t.delta <= 100))
    throw Error(loc, fmt::format("\"delta\" {} fringes must be > 0 and at most 100", t.delta));
  t.test_wavelength_nm = number(e, "test_wavelength_nm", loc, 632.8);
  if (!(t.test_wavelength_nm >= 200 && t.test_wavelength_nm <= 20000))
    throw Error(loc, fmt::format("\"test_wavelength_nm\" {} must be in [200, 20000]",
                                 t.test_wavelength_nm));
  if (s.isStop())
    throw Error(loc, fmt::format("surface {} is the stop: it has no surface to be irregular",
                                 t.surface));
  if (!s.shape.isRotational())
    throw Error(loc, fmt::format("surface {} is not rotationally symmetric (biconic or toroidal): "
                                 "irregularity is modelled on rotational surfaces",
                                 t.surface));
  if (!(s.semiAperture_mm() > 0))
    throw Error(loc, fmt::format("surface {} has no clear aperture to measure fringes over",
                                 t.surface));
  // Both extremes must leave a surface defined over its clear aperture.
  for (double w : {-t.delta, t.delta}) {
    LensSurface b = s;
    applyIrregularity(b, w, t.test_wavelength_nm);
    if (!(sagDomainRadius(b.radius_mm, b.shape) > b.semiAperture_mm()))
      throw Error(loc, fmt::format("\"delta\" {} fringes: the irregular surface {} is not defined "
                                   "out to its semi-aperture {} mm",
                                   t.delta, t.surface, s.semiAperture_mm()));
  }
}

void parseAxialTolerance(const json& e, const FileLoc& loc, const LensPrescription& p,
                         const std::string& k, Tolerance& t) {
  checkKeys(e, loc, {"type", "surface", "delta", "distribution"});
  t.kind = k == "radius"      ? Tolerance::Kind::Radius
           : k == "thickness" ? Tolerance::Kind::Thickness
           : k == "index"     ? Tolerance::Kind::Index
                              : Tolerance::Kind::Abbe;
  t.surface = surfaceIndex(e, loc, p);
  t.last_surface = t.surface;
  const LensSurface& s = p.surfaces[t.surface];
  t.delta = number(e, "delta", loc);
  if (!(t.delta > 0)) throw Error(loc, fmt::format("\"delta\" {} must be > 0", t.delta));
  if (t.kind == Tolerance::Kind::Radius && s.isStop())
    throw Error(loc, fmt::format("surface {} is the stop: it has no radius", t.surface));
  if ((t.kind == Tolerance::Kind::Index || t.kind == Tolerance::Kind::Abbe) &&
      (s.mirror || (s.glass.empty() && (s.ior == 1 || s.ior == 0))))
    throw Error(loc, fmt::format("surface {}: the medium after it is air: index and Abbe "
                                 "tolerances need glass",
                                 t.surface));
  if (t.kind == Tolerance::Kind::Radius && !(t.delta < std::abs(s.radius_mm)))
    throw Error(loc, fmt::format("\"delta\" {} must be below the radius's magnitude {} mm (a "
                                 "build would flip or flatten the surface)",
                                 t.delta, std::abs(s.radius_mm)));
  if (t.kind == Tolerance::Kind::Thickness && !(t.delta < s.thickness_mm))
    throw Error(loc, fmt::format("\"delta\" {} must be below the thickness {} mm", t.delta,
                                 s.thickness_mm));
  if (t.kind == Tolerance::Kind::Index || t.kind == Tolerance::Kind::Abbe) {
    const Glass g = resolveGlass(s.glass, s.ior);
    const bool index = t.kind == Tolerance::Kind::Index;
    const double base = index ? g.n_d() - 1 : g.v_d();
    if (!index && !std::isfinite(base))
      throw Error(loc, fmt::format("surface {}: the medium after it has no dispersion (index {} "
                                   "without V_d): an Abbe tolerance needs a dispersive glass",
                                   t.surface, g.n_d()));
    if (!(t.delta < base))
      throw Error(loc, fmt::format("\"delta\" {} must be below the medium's {} ({}) so that every "
                                   "build is physical",
                                   t.delta, index ? "n_d - 1" : "V_d", base));
  }
}

Tolerance parseTolerance(const json& e, const FileLoc& loc, const LensPrescription& p) {
  Tolerance t;
  t.loc = loc;
  const std::string k = kindOf(e, loc, {"radius", "thickness", "index", "abbe", "decentre",
                                        "decenter", "tilt", "irregularity"});
  if (k == "decentre" || k == "decenter" || k == "tilt") {
    parseMotionTolerance(e, loc, p, k == "tilt", t);
  } else if (k == "irregularity") {
    parseIrregularity(e, loc, p, t);
  } else {
    parseAxialTolerance(e, loc, p, k, t);
  }
  const std::string d = e.value("distribution", std::string("uniform"));
  if (d == "uniform") t.distribution = Tolerance::Distribution::Uniform;
  else if (d == "normal") t.distribution = Tolerance::Distribution::Normal;
  else if (d == "end_point") t.distribution = Tolerance::Distribution::EndPoint;
  else
    throw Error(loc, fmt::format("\"distribution\" \"{}\": expected uniform, normal or end_point", d));
  return t;
}

template <typename T, typename F>
std::vector<T> parseArray(const json& j, const char* key, std::string_view text,
                          const std::string& path, F parse) {
  std::vector<T> out;
  auto it = j.find(key);
  if (it == j.end()) return out;
  if (!it->is_array())
    throw Error(keyLoc(text, key, path), fmt::format("\"{}\" must be an array of objects", key));
  const auto offs = arrayElementOffsets(text, key);
  for (size_t i = 0; i < it->size(); ++i) {
    const FileLoc loc = i < offs.size() ? locAt(text, offs[i], path) : keyLoc(text, key, path);
    if (!(*it)[i].is_object())
      throw Error(loc, fmt::format("\"{}\"[{}] must be an object", key, i));
    out.push_back(parse((*it)[i], loc));
  }
  return out;
}

std::vector<double> numberArray(const json& j, const char* key, std::string_view text,
                                const std::string& path, double lo, double hi) {
  std::vector<double> out;
  const FileLoc loc = keyLoc(text, key, path);
  const json& a = j.at(key);
  if (!a.is_array() || a.empty())
    throw Error(loc, fmt::format("\"{}\" must be a non-empty array of numbers", key));
  for (const json& v : a) {
    if (!v.is_number() || !(v.get<double>() >= lo && v.get<double>() <= hi))
      throw Error(loc, fmt::format("\"{}\": {} is not a number in [{}, {}]", key, v.dump(), lo, hi));
    out.push_back(v.get<double>());
  }
  return out;
}

double totalTrack(const LensPrescription& p) {
  double t = 0;
  for (const LensSurface& s : p.surfaces) t += s.thickness_mm;
  return t;
}

double chiefHeight(const LensSystem& lens, const ParaxialData& par, double field_deg) {
  if (field_deg == 0) return 0;
  auto c = chiefRayFromScene(lens, par, field_deg);
  if (!c) throw Error(fmt::format("no real chief ray at {} deg", field_deg));
  return c->film_height_mm;
}

}  // namespace

const char* variableKindName(Variable::Kind k) {
  switch (k) {
    case Variable::Kind::Curvature: return "curvature";
    case Variable::Kind::Thickness: return "thickness";
    case Variable::Kind::Conic: return "conic";
    case Variable::Kind::Asphere: return "asphere";
    case Variable::Kind::GlassIndex: return "glass_nd";
    case Variable::Kind::GlassAbbe: return "glass_vd";
    case Variable::Kind::StopPosition: return "stop_position";
  }
  return "?";
}

const char* operandKindName(Operand::Kind k) { return kOperandNames[static_cast<int>(k)]; }

std::string Operand::label() const {
  switch (kind) {
    case Kind::RmsSpot:
    case Kind::RmsWavefront:
      return fmt::format("{}({:g} deg, {:g} nm)", operandKindName(kind), field_deg, wavelength_nm);
    case Kind::Mtf:
      return wavelength_nm > 0 ? fmt::format("mtf({:g} c/mm, {:g} deg, {}, {:g} nm)", frequency,
                                             field_deg, sagittal ? "sag" : "tan", wavelength_nm)
                               : fmt::format("mtf({:g} c/mm, {:g} deg, {})", frequency, field_deg,
                                             sagittal ? "sag" : "tan");
    case Kind::Distortion:
    case Kind::LateralColor:
    case Kind::ImageHeight: return fmt::format("{}({:g} deg)", operandKindName(kind), field_deg);
    case Kind::Thickness:
    case Kind::EdgeThickness:
    case Kind::ClearAperture: return fmt::format("{}(surface {})", operandKindName(kind), surface);
    default: return operandKindName(kind);
  }
}

std::string Tolerance::label() const {
  static const char* names[] = {"radius",     "thickness",  "index",  "abbe",  "irregularity",
                                "decentre x", "decentre y", "tilt x", "tilt y"};
  const char* name = names[static_cast<int>(kind)];
  if (kind == Kind::Irregularity)
    return fmt::format("{} surface {} +-{:g} fringes", name, surface, delta);
  if (!moves()) return fmt::format("{} surface {} +-{:g}", name, surface, delta);
  const std::string unit = kind >= Kind::TiltX ? " deg" : "";
  if (last_surface == surface) return fmt::format("{} surface {} +-{:g}{}", name, surface, delta, unit);
  return fmt::format("{} element {}-{} +-{:g}{}", name, surface, last_surface, delta, unit);
}

DesignJob parseDesignJob(std::string_view text, const std::string& path) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw Error(locAt(text, e.byte > 0 ? e.byte - 1 : 0, path),
                fmt::format("not valid JSON: {}", e.what()));
  }
  if (!j.is_object()) throw Error(FileLoc{path, 1, 1}, "a design job must be a JSON object");
  const FileLoc top{path, 1, 1};
  checkKeys(j, top,
            {"$schema", "lens", "wavelengths_nm", "fields_deg", "rings", "variables", "operands",
             "snap_glass", "max_iterations", "tolerancing", "global"});
  DesignJob job;
  job.path = path;
  if (!j.contains("lens") || !j["lens"].is_string())
    throw Error(keyLoc(text, "lens", path), "\"lens\" must name the starting lens file");
  std::string lens = j["lens"].get<std::string>();
  const bool catalogue = lens.rfind("lentil:", 0) == 0 || lens.rfind("lenses:", 0) == 0;
  if (!catalogue && std::filesystem::path(lens).is_relative())
    lens = (std::filesystem::path(path).parent_path() / lens).string();
  job.lens_path = lens;
  try {
    job.start = readLensFile(lens);
  } catch (const Error& e) {
    throw Error(keyLoc(text, "lens", path), fmt::format("cannot read the lens: {}", nestedMessage(e)));
  }
  if (!job.start.stopIndex())
    throw Error(keyLoc(text, "lens", path), "the lens has no aperture stop row: a design needs "
                                            "one (it sets the beam)");
  job.wavelengths_nm = j.contains("wavelengths_nm")
                           ? numberArray(j, "wavelengths_nm", text, path, 200, 2500)
                           : std::vector<double>{primaryWavelength_nm(job.start)};
  job.fields_deg = j.contains("fields_deg") ? numberArray(j, "fields_deg", text, path, 0, 89)
                                            : std::vector<double>{0};
  job.rings = static_cast<int>(number(j, "rings", keyLoc(text, "rings", path), 6.0));
  if (job.rings < 1 || job.rings > 64)
    throw Error(keyLoc(text, "rings", path), fmt::format("\"rings\" {} must be 1 to 64", job.rings));
  job.max_iterations =
      static_cast<int>(number(j, "max_iterations", keyLoc(text, "max_iterations", path), 50.0));
  if (job.max_iterations < 0 || job.max_iterations > 100000)
    throw Error(keyLoc(text, "max_iterations", path), "\"max_iterations\" must be 0 to 100000");
  job.snap_glass = j.value("snap_glass", true);
  if (j.contains("global")) {
    const json& g = j["global"];
    const FileLoc gl = keyLoc(text, "global", path);
    if (!g.is_object())
      throw Error(gl, "\"global\" must be an object: {\"starts\": N, \"seed\": S}");
    checkKeys(g, gl, {"starts", "seed"});
    const double n = number(g, "starts", gl);
    if (n != std::floor(n) || n < 1 || n > 10000)
      throw Error(gl, fmt::format("\"starts\" {} must be an integer 1 to 10000", n));
    job.global_starts = static_cast<int>(n);
    const double seed = number(g, "seed", gl, 1.0);
    if (seed != std::floor(seed) || seed < 0 || seed > 9.0e15)
      throw Error(gl, fmt::format("\"seed\" {} must be a non-negative integer", seed));
    job.global_seed = static_cast<std::uint64_t>(seed);
  }
  const LensPrescription& p = job.start;
  job.variables = parseArray<Variable>(j, "variables", text, path,
                                       [&](const json& e, const FileLoc& l) { return parseVariable(e, l, p); });
  // The stop's position sets the thicknesses on both sides of it: no other variable may.
  for (const Variable& sv : job.variables)
    if (sv.kind == Variable::Kind::StopPosition)
      for (const Variable& v : job.variables)
        if (v.kind == Variable::Kind::Thickness &&
            (v.surface == sv.surface || v.surface == sv.surface - 1))
          throw Error(v.loc, fmt::format("a thickness variable of row {} and the stop_position "
                                         "variable (line {}) set the same thickness",
                                         v.surface, sv.loc.line));
  std::vector<Operand> ops = parseArray<Operand>(
      j, "operands", text, path, [&](const json& e, const FileLoc& l) { return parseOperand(e, l, p); });
  // An RMS spot or wavefront without a field or wavelength stands for every field and wavelength of
  // the job.
  const auto offs = arrayElementOffsets(text, "operands");
  for (size_t i = 0; i < ops.size(); ++i) {
    const json& e = j["operands"][i];
    if (ops[i].kind != Operand::Kind::RmsSpot && ops[i].kind != Operand::Kind::RmsWavefront) {
      job.operands.push_back(ops[i]);
      continue;
    }
    const std::vector<double> fs =
        e.contains("field_deg") ? std::vector<double>{ops[i].field_deg} : job.fields_deg;
    const std::vector<double> ws =
        e.contains("wavelength_nm") ? std::vector<double>{ops[i].wavelength_nm} : job.wavelengths_nm;
    for (double f : fs)
      for (double w : ws) {
        Operand o = ops[i];
        o.field_deg = f, o.wavelength_nm = w;
        job.operands.push_back(o);
      }
  }
  if (j.contains("tolerancing")) {
    const json& t = j["tolerancing"];
    const FileLoc tl = keyLoc(text, "tolerancing", path);
    if (!t.is_object()) throw Error(tl, "\"tolerancing\" must be an object");
    checkKeys(t, tl, {"tolerances", "criterion", "compensator", "monte_carlo", "seed", "frequency",
                      "azimuth"});
    job.tolerance.tolerances = parseArray<Tolerance>(
        t, "tolerances", text, path, [&](const json& e, const FileLoc& l) { return parseTolerance(e, l, p); });
    job.tolerance.criterion = t.value("criterion", std::string("rms_spot"));
    static const std::vector<std::string> crit = {"rms_spot", "boresight", "mtf", "efl", "bfl",
                                                  "f_number", "total_track", "longitudinal_color"};
    if (std::find(crit.begin(), crit.end(), job.tolerance.criterion) == crit.end())
      throw Error(tl, fmt::format("\"criterion\" \"{}\": expected one of {}", job.tolerance.criterion,
                                  fmt::join(crit, ", ")));
    if (job.tolerance.criterion == "mtf") {
      job.tolerance.mtf_frequency = number(t, "frequency", tl);
      if (!(job.tolerance.mtf_frequency > 0 && job.tolerance.mtf_frequency <= 5000))
        throw Error(tl, fmt::format("\"frequency\" {} must be in (0, 5000] cycles/mm",
                                    job.tolerance.mtf_frequency));
      job.tolerance.mtf_azimuth = t.value("azimuth", std::string("both"));
      if (job.tolerance.mtf_azimuth != "both" && job.tolerance.mtf_azimuth != "tangential" &&
          job.tolerance.mtf_azimuth != "sagittal")
        throw Error(tl, fmt::format("\"azimuth\" \"{}\": expected both, tangential or sagittal",
                                    job.tolerance.mtf_azimuth));
    } else if (t.contains("frequency") || t.contains("azimuth")) {
      throw Error(tl, "\"frequency\" and \"azimuth\" belong to the mtf criterion");
    }
    for (const Tolerance& x : job.tolerance.tolerances)
      if (x.moves() && job.tolerance.criterion != "rms_spot" &&
          job.tolerance.criterion != "boresight")
        throw Error(x.loc, fmt::format("a decentre or tilt makes the lens non-coaxial, which has "
                                       "no {} \"{}\": use criterion rms_spot or boresight",
                                       job.tolerance.criterion == "mtf" ? "coaxial pupil function for"
                                                                        : "first-order",
                                       job.tolerance.criterion));
    const std::string comp = t.value("compensator", std::string("back_focus"));
    if (comp != "back_focus" && comp != "none")
      throw Error(tl, fmt::format("\"compensator\" \"{}\": expected back_focus or none", comp));
    job.tolerance.back_focus_compensator = comp == "back_focus";
    const double n = number(t, "monte_carlo", tl, 100.0);
    if (n != std::floor(n) || n < 0 || n > 1e6)
      throw Error(tl, fmt::format("\"monte_carlo\" {} must be an integer 0 to 1000000", n));
    job.tolerance.monte_carlo = static_cast<int>(n);
    const double seed = number(t, "seed", tl, 1.0);
    if (seed != std::floor(seed) || seed < 0 || seed > 9.0e15)
      throw Error(tl, fmt::format("\"seed\" {} must be a non-negative integer", seed));
    job.tolerance.seed = static_cast<std::uint64_t>(seed);
  }
  return job;
}

DesignJob readDesignJob(const std::string& path) {
  return parseDesignJob(readRegularFile(path, "design job", kMaxLensFileBytes), path);
}

std::vector<double> variableValues(const std::vector<Variable>& vars, const LensPrescription& p) {
  std::vector<double> x;
  for (const Variable& v : vars) {
    const LensSurface& s = p.surfaces[v.surface];
    switch (v.kind) {
      case Variable::Kind::Curvature: x.push_back(s.radius_mm == 0 ? 0 : 1 / s.radius_mm); break;
      case Variable::Kind::Thickness: x.push_back(s.thickness_mm); break;
      case Variable::Kind::StopPosition: x.push_back(p.surfaces[size_t(v.surface - 1)].thickness_mm); break;
      case Variable::Kind::Conic: x.push_back(s.shape.conic); break;
      case Variable::Kind::Asphere:
        x.push_back(static_cast<int>(s.shape.poly.size()) > v.power ? s.shape.poly[v.power] : 0);
        break;
      case Variable::Kind::GlassIndex:
      case Variable::Kind::GlassAbbe: {
        const Glass g = resolveGlass(s.glass, s.ior);
        const double vd = g.v_d();
        x.push_back(v.kind == Variable::Kind::GlassIndex ? g.n_d() : (std::isfinite(vd) ? vd : 60));
        break;
      }
    }
  }
  return x;
}

LensPrescription applyVariables(const std::vector<Variable>& vars, LensPrescription p,
                                const std::vector<double>& x) {
  for (size_t k = 0; k < vars.size(); ++k) {
    const Variable& v = vars[k];
    LensSurface& s = p.surfaces[v.surface];
    switch (v.kind) {
      case Variable::Kind::Curvature: s.radius_mm = x[k] == 0 ? 0 : 1 / x[k]; break;
      case Variable::Kind::Thickness: s.thickness_mm = x[k]; break;
      case Variable::Kind::StopPosition:
        p.surfaces[size_t(v.surface - 1)].thickness_mm = x[k];
        s.thickness_mm = v.gap_mm - x[k];
        break;
      case Variable::Kind::Conic: s.shape.conic = x[k]; break;
      case Variable::Kind::Asphere:
        if (static_cast<int>(s.shape.poly.size()) <= v.power) s.shape.poly.resize(v.power + 1, 0);
        s.shape.poly[v.power] = x[k];
        break;
      case Variable::Kind::GlassIndex:
      case Variable::Kind::GlassAbbe: {
        // A model glass through (n_d, V_d): start from the medium's current values.
        const Glass g = resolveGlass(s.glass, s.ior);
        double nd = s.glass.name.empty() && s.glass.n_d ? *s.glass.n_d : g.n_d();
        double vd = s.glass.name.empty() && s.glass.v_d ? *s.glass.v_d : g.v_d();
        if (!std::isfinite(vd)) vd = 60;
        (v.kind == Variable::Kind::GlassIndex ? nd : vd) = x[k];
        s.glass.name.clear();
        s.glass.n_d = nd;
        s.glass.v_d = vd;
        s.ior = nd;
        break;
      }
    }
  }
  // A radius shorter than the clear aperture: the aperture shrinks to what the surface allows.
  for (LensSurface& s : p.surfaces) {
    const double extent = sagDomainRadius(s.radius_mm, s.shape);
    if (s.semiAperture_mm() >= extent) s.aperture_diameter_mm = 2 * 0.98 * extent;
  }
  return p;
}

SpotQuadratic beamSpot(double pupil_radius_mm, double field_deg, int rings, const LandFn& land) {
  Vec2 hit, slope;
  const FieldBundle::PupilRegion region = passingPupil(
      pupil_radius_mm, [&](Vec2 o) { return land(o, hit, slope); }, field_deg);
  const bool cut = region.radius.size() != 4;
  // Weighted moments of the hit (x, y) and of the slopes (u, v) = d(x, y)/dz.
  double sw = 0, sx = 0, sy = 0, su = 0, sv = 0, sxx = 0, sxu = 0, suu = 0;
  for (const PupilPoint& q : hexapolarPupil(region, rings)) {
    // In a cut beam a point may fall where the boundary bends in between two azimuths: left out.
    if (!land(q.offset_mm, hit, slope)) {
      if (cut) continue;
      throw Error(fmt::format("a ray of the {} deg beam does not reach the film", field_deg));
    }
    const double x = hit.x, y = hit.y, u = slope.x, v = slope.y, w = q.weight;
    sw += w, sx += w * x, sy += w * y, su += w * u, sv += w * v;
    sxx += w * (x * x + y * y), sxu += w * (x * u + y * v), suu += w * (u * u + v * v);
  }
  if (!(sw > 0))
    throw Error(fmt::format("no ray of the {} deg beam reaches the film", field_deg));
  SpotQuadratic out;
  out.a = std::max(0.0, sxx / sw - (sx * sx + sy * sy) / (sw * sw));
  out.b = sxu / sw - (sx * su + sy * sv) / (sw * sw);
  out.c = std::max(0.0, suu / sw - (su * su + sv * sv) / (sw * sw));
  return out;
}

SpotQuadratic spotQuadratic(const LensPrescription& p, double field_deg, double lambda_nm,
                            double primary_nm, int rings) {
  const FocusedLens fl = evaluationLens(p);
  const LensSystem prim = fl.lens->atWavelength(primary_nm);
  const ParaxialData pp = computeParaxial(prim);
  const FieldBundle beam = fieldBundle(prim, pp, field_deg);
  const LensSystem lens = fl.lens->atWavelength(lambda_nm);
  const double film_z = lens.filmZ_mm();
  return beamSpot(pp.entrance_pupil_diameter_mm / 2, field_deg, rings,
                  [&](Vec2 offset, Vec2& hit, Vec2& slope) {
                    const TraceResult r = lens.tracer().traceFromScene(beam.sceneRay(offset),
                                                                       TraceOptions{false});
                    if (!r.ok() || !(r.ray.direction.z > 0)) return false;
                    const double t = (film_z - r.ray.origin.z) / r.ray.direction.z;
                    hit = {r.ray.origin.x + r.ray.direction.x * t,
                           r.ray.origin.y + r.ray.direction.y * t};
                    slope = {r.ray.direction.x / r.ray.direction.z,
                             r.ray.direction.y / r.ray.direction.z};
                    return true;
                  });
}

double rmsSpot_mm(const LensPrescription& p, double field_deg, double lambda_nm, double primary_nm,
                  int rings) {
  return std::sqrt(spotQuadratic(p, field_deg, lambda_nm, primary_nm, rings).a);
}

namespace {

// Thickness after row `i` at the element's edge: at the larger of the two rows' semi-apertures,
// along y.
double edgeThickness(const LensPrescription& p, int i) {
  const LensSurface& a = p.surfaces[size_t(i)];
  const LensSurface& b = p.surfaces[size_t(i + 1)];
  const double h = std::max(a.semiAperture_mm(), b.semiAperture_mm());
  auto sag = [&](const LensSurface& s, int row) {
    const auto g = surfaceSag(s.radius_mm, s.shape, 0, h);
    if (!g)
      throw Error(fmt::format("edge_thickness: the sag of row {} is not defined at the edge "
                              "height {} mm",
                              row, h));
    return g->z;
  };
  return a.thickness_mm + sag(b, i + 1) - sag(a, i);
}

// The largest real ray height at row `row` over the rims of the job's field beams (primary
// wavelength, floating apertures as every operand sees them).
double clearAperture(const DesignJob& job, const FocusedLens& fl, const ParaxialData& pp, int row) {
  const LensSystem& lens = *fl.lens;
  constexpr int kAzimuths = 32;
  double most = 0;
  std::vector<Vec3> path;
  for (double field : job.fields_deg) {
    const FieldBundle beam = fieldBundle(lens, pp, field);
    auto trace = [&](Vec2 o, std::vector<Vec3>* at) {
      const TraceResult r = lens.tracer().traceFromScene(beam.sceneRay(o), TraceOptions{false}, at);
      return r.ok() && r.ray.direction.z > 0;
    };
    const FieldBundle::PupilRegion region = passingPupil(
        pp.entrance_pupil_diameter_mm / 2, [&](Vec2 o) { return trace(o, nullptr); }, field,
        kAzimuths);
    for (int k = 0; k < kAzimuths; ++k) {
      const double phi = 2 * std::numbers::pi * k / kAzimuths;
      const double r = region.radiusAt(phi);
      path.clear();
      if (!trace({r * std::cos(phi), r * std::sin(phi)}, &path) ||
          path.size() < static_cast<size_t>(row) + 2)
        throw Error(fmt::format("clear_aperture: a rim ray of the {} deg beam does not reach the "
                                "film",
                                field));
      const Vec3& q = path[size_t(row) + 1];  // path[0] is the ray's start
      most = std::max(most, std::hypot(q.x, q.y));
    }
  }
  return most;
}

}  // namespace

std::vector<double> operandValues(const DesignJob& job, const LensPrescription& p) {
  const double primary = job.wavelengths_nm.front();
  FocusedLens fl = evaluationLens(p);
  fl.lens->setWavelength(primary);
  fl.paraxial = computeParaxial(*fl.lens);
  const ParaxialData& par = fl.paraxial;
  auto paraxialAt = [&](double nm) { return computeParaxial(fl.lens->atWavelength(nm)); };
  std::vector<double> out;
  for (const Operand& o : job.operands) {
    double v = 0;
    switch (o.kind) {
      case Operand::Kind::Efl: v = par.effective_focal_length_mm; break;
      case Operand::Kind::FNumber: v = par.f_number; break;
      case Operand::Kind::Bfl: v = par.back_focal_length_mm; break;
      case Operand::Kind::TotalTrack: v = totalTrack(p); break;
      case Operand::Kind::RmsSpot: v = rmsSpot_mm(p, o.field_deg, o.wavelength_nm, primary, job.rings); break;
      case Operand::Kind::Distortion: {
        if (o.field_deg == 0) break;
        const double ref = par.effective_focal_length_mm * std::tan(o.field_deg * kDeg);
        v = 100 * (chiefHeight(*fl.lens, par, o.field_deg) - ref) / ref;
        break;
      }
      case Operand::Kind::LateralColor: {
        const LensSystem f = fl.lens->atWavelength(kLineF_nm), c = fl.lens->atWavelength(kLineC_nm);
        v = chiefHeight(f, computeParaxial(f), o.field_deg) -
            chiefHeight(c, computeParaxial(c), o.field_deg);
        break;
      }
      case Operand::Kind::LongitudinalColor:
        v = paraxialAt(kLineF_nm).back_focal_length_mm - paraxialAt(kLineC_nm).back_focal_length_mm;
        break;
      case Operand::Kind::Thickness: v = p.surfaces[o.surface].thickness_mm; break;
      case Operand::Kind::EdgeThickness: v = edgeThickness(p, o.surface); break;
      case Operand::Kind::ClearAperture: v = clearAperture(job, fl, par, o.surface); break;
      case Operand::Kind::ImageHeight: v = chiefHeight(*fl.lens, par, o.field_deg); break;
      case Operand::Kind::RmsWavefront:
        v = rmsWavefront_waves(p, o.field_deg, o.wavelength_nm, primary);
        break;
      case Operand::Kind::Mtf:
        v = mtfAt(p, o.field_deg,
                  o.wavelength_nm > 0 ? std::vector<double>{o.wavelength_nm} : job.wavelengths_nm,
                  primary, o.frequency, o.sagittal);
        break;
    }
    if (!std::isfinite(v)) throw Error(fmt::format("{} is not finite", o.label()));
    out.push_back(v);
  }
  return out;
}

double operandResidual(const Operand& o, double value) {
  if (o.min || o.max) {
    double ex = 0;
    if (o.min && value < *o.min) ex = *o.min - value;
    if (o.max && value > *o.max) ex = value - *o.max;
    return o.weight * ex;
  }
  return o.weight * (value - o.target);
}

}  // namespace lensim::optics::design
