#include "lensim/optics/coating/coating.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "lensim/util/file.h"

namespace lensim::optics {

namespace {

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = char(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

struct Tok {
  std::string_view text;
  int col = 0;
};

std::vector<Tok> tokens(std::string_view line) {
  std::vector<Tok> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i >= line.size() || line[i] == '!') break;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '!') ++j;
    out.push_back({line.substr(i, j - i), int(i) + 1});
    i = j;
  }
  return out;
}

double number(const Tok& t, const FileLoc& line_loc, const char* what) {
  double v = 0;
  const char* b = t.text.data();
  const char* e = b + t.text.size();
  auto [p, ec] = std::from_chars(b, e, v);
  if (ec != std::errc() || p != e || !std::isfinite(v))
    throw Error(FileLoc{line_loc.file, line_loc.line, t.col},
                fmt::format("expected a number for the {}, found '{}'", what, t.text));
  return v;
}

}  // namespace

CoatingMaterial CoatingMaterial::constant(std::string name, double n, double k) {
  CoatingMaterial m;
  m.name = std::move(name);
  m.lambda_nm = {550};
  m.n = {n};
  m.k = {k};
  return m;
}

ComplexIndex CoatingMaterial::index(double lambda) const {
  if (lambda_nm.size() == 1 || lambda <= lambda_nm.front()) return {n.front(), k.front()};
  if (lambda >= lambda_nm.back()) return {n.back(), k.back()};
  const size_t i = size_t(std::upper_bound(lambda_nm.begin(), lambda_nm.end(), lambda) -
                          lambda_nm.begin());
  const double t = (lambda - lambda_nm[i - 1]) / (lambda_nm[i] - lambda_nm[i - 1]);
  return {n[i - 1] + t * (n[i] - n[i - 1]), k[i - 1] + t * (k[i] - k[i - 1])};
}

CoatingLibrary::CoatingLibrary() {
  const int mgf2 = addMaterial(CoatingMaterial::constant("MGF2", 1.38));
  const int zro2 = addMaterial(CoatingMaterial::constant("ZRO2", 2.05));
  const int al2o3 = addMaterial(CoatingMaterial::constant("AL2O3", 1.63));
  coatings_["UNCOATED"] = Coating{"uncoated", {}, 550, {}};
  coatings_["SINGLE"] = Coating{"single", {{mgf2, 0.25, false}}, 550, {}};
  coatings_["MULTI"] =
      Coating{"multi", {{mgf2, 0.25, false}, {zro2, 0.5, false}, {al2o3, 0.25, false}}, 510, {}};
}

int CoatingLibrary::addMaterial(CoatingMaterial m) {
  const std::string key = upper(m.name);
  if (auto it = material_by_name_.find(key); it != material_by_name_.end()) {
    materials_[size_t(it->second)] = std::move(m);
    return it->second;
  }
  materials_.push_back(std::move(m));
  material_by_name_[key] = int(materials_.size() - 1);
  return int(materials_.size() - 1);
}

void CoatingLibrary::readZemaxCoatingFile(const std::string& path) {
  addZemaxCoatingFile(readRegularFile(path, "coating file", uint64_t{16} << 20), path);
}

void CoatingLibrary::addZemaxCoatingFile(std::string_view text, const std::string& path) {
  CoatingMaterial* mate = nullptr;
  Coating* coat = nullptr;
  // Layers name materials that may be defined further down: resolved at the end.
  struct PendingLayer {
    std::string coating, material;
    FileLoc loc;
  };
  std::vector<PendingLayer> pending;
  std::vector<CoatingMaterial> new_materials;
  std::set<std::string> coats_here;
  int line_no = 0;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    ++line_no;
    pos = end + 1;
    const std::vector<Tok> t = tokens(line);
    if (t.empty()) continue;
    const FileLoc loc{path, line_no, t[0].col};
    const std::string key = upper(t[0].text);
    if (key == "MATE" || key == "COAT") {
      if (t.size() != 2)
        throw Error(loc, fmt::format("{} takes one name (found {} words)", key, t.size() - 1));
      if (key == "MATE") {
        new_materials.push_back(CoatingMaterial{std::string(t[1].text), {}, {}, {}, loc});
        mate = &new_materials.back();
        coat = nullptr;
      } else {
        if (!coats_here.insert(upper(t[1].text)).second)
          throw Error(loc, fmt::format("coating {} is defined twice in this file", t[1].text));
        Coating c{std::string(t[1].text), {}, 0, loc};
        coat = &(coatings_[upper(t[1].text)] = std::move(c));
        mate = nullptr;
      }
      continue;
    }
    if (key == "TAPR" || key == "ENCI" || key == "TABLE" || key == "IDEAL" || key == "IDEAL2")
      throw Error(loc, fmt::format("Zemax coating block {} is not supported (lensim reads MATE "
                                   "and COAT blocks)",
                                   key));
    if (mate) {
      if (t.size() != 3 && t.size() != 2)
        throw Error(loc, fmt::format("material {}: expected 'wavelength_um n k', found {} values",
                                     mate->name, t.size()));
      const double w = number(t[0], loc, "wavelength (um)");
      const double n = number(t[1], loc, "index n");
      const double k = t.size() == 3 ? number(t[2], loc, "extinction k") : 0.0;
      if (!(w > 0.1 && w < 100))
        throw Error(loc, fmt::format("material {}: wavelength {} um is outside 0.1..100 um",
                                     mate->name, w));
      if (!mate->lambda_nm.empty() && !(w * 1000 > mate->lambda_nm.back()))
        throw Error(loc, fmt::format("material {}: wavelength {} um does not ascend",
                                     mate->name, w));
      if (!(n > 0) || !(k >= 0))
        throw Error(loc, fmt::format("material {}: index n = {} must be > 0 and k = {} >= 0",
                                     mate->name, n, k));
      mate->lambda_nm.push_back(w * 1000);
      mate->n.push_back(n);
      mate->k.push_back(k);
    } else if (coat) {
      if (t.size() < 2 || t.size() > 3)
        throw Error(loc, fmt::format("coating {}: expected 'MATERIAL thickness [is_absolute]', "
                                     "found {} words",
                                     coat->name, t.size()));
      CoatingLayer l;
      l.thickness = number(t[1], loc, "layer thickness");
      if (t.size() == 3) {
        const double a = number(t[2], loc, "is_absolute flag");
        if (a != 0 && a != 1)
          throw Error(FileLoc{path, line_no, t[2].col},
                      fmt::format("is_absolute must be 0 or 1, found '{}'", t[2].text));
        l.absolute = a == 1;
      }
      if (!(l.thickness >= 0) || l.thickness > 1000)
        throw Error(FileLoc{path, line_no, t[1].col},
                    fmt::format("coating {}: layer thickness {} must be between 0 and 1000 {}",
                                coat->name, l.thickness, l.absolute ? "um" : "waves"));
      if (l.absolute) l.thickness *= 1000;  // um -> nm
      coat->layers.push_back(l);
      pending.push_back({upper(coat->name), std::string(t[0].text), loc});
    } else {
      throw Error(loc, fmt::format("'{}' outside a MATE or COAT block", t[0].text));
    }
  }
  for (CoatingMaterial& m : new_materials) {
    if (m.lambda_nm.empty())
      throw Error(m.loc, fmt::format("material {} has no 'wavelength_um n k' rows", m.name));
    addMaterial(std::move(m));
  }
  std::map<std::string, size_t> next_layer;
  for (const PendingLayer& pl : pending) {
    Coating& c = coatings_[pl.coating];
    const size_t i = next_layer[pl.coating]++;
    auto it = material_by_name_.find(upper(pl.material));
    if (it == material_by_name_.end())
      throw Error(pl.loc, fmt::format("coating {}: unknown material '{}' (define it in a MATE "
                                      "block)",
                                      c.name, pl.material));
    c.layers[i].material = it->second;
  }
}

