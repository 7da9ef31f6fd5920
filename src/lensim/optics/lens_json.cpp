// JSON lens files: lensim's own format, ISET3d's and lentil's database; the .dat and JSON
// writers; the lens catalogue.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/lens_formats.h"

namespace lensim::optics {

using nlohmann::json;

std::vector<size_t> arrayElementOffsets(std::string_view text, std::string_view key,
                                        int occurrence) {
  std::vector<size_t> out;
  int depth = 0;
  int found = -1;
  int array_depth = -1;
  std::string last_string;
  bool last_was_key = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      size_t j = i + 1;
      std::string s;
      while (j < text.size() && text[j] != '"') {
        if (text[j] == '\\' && j + 1 < text.size()) ++j;
        s += text[j++];
      }
      i = j;
      last_string = s;
      // A key if the next non-space character is ':'.
      size_t k = j + 1;
      while (k < text.size() && std::isspace(static_cast<unsigned char>(text[k]))) ++k;
      last_was_key = k < text.size() && text[k] == ':';
      continue;
    }
    if (c == '[') {
      ++depth;
      if (array_depth < 0 && last_was_key && last_string == key) {
        if (++found == occurrence) array_depth = depth;
      }
      last_was_key = false;
    } else if (c == ']') {
      if (depth == array_depth) return out;
      --depth;
    } else if (c == '{') {
      if (array_depth >= 0 && depth == array_depth) out.push_back(i);
      ++depth;
    } else if (c == '}') {
      --depth;
    } else if (c == ',') {
      last_was_key = false;
    }
  }
  return out;
}

FileLoc locAt(std::string_view text, size_t offset, const std::string& path) {
  int line = 1, col = 1;
  for (size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line, col = 1;
    } else {
      ++col;
    }
  }
  return FileLoc{path, line, col};
}

namespace {

// Where a key of the top-level object is written (its quote), for errors about its value.
FileLoc keyLoc(std::string_view text, std::string_view key, const std::string& path) {
  int depth = 0;
  bool in_string = false;
  size_t start = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') {
        ++i;
      } else if (c == '"') {
        in_string = false;
        if (depth == 1 && text.substr(start + 1, i - start - 1) == key)
          return locAt(text, start, path);
      }
    } else if (c == '"') {
      in_string = true;
      start = i;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
  return FileLoc{path, 1, 1};
}

double getNumber(const json& j, const char* key, const FileLoc& loc, const char* what) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_number())
    throw Error(loc, fmt::format("{}: expected a number for \"{}\"{}", what, key,
                                 it == j.end() ? " (missing)" : ""));
  const double v = it->get<double>();
  if (!std::isfinite(v)) throw Error(loc, fmt::format("{}: \"{}\" must be finite", what, key));
  return v;
}

std::optional<double> optNumber(const json& j, const char* key, const FileLoc& loc,
                                const char* what) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::nullopt;
  return getNumber(j, key, loc, what);
}

// `mirrors`: the mirrors up to and including this surface (thicknesses are signed z distances:
// negative after an odd number of them).
void checkSurface(const LensSurface& s, int index, int mirrors = 0) {
  if (s.thickness_mm * (mirrors % 2 ? -1 : 1) < 0)
    throw Error(s.loc,
                fmt::format("surface {}: thickness {} mm is {} after {} mirror{} (the "
                            "next surface must lie the way the light travels: +z, -z "
                            "after an odd number of mirrors)",
                            index, s.thickness_mm, s.thickness_mm < 0 ? "negative" : "positive",
                            mirrors, mirrors == 1 ? "" : "s"));
  if (!(s.obscuration_radius_mm >= 0) ||
      (s.obscuration_radius_mm > 0 && !(s.obscuration_radius_mm < s.semiAperture_mm())))
    throw Error(s.loc, fmt::format("surface {}: obscuration radius {} mm must be >= 0 and "
                                   "smaller than the semi-aperture {} mm",
                                   index, s.obscuration_radius_mm, s.semiAperture_mm()));
  if (!(s.aperture_diameter_mm > 0))
    throw Error(s.loc, fmt::format("surface {}: the clear aperture must be > 0 (found semi-"
                                   "aperture {} mm)",
                                   index, s.aperture_diameter_mm / 2));
  if (s.ior < 1)
    throw Error(s.loc,
                fmt::format("surface {}: index of refraction {} is not physical", index, s.ior));
  if (s.semiAperture_mm() >= sagDomainRadius(s.radius_mm, s.shape))
    throw Error(s.loc, fmt::format("surface {}: semi-aperture {} mm exceeds the surface's "
                                   "extent",
                                   index, s.semiAperture_mm()));
}

