#include "lensim/optics/coating/lens_coatings.h"

#include <filesystem>

#include <fmt/format.h>

#include "lensim/optics/glass.h"
#include "lensim/optics/lens_system.h"

namespace lensim::optics {

FilmRTA LensCoatings::rta(int k, double n_before, double n_after, double lambda_nm,
                          double cos_i) const {
  return library->interfaceRTA(coating[size_t(k)], n_before, n_after, lambda_nm, cos_i,
                               design_wavelength_nm);
}

void LensCoatings::rtaSpectral(int k, double n_before, double n_after,
                               std::span<const double> lambda_nm, double cos_i,
                               FilmRTA* out) const {
  library->interfaceRTASpectral(coating[size_t(k)], n_before, n_after, lambda_nm, cos_i,
                                design_wavelength_nm, out);
}

LensCoatings resolveCoatings(const LensPrescription& p) {
  auto lib = std::make_shared<CoatingLibrary>();
  if (!p.coating_file.empty()) {
    try {
      lib->readZemaxCoatingFile(p.coating_file);
    } catch (const Error& e) {
      // Unreadable: say so where the lens names the file; malformed: the file's own line.
      if (e.loc().file == p.coating_file) throw;
      throw Error(p.coating_file_loc, e.message());
    }
  }
  auto unknown = [&](const std::string& name, const FileLoc& loc, const char* what) {
    std::string known;
    for (const std::string& n : lib->names()) known += (known.empty() ? "" : ", ") + n;
    return Error(loc, fmt::format("unknown {} '{}' (known: {}{})", what, name, known,
                                  p.coating_file.empty() ? "; a Zemax coating file may define "
                                                           "more"
                                                         : ""));
  };
  LensCoatings out;
  out.design_wavelength_nm = primaryWavelength_nm(p);
  const Coating* lens_default = lib->find("uncoated");
  if (!p.default_coating.empty()) {
    lens_default = lib->find(p.default_coating);
    if (!lens_default) throw unknown(p.default_coating, p.default_coating_loc, "lens-wide coating");
  }
  double before = 1;
  for (const LensSurface& s : p.surfaces) {
    const double after = s.ior == 0 ? 1.0 : s.ior;
    const Coating* c = nullptr;
    std::string label;
    if (!s.coating.empty()) {
      c = lib->find(s.coating);
      if (!c) throw unknown(s.coating, s.coating_loc, "coating");
      label = c->name;
    } else if (s.mirror) {
      label = "mirror";
    } else if (before == after) {
      label = "index-matched";
    } else if (before == 1 || after == 1) {
      c = lens_default;
      label = c->name;
    } else {
      label = "cemented";
    }
    if (s.mirror && c) label = "mirror";
    out.coating.push_back(s.mirror ? nullptr : c);
    out.label.push_back(label);
    before = after;
  }
  out.library = std::move(lib);
  return out;
}

double axialTransmittance(const LensSystem& lens, const LensCoatings& c, double lambda_nm) {
  std::vector<double> nb(size_t(lens.surfaceCount())), na(size_t(lens.surfaceCount()));
  lens.indicesAt(lambda_nm, nb.data(), na.data());
  double t = 1;
  for (int k = 0; k < lens.surfaceCount(); ++k) {
    if (lens.interfaces()[size_t(k)].is_mirror) continue;
    t *= c.rta(k, nb[size_t(k)], na[size_t(k)], lambda_nm, 1.0).T;
  }
  return t;
}

}  // namespace lensim::optics