const Coating* CoatingLibrary::find(std::string_view name) const {
  auto it = coatings_.find(upper(name));
  return it == coatings_.end() ? nullptr : &it->second;
}

std::vector<std::string> CoatingLibrary::names() const {
  std::vector<std::string> out;
  for (const auto& [k, c] : coatings_) out.push_back(c.name);
  std::sort(out.begin(), out.end());
  return out;
}

void CoatingLibrary::fillLayers(const Coating& c, double lambda_nm, double fallback_design_nm,
                                bool reversed, FilmLayer* out) const {
  const double design = c.design_wavelength_nm > 0 ? c.design_wavelength_nm : fallback_design_nm;
  const size_t q = c.layers.size();
  for (size_t i = 0; i < q; ++i) {
    const CoatingLayer& l = c.layers[i];
    const CoatingMaterial& m = materials_[size_t(l.material)];
    const double d = l.absolute ? l.thickness : l.thickness * design / m.index(design).real();
    out[reversed ? q - 1 - i : i] = {m.index(lambda_nm), d};
  }
}

std::vector<FilmLayer> CoatingLibrary::layersAt(const Coating& c, double lambda_nm,
                                                double fallback_design_nm) const {
  std::vector<FilmLayer> out(c.layers.size());
  fillLayers(c, lambda_nm, fallback_design_nm, false, out.data());
  return out;
}

FilmRTA CoatingLibrary::interfaceRTA(const Coating* c, double n_before, double n_after,
                                     double lambda_nm, double cos_i,
                                     double fallback_design_nm) const {
  FilmRTA out;
  interfaceRTASpectral(c, n_before, n_after, {&lambda_nm, 1}, cos_i, fallback_design_nm, &out);
  return out;
}

void CoatingLibrary::interfaceRTASpectral(const Coating* c, double n_before, double n_after,
                                          std::span<const double> lambda_nm, double cos_i,
                                          double fallback_design_nm, FilmRTA* out) const {
  if (!c || c->layers.empty() || n_before == n_after) {
    const FilmRTA f =
        n_before == n_after ? FilmRTA{0, 1, 0} : fresnelDielectric(n_before, n_after, cos_i);
    std::fill(out, out + lambda_nm.size(), f);
    return;
  }
  // Called for every coated crossing of every camera ray with flare: the layers of an ordinary
  // coating go in a buffer on the stack rather than a heap allocation.
  constexpr size_t kStackLayers = 16;
  std::array<FilmLayer, kStackLayers> buf;
  std::vector<FilmLayer> heap;
  FilmLayer* layers = buf.data();
  if (c->layers.size() > kStackLayers) {
    heap.resize(c->layers.size());
    layers = heap.data();
  }
  const std::span<const FilmLayer> stack(layers, c->layers.size());
  const bool reversed = n_before > n_after;
  const bool dispersive = std::any_of(c->layers.begin(), c->layers.end(), [&](const auto& l) {
    return materials_[size_t(l.material)].lambda_nm.size() > 1;
  });
  if (!dispersive) {
    fillLayers(*c, lambda_nm[0], fallback_design_nm, reversed, layers);
    thinFilmStackSpectral(n_before, stack, n_after, lambda_nm, cos_i, out);
    return;
  }
  for (size_t w = 0; w < lambda_nm.size(); ++w) {
    fillLayers(*c, lambda_nm[w], fallback_design_nm, reversed, layers);
    out[w] = thinFilmStack(n_before, stack, n_after, lambda_nm[w], cos_i);
  }
}

}  // namespace lensim::optics