// A JSON object key naming a surface index ("0", "12"); -1 when it is not a whole number >= 0.
int surfaceIndexKey(const std::string& k) {
  size_t used = 0;
  int index = -1;
  try {
    index = std::stoi(k, &used);
  } catch (...) {
    return -1;
  }
  return used == k.size() ? index : -1;
}

// lensim JSON "configurations" (a zoom): an array of objects, each overriding surfaces by their
// 0-based index: {"name": "wide", "thickness_mm": {"4": 2.604}, "semi_aperture_mm": {...},
// "radius_mm": {...}}; "active_configuration" (1-based) says which one "surfaces" shows.
void readLensimConfigurations(const json& j, std::string_view text, const std::string& path,
                              LensPrescription& p) {
  auto it = j.find("configurations");
  if (it == j.end()) return;
  const FileLoc top{path, 1, 1};
  if (!it->is_array() || it->empty())
    throw Error(top, "\"configurations\" must be a non-empty array of objects");
  const auto offs = arrayElementOffsets(text, "configurations");
  for (size_t c = 0; c < it->size(); ++c) {
    const json& e = (*it)[c];
    const FileLoc loc = c < offs.size() ? locAt(text, offs[c], path) : top;
    if (!e.is_object())
      throw Error(loc, fmt::format("configuration {}: expected an object", c + 1));
    LensConfiguration cfg;
    cfg.loc = loc;
    cfg.surfaces = p.surfaces;
    cfg.object_distance_mm = p.object_distance_mm;
    for (const auto& [key, value] : e.items()) {
      if (key == "name") continue;
      if (key != "thickness_mm" && key != "semi_aperture_mm" && key != "radius_mm")
        throw Error(loc, fmt::format("configuration {}: \"{}\" is not supported (a "
                                     "configuration sets \"thickness_mm\", "
                                     "\"semi_aperture_mm\" and \"radius_mm\" by surface index)",
                                     c + 1, key));
      if (!value.is_object())
        throw Error(loc, fmt::format("configuration {}: \"{}\" must map surface indices "
                                     "(\"0\", \"1\", ...) to numbers",
                                     c + 1, key));
      for (const auto& [k, v] : value.items()) {
        const int index = surfaceIndexKey(k);
        if (index < 0 || index >= int(p.surfaces.size()))
          throw Error(loc, fmt::format("configuration {}: \"{}\": surface index \"{}\" is not "
                                       "0 to {}",
                                       c + 1, key, k, p.surfaces.size() - 1));
        if (!v.is_number() || !std::isfinite(v.get<double>()))
          throw Error(loc, fmt::format("configuration {}: \"{}\" of surface {}: expected a "
                                       "number",
                                       c + 1, key, index));
        LensSurface& s = cfg.surfaces[size_t(index)];
        const double x = v.get<double>();
        if (key == "thickness_mm")
          s.thickness_mm = x;
        else if (key == "semi_aperture_mm")
          s.aperture_diameter_mm = 2 * x;
        else
          s.radius_mm = x;
      }
    }
    int mirrors = 0;
    for (size_t i = 0; i < cfg.surfaces.size(); ++i) {
      mirrors += cfg.surfaces[i].mirror ? 1 : 0;
      try {
        checkSurface(cfg.surfaces[i], int(i), mirrors);
      } catch (const Error& err) {
        throw Error(loc, fmt::format("configuration {}: {}", c + 1, err.message()));
      }
    }
    p.configurations.push_back(std::move(cfg));
  }
  if (auto a = j.find("active_configuration"); a != j.end()) {
    if (!a->is_number_integer() || a->get<int>() < 1 || a->get<int>() > int(it->size()))
      throw Error(top, fmt::format("\"active_configuration\" must be 1 to {}", it->size()));
    p.active_configuration = a->get<int>();
  }
  if (p.configurations.size() == 1) p.configurations.clear();  // nothing to choose
}

// lensim JSON "focus_group": surface index -> rate (mm of thickness per mm of group travel).
void readLensimFocusGroup(const json& j, const std::string& path, LensPrescription& p) {
  auto it = j.find("focus_group");
  if (it == j.end()) return;
  const FileLoc top{path, 1, 1};
  if (!it->is_object() || it->empty())
    throw Error(top, "\"focus_group\" must map surface indices (\"4\") to rates (1, -1)");
  for (const auto& [k, v] : it->items()) {
    const int index = surfaceIndexKey(k);
    if (index < 0 || index + 1 >= int(p.surfaces.size()))
      throw Error(top, fmt::format("\"focus_group\": \"{}\" is not a gap between surfaces "
                                   "(0 to {})",
                                   k, int(p.surfaces.size()) - 2));
    if (!v.is_number() || v.get<double>() == 0 || !std::isfinite(v.get<double>()))
      throw Error(top, fmt::format("\"focus_group\": \"{}\": expected a non-zero rate", k));
    p.focus_group.emplace_back(index, v.get<double>());
  }
}

// The configurations as lensim JSON: each configuration's differences from `surfaces`.
json lensimConfigurationsJson(const LensPrescription& p) {
  json arr = json::array();
  for (const LensConfiguration& c : p.configurations) {
    json e = json::object(), t = json::object(), a = json::object(), r = json::object();
    for (size_t i = 0; i < c.surfaces.size() && i < p.surfaces.size(); ++i) {
      const LensSurface &x = c.surfaces[i], &base = p.surfaces[i];
      if (x.thickness_mm != base.thickness_mm) t[std::to_string(i)] = x.thickness_mm;
      if (x.aperture_diameter_mm != base.aperture_diameter_mm)
        a[std::to_string(i)] = x.semiAperture_mm();
      if (x.radius_mm != base.radius_mm) r[std::to_string(i)] = x.radius_mm;
    }
    if (!t.empty()) e["thickness_mm"] = t;
    if (!a.empty()) e["semi_aperture_mm"] = a;
    if (!r.empty()) e["radius_mm"] = r;
    arr.push_back(e);
  }
  return arr;
}

LensPrescription parseLensim(const json& j, std::string_view text, const std::string& path) {
  LensPrescription p;
  p.path = path;
  p.format = "lensim-json";
  p.name = j.value("name", std::filesystem::path(path).stem().string());
  if (j.contains("units") && j["units"] != "mm")
    throw Error(FileLoc{path, 1, 1}, "\"units\" must be \"mm\"");
  if (auto w = j.find("wavelengths_nm"); w != j.end() && w->is_array())
    for (const auto& v : *w) p.wavelengths_nm.push_back(v.get<double>());
  if (auto w = j.find("primary_wavelength_nm"); w != j.end() && w->is_number())
    p.primary_wavelength_nm = w->get<double>();
  if (auto w = j.find("object_distance_mm"); w != j.end() && w->is_number())
    p.object_distance_mm = w->get<double>();
  const FileLoc top{path, 1, 1};
  if (auto c = j.find("coating"); c != j.end()) {
    if (!c->is_string())
      throw Error(top, "\"coating\" (the lens-wide default) must be a coating name: "
                       "\"uncoated\", \"single\", \"multi\" or one of the coating file's");
    p.default_coating = c->get<std::string>();
    p.default_coating_loc = keyLoc(text, "coating", path);
  }
  if (auto c = j.find("coating_file"); c != j.end()) {
    if (!c->is_string()) throw Error(top, "\"coating_file\" must be a path");
    // Relative to the lens file's folder.
    p.coating_file =
        (std::filesystem::path(path).parent_path() / c->get<std::string>()).lexically_normal().string();
    p.coating_file_loc = keyLoc(text, "coating_file", path);
  }
  const auto offs = arrayElementOffsets(text, "surfaces");
  const json& surfs = j.at("surfaces");
  int mirrors = 0;
  for (size_t i = 0; i < surfs.size(); ++i) {
    const json& e = surfs[i];
    LensSurface s;
    s.loc = i < offs.size() ? locAt(text, offs[i], path) : FileLoc{path, 1, 1};
    if (!e.is_object()) throw Error(s.loc, fmt::format("surface {}: expected an object", i));
    const char* what = "surface";
    s.radius_mm = getNumber(e, "radius_mm", s.loc, what);
    s.thickness_mm = getNumber(e, "thickness_mm", s.loc, what);
    s.aperture_diameter_mm = 2 * getNumber(e, "semi_aperture_mm", s.loc, what);
    s.ior = optNumber(e, "ior", s.loc, what).value_or(1.0);
    s.stop_flag = e.value("stop", false);
    s.shape.conic = optNumber(e, "conic", s.loc, what).value_or(0.0);
    s.shape.radius_x_mm = optNumber(e, "radius_x_mm", s.loc, what);
    s.shape.conic_x = optNumber(e, "conic_x", s.loc, what).value_or(0.0);
    if (auto a = e.find("aspheric"); a != e.end()) {
      if (!a->is_object())
        throw Error(s.loc, "\"aspheric\" must map powers (\"4\", \"6\", ...) to coefficients");
      for (const auto& [k, v] : a->items()) {
        int pw = 0;
        try {
          pw = std::stoi(k);
        } catch (...) {
          pw = 0;
        }
        if (pw < 1 || pw > 40 || !v.is_number())
          throw Error(s.loc, fmt::format("aspheric term \"{}\": expected a power 1..40 mapped "
                                         "to a number",
                                         k));
        if (s.shape.poly.size() <= size_t(pw)) s.shape.poly.resize(size_t(pw) + 1, 0.0);
        s.shape.poly[size_t(pw)] = v.get<double>();
      }
    }
    s.shape.rotation_radius_mm = optNumber(e, "rotation_radius_mm", s.loc, what);
    if (s.shape.isToroidal()) {
      if (s.shape.radius_x_mm || s.shape.conic_x != 0)
        throw Error(s.loc, fmt::format("surface {}: \"rotation_radius_mm\" (a toroid) and "
                                       "\"radius_x_mm\"/\"conic_x\" (a biconic) exclude each "
                                       "other",
                                       i));
      for (size_t pw = 1; pw < s.shape.poly.size(); pw += 2)
        if (s.shape.poly[pw] != 0)
          throw Error(s.loc, fmt::format("surface {}: aspheric term \"{}\": a toroid's y-curve "
                                         "terms are even powers of y",
                                         i, pw));
    }
    if (auto g = e.find("glass"); g != e.end() && g->is_object()) {
      s.glass.name = g->value("name", "");
      s.glass.n_d = optNumber(*g, "n_d", s.loc, "glass");
      s.glass.v_d = optNumber(*g, "v_d", s.loc, "glass");
      s.glass.loc = s.loc;
      if (!e.contains("ior") && s.glass.n_d) s.ior = *s.glass.n_d;
    }
    s.obscuration_radius_mm = optNumber(e, "obscuration_radius_mm", s.loc, what).value_or(0.0);
    if (auto c = e.find("coating"); c != e.end()) {
      if (!c->is_string())
        throw Error(s.loc, fmt::format("surface {}: \"coating\" must be a coating name", i));
      s.coating = c->get<std::string>();
      s.coating_loc = s.loc;
    }
    if (auto m = e.find("mirror"); m != e.end()) {
      if (!m->is_boolean())
        throw Error(s.loc, fmt::format("surface {}: \"mirror\" must be true or false", i));
      s.mirror = m->get<bool>();
    }
    if (s.mirror) {
      // The light goes back through the medium it came from; an "ior" or "glass" on a mirror
      // must name that medium.
      const double before = p.surfaces.empty() ? 1.0 : p.surfaces.back().ior;
      if (e.contains("ior") && s.ior != before)
        throw Error(s.loc, fmt::format("surface {} is a mirror: its \"ior\" {} must be the "
                                       "index before it ({}) or be left out",
                                       i, s.ior, before));
      s.ior = before;
      s.glass = p.surfaces.empty() ? GlassSpec{} : p.surfaces.back().glass;
      ++mirrors;
    }
    checkSurface(s, int(i), mirrors);
    p.surfaces.push_back(s);
  }
  // Unknown coating names are refused here, at their line.
  resolveCoatings(p);

  readLensimConfigurations(j, text, path, p);
  readLensimFocusGroup(j, path, p);
  return p;
}

// ISET3d / isetlens: {"name", "description", "type", "surfaces": [{radius, thickness, ior,
// semi_aperture}]} in millimetres; radius 0 is the stop (ior 0 there means air), as in .dat.
LensPrescription parseIset(const json& j, std::string_view text, const std::string& path) {
  LensPrescription p;
  p.path = path;
  p.format = "iset-json";
  p.name = j.value("name", std::filesystem::path(path).stem().string());
  const auto offs = arrayElementOffsets(text, "surfaces");
  const json& surfs = j.at("surfaces");
  bool stop_seen = false;
  for (size_t i = 0; i < surfs.size(); ++i) {
    const json& e = surfs[i];
    LensSurface s;
    s.loc = i < offs.size() ? locAt(text, offs[i], path) : FileLoc{path, 1, 1};
    if (!e.is_object()) throw Error(s.loc, fmt::format("surface {}: expected an object", i));
    s.radius_mm = getNumber(e, "radius", s.loc, "surface");
    s.thickness_mm = getNumber(e, "thickness", s.loc, "surface");
    const double n = getNumber(e, "ior", s.loc, "surface");
    s.ior = n == 0 ? 1.0 : n;
    s.aperture_diameter_mm = 2 * getNumber(e, "semi_aperture", s.loc, "surface");
    if (auto k = optNumber(e, "conic_constant", s.loc, "surface")) s.shape.conic = *k;
    if (s.radius_mm == 0) {
      if (stop_seen) throw Error(s.loc, "second aperture stop (radius 0)");
      stop_seen = true;
    }
    checkSurface(s, int(i));
    p.surfaces.push_back(s);
  }
  return p;
}

// lentil (zpelgrims/lentil, polynomial-optics/database/lenses.json): one design per key.
LensPrescription parseLentil(const json& db, std::string_view text, const std::string& path,
                             const std::string& key) {
  auto it = db.find(key);
  if (it == db.end()) {
    std::string keys;
    for (const auto& [k, v] : db.items()) keys += (keys.empty() ? "" : ", ") + k;
    throw Error(FileLoc{path, 1, 1},
                fmt::format("lentil database has no lens '{}'; it has {}", key, keys));
  }
  const json& lens = *it;
  LensPrescription p;
  p.path = path;
  p.format = "lentil";
  p.name = fmt::format(
      "lentil {} {} {} {}", key, lens.value("company", ""), lens.value("product-name", ""),
      lens.contains("year") && lens["year"].is_number() ? std::to_string(lens["year"].get<int>())
                                                        : std::string());
  const char* elements_key = lens.contains("optical-elements-adjusted")
                                 ? "optical-elements-adjusted"
                                 : "optical-elements-patent";
  // Locations: the element arrays of this design, found after the design's key in the text.
  size_t design_pos = text.find("\"" + key + "\"");
  std::vector<size_t> offs;
  if (design_pos != std::string_view::npos) {
    offs = arrayElementOffsets(text.substr(design_pos), elements_key);
    for (auto& o : offs) o += design_pos;
  }
  const json& els = lens.at(elements_key);
  const FileLoc design_loc =
      design_pos != std::string_view::npos ? locAt(text, design_pos, path) : FileLoc{path, 1, 1};
  if (!els.is_array() || els.empty())
    throw Error(design_loc, fmt::format("lentil lens {}: no optical elements", key));
  // The database's legend reserves keys 1500-1999 for zooms, but its designs carry one set of
  // thicknesses each (docs/zoom.md): a design marked as a zoom would be read at one unknown
  // position, so it is refused.
  if (auto prime = lens.find("prime"); prime != lens.end() && prime->is_boolean() && !*prime)
    throw Error(design_loc, fmt::format("lentil lens {} is marked \"prime\": false (a zoom); "
                                        "lentil's database carries one set of thicknesses per "
                                        "design and no zoom positions for lensim to read",
                                        key));
  bool stop_seen = false;
  for (size_t i = 0; i < els.size(); ++i) {
    const json& e = els[i];
    LensSurface s;
    s.loc = i < offs.size() ? locAt(text, offs[i], path) : design_loc;
    const std::string material = e.value("material", "");
    const std::string geometry = e.value("lens-geometry", "spherical");
    const double R = getNumber(e, "radius", s.loc, "element");
    s.thickness_mm = getNumber(e, "thickness", s.loc, "element");
    s.aperture_diameter_mm = 2 * getNumber(e, "housing-radius", s.loc, "element");
    const auto ior = optNumber(e, "ior", s.loc, "element");
    const auto abbe = optNumber(e, "abbe", s.loc, "element");
    const bool iris = material == "iris" || material == "IRIS";
    s.stop_flag = iris;
    if (iris) {
      if (stop_seen) throw Error(s.loc, "second iris (aperture stop)");
      stop_seen = true;
      s.radius_mm = 0;  // lentil writes the iris as a huge radius
    } else if (geometry == "spherical" || geometry == "aspherical") {
      s.radius_mm = R;
    } else if (geometry == "cyl-y") {
      // A cylinder with its axis along y: curved in the x-z section (Hanika & Dachsbacher's
      // lens-system convention, which lentil follows), flat in y.
      s.radius_mm = 0;
      s.shape.radius_x_mm = R;
    } else if (geometry == "cyl-x") {
      s.radius_mm = R;
      s.shape.radius_x_mm = 0.0;
    } else {
      throw Error(s.loc, fmt::format("element {}: lens-geometry '{}' is not supported (expected "
                                     "spherical, aspherical, cyl-x or cyl-y)",
                                     i, geometry));
    }
    if (geometry == "aspherical") {
      auto a = e.find("aspherical-equation");
      if (a == e.end() || !a->is_array())
        throw Error(s.loc, fmt::format("element {}: aspherical without aspherical-equation", i));
      // lentil's even asphere: coefficients of r^4, r^6, r^8, r^10 (conic 0).
      s.shape.poly.assign(11, 0.0);
      int power = 4;
      for (const auto& c : *a) {
        if (power > 10 || !c.is_number())
          throw Error(s.loc, fmt::format("element {}: expected up to 4 aspheric coefficients", i));
        s.shape.poly[size_t(power)] = c.get<double>();
        power += 2;
      }
    }
    const bool air = material == "air" || iris || !ior || *ior == 0 || *ior == 1;
    if (air) {
      s.ior = 1;
    } else {
      s.ior = *ior;
      s.glass.name = material == "abbe" ? std::string() : material;
      s.glass.n_d = *ior;
      if (abbe && *abbe > 0) s.glass.v_d = *abbe;
      s.glass.loc = s.loc;
    }
    // lentil's database has a few housings wider than their sphere (0015): clamp, with a warning.
    const double domain = sagDomainRadius(s.radius_mm, s.shape);
    if (s.semiAperture_mm() >= domain) {
      p.diagnostics.push_back(
          {Severity::Warning, s.loc,
           fmt::format("element {}: housing radius {} mm is wider than the surface (radius {} "
                       "mm); clamped to {:.6g} mm",
                       i, s.semiAperture_mm(), domain, 0.999 * domain)});
      s.aperture_diameter_mm = 2 * 0.999 * domain;
    }
    checkSurface(s, int(i));
    p.surfaces.push_back(s);
  }
  if (lens.contains("focal-length-mm-patent") && lens["focal-length-mm-patent"].is_number())
    p.nominal_focal_length_mm = lens["focal-length-mm-patent"].get<double>();
  return p;
}

}  // namespace

LensPrescription parseLensJson(std::string_view text, const std::string& path,
                               const std::string& lentil_key) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw Error(locAt(text, e.byte > 0 ? e.byte - 1 : 0, path),
                fmt::format("malformed JSON: {}", e.what()));
  } catch (const json::exception& e) {
    // Other parse failures (a number too large for a double: out_of_range.406) carry no byte
    // position; their message quotes the token, located at its first occurrence.
    const std::string what = e.what();
    size_t at = std::string::npos;
    if (const size_t q0 = what.find('\''); q0 != std::string::npos)
      if (const size_t q1 = what.find('\'', q0 + 1); q1 != std::string::npos && q1 > q0 + 1)
        at = text.find(what.substr(q0 + 1, q1 - q0 - 1));
    throw Error(at != std::string::npos ? locAt(text, at, path) : FileLoc{path, 1, 1},
                fmt::format("malformed JSON: {}", what));
  }
  if (!j.is_object()) throw Error(FileLoc{path, 1, 1}, "expected a JSON object");
  try {
    if (!lentil_key.empty()) return parseLentil(j, text, path, lentil_key);
    if (j.value("format", "") == "lensim-lens") return parseLensim(j, text, path);
    if (j.contains("surfaces") && j["surfaces"].is_array()) return parseIset(j, text, path);
    // A lentil database: a single design is read directly; otherwise a key is needed.
    bool lentil = !j.empty();
    for (const auto& [k, v] : j.items())
      lentil = lentil && v.is_object() && (v.contains("optical-elements-patent"));
    if (lentil) {
      if (j.size() == 1) return parseLentil(j, text, path, j.begin().key());
      throw Error(FileLoc{path, 1, 1},
                  fmt::format("a lentil database with {} lenses: pick one with lentil:KEY "
                              "(e.g. lentil:{})",
                              j.size(), j.begin().key()));
    }
  } catch (const json::exception& e) {
    throw Error(FileLoc{path, 1, 1}, fmt::format("unexpected JSON structure: {}", e.what()));
  }
  throw Error(FileLoc{path, 1, 1},
              "unknown JSON lens format: expected lensim's (\"format\": \"lensim-lens\"), "
              "ISET3d's (\"surfaces\" with radius/thickness/ior/semi_aperture) or lentil's "
              "database");
}

namespace {

// The coaxial formats (lensim JSON, .dat) place rotationally symmetric surfaces on one axis.
void refuseNonCoaxial(const LensPrescription& p, const char* format) {
  if (p.noncoaxial_loc)
    throw Error(*p.noncoaxial_loc, fmt::format("{}: a lens with {} cannot be written as {} (it "
                                               "places rotationally symmetric surfaces on one "
                                               "axis)",
                                               p.noncoaxial_reason,
                                               firstGrating(p) ? "a diffraction grating"
                                                               : "tilted or decentred surfaces",
                                               format));
}

}  // namespace

std::string writeLensJson(const LensPrescription& p) {
  refuseNonCoaxial(p, "a lensim lens file");
  if (p.floating_focus)
    throw Error(p.floating_focus->loc, "a lens with floating focus (Zemax focus positions whose "
                                       "gaps move at different rates) cannot be written as a "
                                       "lensim lens file, which has no such data");
  json j;
  j["format"] = "lensim-lens";
  j["version"] = 1;
  j["name"] = p.name;
  j["units"] = "mm";
  if (!p.wavelengths_nm.empty()) j["wavelengths_nm"] = p.wavelengths_nm;
  if (p.primary_wavelength_nm) j["primary_wavelength_nm"] = *p.primary_wavelength_nm;
  if (p.object_distance_mm) j["object_distance_mm"] = *p.object_distance_mm;
  j["source"] = fmt::format("{} ({})", p.path, p.format);
  if (!p.default_coating.empty()) j["coating"] = p.default_coating;
  if (!p.coating_file.empty())
    j["coating_file"] = std::filesystem::absolute(p.coating_file).lexically_normal().string();
  json surfs = json::array();
  for (const LensSurface& s : p.surfaces) {
    json e;
    e["radius_mm"] = s.radius_mm;
    e["thickness_mm"] = s.thickness_mm;
    e["semi_aperture_mm"] = s.semiAperture_mm();
    e["ior"] = s.ior;
    if (s.isStop()) e["stop"] = true;
    if (s.mirror) e["mirror"] = true;
    if (s.obscuration_radius_mm > 0) e["obscuration_radius_mm"] = s.obscuration_radius_mm;
    if (s.aperture_shape != ApertureShape::Circle)
      throw Error(s.loc, fmt::format("surface {}: its {} aperture ({} x {} mm half-widths) "
                                     "cannot be written to a lens JSON file, whose apertures "
                                     "are circles",
                                     surfs.size(),
                                     s.aperture_shape == ApertureShape::Rectangle ? "rectangular"
                                                                                  : "elliptical",
                                     s.aperture_half_x_mm, s.aperture_half_y_mm));
    if (s.apertureDecentred())
      throw Error(s.loc, fmt::format("surface {}: its decentred aperture cannot be written to a "
                                     "lens JSON file, whose apertures are centred",
                                     surfs.size()));
    if (!s.coating.empty()) e["coating"] = s.coating;
    if (s.shape.conic != 0) e["conic"] = s.shape.conic;
    if (s.shape.radius_x_mm) e["radius_x_mm"] = *s.shape.radius_x_mm;
    if (s.shape.conic_x != 0) e["conic_x"] = s.shape.conic_x;
    if (s.shape.rotation_radius_mm) e["rotation_radius_mm"] = *s.shape.rotation_radius_mm;
    if (s.shape.hasPolynomial()) {
      json a = json::object();
      for (size_t k = 1; k < s.shape.poly.size(); ++k)
        if (s.shape.poly[k] != 0) a[std::to_string(k)] = s.shape.poly[k];
      e["aspheric"] = a;
    }
    if (!s.glass.empty() || s.glass.n_d) {
      json g;
      if (!s.glass.name.empty()) g["name"] = s.glass.name;
      if (s.glass.n_d) g["n_d"] = *s.glass.n_d;
      if (s.glass.v_d) g["v_d"] = *s.glass.v_d;
      e["glass"] = g;
    }
    surfs.push_back(e);
  }
  j["surfaces"] = surfs;
  if (!p.focus_group.empty()) {
    json g = json::object();
    for (const auto& [row, rate] : p.focus_group) g[std::to_string(row)] = rate;
    j["focus_group"] = g;
  }
  if (!p.configurations.empty()) {
    j["configurations"] = lensimConfigurationsJson(p);
    j["active_configuration"] = p.active_configuration;
  }
  return j.dump(2) + "\n";
}

std::string writeLensDat(const LensPrescription& p) {
  refuseNonCoaxial(p, "a .dat file");
  std::string out =
      fmt::format("# {}\n# converted by lensim from {} ({})\n", p.name, p.path, p.format);
  out +=
      "# radius thickness index aperture (mm; planes that are not the stop are written as "
      "radius 1e9)\n";
  int stops = 0;
  for (size_t i = 0; i < p.surfaces.size(); ++i) {
    const LensSurface& s = p.surfaces[i];
    if (s.mirror)
      throw Error(s.loc, fmt::format("surface {} cannot be written to .dat: it is a mirror (the "
                                     ".dat format has refracting surfaces only); write .json "
                                     "instead",
                                     i));
    if (s.aperture_shape != ApertureShape::Circle)
      throw Error(s.loc, fmt::format("surface {} cannot be written to .dat: its aperture is not "
                                     "a circle (Zemax SQAP/ELAP)",
                                     i));
    if (s.obscuration_radius_mm > 0)
      throw Error(s.loc, fmt::format("surface {} cannot be written to .dat: it has a central "
                                     "obscuration (radius {} mm) that .dat cannot hold; write "
                                     ".json instead",
                                     i, s.obscuration_radius_mm));
    if (!s.shape.isSpherical())
      throw Error(s.loc, fmt::format("surface {} cannot be written to .dat: it is {} (the .dat "
                                     "format has spheres only); write .json instead",
                                     i,
                                     s.shape.isToroidal()  ? "toroidal"
                                     : s.shape.radius_x_mm ? "cylindrical/biconic"
                                                           : "aspheric (conic or polynomial)"));
    double radius = s.radius_mm;
    if (s.isStop()) {
      if (s.radius_mm != 0)
        throw Error(s.loc,
                    fmt::format("surface {} cannot be written to .dat: the stop is curved", i));
      if (s.ior != 1 && !(i > 0 && p.surfaces[i - 1].ior == s.ior))
        throw Error(s.loc, fmt::format("surface {} cannot be written to .dat: the stop changes "
                                       "the medium",
                                       i));
      ++stops;
    } else if (radius == 0) {
      radius = 1e9;
    }
    out += fmt::format("{:.10g}\t{:.10g}\t{:.10g}\t{:.10g}", radius, s.thickness_mm,
                       s.isStop() && s.ior == 1 ? 0.0 : s.ior, s.aperture_diameter_mm);
    // Columns 5 and 6 keep the glass: a catalogue glass by name, a model glass by its V_d.
    if (s.ior != 1 && !s.isStop()) {
      const CatalogGlass* g =
          s.glass.name.empty() ? nullptr : GlassCatalog::builtin().find(s.glass.name);
      if (g)
        out += fmt::format("\t{:.6g}\t{}", g->listed_v_d, g->qualifiedName());
      else if (s.glass.v_d)
        out += fmt::format("\t{:.10g}", *s.glass.v_d);
    }
    out += "\n";
  }
  (void)stops;
  return out;
}

std::string lensCatalogueDir() {
  if (const char* env = std::getenv("LENSIM_LENSES_DIR")) return env;
#ifdef LENSIM_LENSES_DIR_DEFAULT
  return LENSIM_LENSES_DIR_DEFAULT;
#else
  return "lenses";
#endif
}

LensRef resolveLensName(const std::string& name) {
  if (name.rfind("lentil:", 0) == 0) {
    return {lensCatalogueDir() + "/lentil/lenses.json", name.substr(7)};
  }
  if (name.rfind("lenses:", 0) == 0) {
    const std::string rest = name.substr(7);
    const std::string dir = lensCatalogueDir();
    for (const char* ext : {"", ".dat", ".zmx", ".json"}) {
      const std::string candidate = dir + "/" + rest + ext;
      if (std::filesystem::is_regular_file(candidate)) return {candidate, ""};
    }
    throw Error(FileLoc{name, 0, 0},
                fmt::format("no lens '{}' in the catalogue {} (see lenses/README.md)", rest, dir));
  }
  return {name, ""};
}

}  // namespace lensim::optics
