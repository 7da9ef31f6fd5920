// Builder: MakeNamedMedium, grid media and MediumInterface resolution.
#include "lensim/scene/build/builder_internal.h"

namespace lensim::scene::detail {

// ---- media ---------------------------------------------------------------------------------
void Builder::makeNamedMedium(const Directive& d) {
  const std::string& name = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("MakeNamedMedium \"{}\"", name));
  ps.addDefaults(gs_.medium_attrs);
  auto type = ps.findString({"type"});
  if (!type)
    throw Error(d.loc, fmt::format("MakeNamedMedium \"{}\": missing \"string type\"", name));
  Medium m;
  m.name = name;
  m.loc = d.loc;
  m.type_as_written = *type;
  m.medium_from_world = inverse(gs_.ctm[0]);
  warnIfAnimated(d.loc, "media");
  if (*type == "uniformgrid" || *type == "rgbgrid" || *type == "heterogeneous") {
    gridMedium(m, ps, d.loc);
    addNamedMedium(std::move(m), ps);
    return;
  }
  if (*type == "cloud" || *type == "nanovdb") {
    proceduralMedium(m, ps, d.loc);
    addNamedMedium(std::move(m), ps);
    return;
  }
  if (*type != "homogeneous") {
    ps.markAllUsed();
    warnOnce("medium " + *type, d.loc,
             fmt::format("medium \"{}\" is not rendered by lensim; media of this type are "
                         "left out (vacuum)",
                         *type));
    named_media_[name] = -1;
    return;
  }
  m.type = "homogeneous";
  if (const Param* p = ps.find({"preset"}, {ParamType::String})) {
    m.preset = p->strings[0];
    if (!mediumPreset(m.preset, m.sigma_a, m.sigma_s)) {
      ps.fail(*p, fmt::format("unknown medium preset \"{}\"{}", m.preset,
                              didYouMean(m.preset, mediumPresetNames(), 4)));
    }
  } else {
    optionalSpectrum(ps, "sigma_a", m.sigma_a);
    optionalSpectrum(ps, "sigma_s", m.sigma_s);
  }
  optionalSpectrum(ps, "Le", m.Le);
  m.Le_scale = ps.getFloat({"Lescale"}, 1);
  m.scale = ps.getFloat({"scale"}, 1);
  m.g = ps.getFloat({"g"}, 0);
  if (!(m.g > -1 && m.g < 1)) {
    const Param* p = ps.peek({"g"});
    throw Error(p ? p->loc : d.loc, fmt::format("medium \"{}\": g {} outside (-1, 1)", name, m.g));
  }
  if (!(m.scale >= 0)) {
    const Param* p = ps.peek({"scale"});
    throw Error(p ? p->loc : d.loc,
                fmt::format("medium \"{}\": scale {} must not be negative", name, m.scale));
  }
  addNamedMedium(std::move(m), ps);
}

void Builder::addNamedMedium(Medium m, ParamSet& ps) {
  finish(ps);
  const std::string name = m.name;
  if (named_media_.count(name)) warn(m.loc, fmt::format("named medium \"{}\" redefined", name));
  scene_.media.push_back(std::move(m));
  named_media_[name] = static_cast<int>(scene_.media.size()) - 1;
}

void Builder::optionalSpectrum(ParamSet& ps, const char* name, SpectrumValue& out) {
  if (const Param* p = ps.find({name}, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody}))
    out = spectrumOf(*p);
}

// pbrt-v4's "uniformgrid" (GridMedium: a density grid scaling sigma_a and sigma_s, optional
// per-voxel Lescale) and "rgbgrid" (RGBGridMedium: RGB sigma_a, sigma_s and Le grids).
void Builder::gridMedium(Medium& m, ParamSet& ps, const FileLoc& loc) {
  // pbrt-v3's "heterogeneous" (GridDensityMedium) is pbrt-v4's uniformgrid.
  m.type = m.type_as_written == "heterogeneous" ? "uniformgrid" : m.type_as_written;
  m.nx = ps.getInt({"nx"}, 1);
  m.ny = ps.getInt({"ny"}, 1);
  m.nz = ps.getInt({"nz"}, 1);
  if (m.nx < 1 || m.ny < 1 || m.nz < 1)
    throw Error(loc, fmt::format("medium \"{}\": grid resolution {} x {} x {} must be positive",
                                 m.name, m.nx, m.ny, m.nz));
  const size_t n = size_t(m.nx) * size_t(m.ny) * size_t(m.nz);
  if (auto p = ps.findPoint3({"p0"})) m.p0 = *p;
  if (auto p = ps.findPoint3({"p1"})) m.p1 = *p;
  if (!(m.p0.x < m.p1.x && m.p0.y < m.p1.y && m.p0.z < m.p1.z))
    throw Error(ps.peek({"p1"}) ? ps.peek({"p1"})->loc : loc,
                fmt::format("medium \"{}\": empty bounds p0 ({}, {}, {}) to p1 ({}, {}, {})",
                            m.name, m.p0.x, m.p0.y, m.p0.z, m.p1.x, m.p1.y, m.p1.z));
  auto expectCount = [&](const char* pname, size_t count, size_t per) {
    const Param* p = ps.peek({pname});
    if (count != n)
      throw Error(
          p ? p->loc : loc,
          fmt::format("medium \"{}\": \"{}\" has {} values; expected nx*ny*nz = {}{}", m.name,
                      pname, count, n, per > 1 ? fmt::format(" ({} numbers each)", per) : ""));
  };
  m.scale = ps.getFloat({"scale"}, 1);
  m.g = ps.getFloat({"g"}, 0);
  if (!(m.g > -1 && m.g < 1)) {
    const Param* p = ps.peek({"g"});
    throw Error(p ? p->loc : loc, fmt::format("medium \"{}\": g {} outside (-1, 1)", m.name, m.g));
  }
  auto negative = [&](const char* pname, const std::vector<double>& v) {
    for (double x : v)
      if (!(x >= 0))
        throw Error(ps.peek({pname})->loc,
                    fmt::format("medium \"{}\": \"{}\" has a negative value {}", m.name, pname, x));
  };
  if (m.type == "uniformgrid") {
    const Param* dp = ps.find({"density"}, {ParamType::Float});
    if (!dp) throw Error(loc, fmt::format("medium \"{}\": missing \"float density\"", m.name));
    m.density = dp->numbers;
    expectCount("density", m.density.size(), 1);
    negative("density", m.density);
    if (ps.peek({"temperature"}))
      throw Error(
          ps.peek({"temperature"})->loc,
          fmt::format("medium \"{}\": \"temperature\" grids are not rendered by lensim", m.name));
    optionalSpectrum(ps, "sigma_a", m.sigma_a);
    optionalSpectrum(ps, "sigma_s", m.sigma_s);
    optionalSpectrum(ps, "Le", m.Le);
    if (const Param* p = ps.find({"Lescale"}, {ParamType::Float})) {
      if (p->numbers.size() == 1 && n != 1) {
        m.Le_scale = p->numbers[0];
      } else {
        m.Le_scale_grid = p->numbers;
        expectCount("Lescale", m.Le_scale_grid.size(), 1);
      }
    }
  } else {
    auto rgbs = [&](const char* pname, std::vector<Vec3>& out) {
      if (const Param* p = ps.find({pname}, {ParamType::Rgb})) {
        if (p->numbers.size() % 3)
          throw Error(p->loc, fmt::format("\"{}\": {} numbers is not a whole number of rgb "
                                          "values",
                                          pname, p->numbers.size()));
        negative(pname, p->numbers);
        for (size_t i = 0; i < p->numbers.size(); i += 3)
          out.push_back({p->numbers[i], p->numbers[i + 1], p->numbers[i + 2]});
        expectCount(pname, out.size(), 3);
      }
    };
    rgbs("sigma_a", m.sigma_a_grid);
    rgbs("sigma_s", m.sigma_s_grid);
    rgbs("Le", m.Le_grid);
    if (m.sigma_a_grid.empty() && m.sigma_s_grid.empty())
      throw Error(loc, fmt::format("medium \"{}\": rgbgrid needs \"rgb sigma_a\" or \"rgb "
                                   "sigma_s\" values",
                                   m.name));
    m.Le_scale = ps.getFloat({"Lescale"}, 1);
  }
}

// pbrt-v4's "cloud" (CloudMedium) and "nanovdb" (NanoVDBMedium): constant sigma_a, sigma_s
// (default 1) times `scale` times a density from noise or from the file (media.cpp, Create).
void Builder::proceduralMedium(Medium& m, ParamSet& ps, const FileLoc& loc) {
  m.type = m.type_as_written;
  optionalSpectrum(ps, "sigma_a", m.sigma_a);
  optionalSpectrum(ps, "sigma_s", m.sigma_s);
  m.scale = ps.getFloat({"scale"}, 1);
  m.g = ps.getFloat({"g"}, 0);
  auto check = [&](const char* pname, double v, bool ok, const char* expected) {
    if (ok) return;
    const Param* p = ps.peek({pname});
    throw Error(p ? p->loc : loc,
                fmt::format("medium \"{}\": {} {} {}", m.name, pname, v, expected));
  };
  check("g", m.g, m.g > -1 && m.g < 1, "outside (-1, 1)");
  check("scale", m.scale, m.scale >= 0, "must not be negative");
  if (m.type == "cloud") {
    m.cloud_density = ps.getFloat({"density"}, 1);
    m.wispiness = ps.getFloat({"wispiness"}, 1);
    m.frequency = ps.getFloat({"frequency"}, 5);
    check("density", m.cloud_density, m.cloud_density >= 0, "must not be negative");
    if (auto p = ps.findPoint3({"p0"})) m.p0 = *p;
    if (auto p = ps.findPoint3({"p1"})) m.p1 = *p;
    if (!(m.p0.x < m.p1.x && m.p0.y < m.p1.y && m.p0.z < m.p1.z))
      throw Error(ps.peek({"p1"}) ? ps.peek({"p1"})->loc : loc,
                  fmt::format("medium \"{}\": empty bounds p0 ({}, {}, {}) to p1 ({}, {}, {})",
                              m.name, m.p0.x, m.p0.y, m.p0.z, m.p1.x, m.p1.y, m.p1.z));
    return;
  }
  const Param* f = ps.find({"filename"}, {ParamType::String});
  if (!f || f->strings[0].empty())
    throw Error(loc, fmt::format("medium \"{}\": nanovdb needs \"string filename\" (a .nvdb "
                                 "file)",
                                 m.name));
  m.filename = resolve(f->strings[0], f->loc, "NanoVDB file");
  m.Le_scale = ps.getFloat({"Lescale", "LeScale"}, 1);
  m.temperature_offset = ps.getFloat({"temperatureoffset"}, ps.getFloat({"temperaturecutoff"}, 0));
  m.temperature_scale = ps.getFloat({"temperaturescale"}, 1);
}

int Builder::mediumIndex(const std::string& name, const FileLoc& loc) {
  if (name.empty()) return -1;
  auto it = named_media_.find(name);
  if (it != named_media_.end()) return it->second;
  const std::string hint = didYouMean(name, named_media_, 3);
  throw Error(loc, fmt::format("MediumInterface: unknown medium \"{}\"{}", name,
                               hint.empty() ? " (no MakeNamedMedium defines it)" : hint));
}

void Builder::resolveMedia() {
  std::set<std::pair<std::string, std::string>> reported;  // each bad name once per place
  for (const PendingMedia& pm : pending_media_) {
    try {
      const int in = mediumIndex(pm.inside, pm.loc), out = mediumIndex(pm.outside, pm.loc);
      if (pm.light >= 0) {
        scene_.lights[static_cast<size_t>(pm.light)].medium = out;
      } else if (pm.shape < 0) {
        scene_.camera.medium = out;
      } else {
        Shape& s = scene_.shapes[static_cast<size_t>(pm.shape)];
        s.inside_medium = in;
        s.outside_medium = out;
      }
    } catch (const Error& e) {
      if (reported.insert({e.loc().str(), e.message()}).second)
        scene_.diagnostics.push_back({Severity::Error, e.loc(), e.message()});
    }
  }
  bool used = scene_.camera.medium >= 0;
  for (const Shape& sh : scene_.shapes)
    used = used || sh.inside_medium >= 0 || sh.outside_medium >= 0;
  // The subsurface random walk (render/media/subsurface.h) runs in volpath (and path, which uses
  // its code for such scenes); bdpt's and lighttracer's subpaths do not walk inside, so they
  // would render a subsurface shape as its bare dielectric boundary.
  bool subsurface = false;
  for (const Shape& sh : scene_.shapes)
    subsurface = subsurface || (sh.material >= 0 && scene_.materials[size_t(sh.material)].kind() ==
                                                        MaterialKind::Subsurface);
  const FileLoc iloc = scene_.integrator.loc.valid() ? scene_.integrator.loc : scene_.camera.loc;
  if (subsurface && scene_.integrator.type == "bdpt") {
    warn(iloc,
         "integrator \"bdpt\" does not walk inside \"subsurface\" materials in lensim; the "
         "scene renders with \"volpath\", which does");
    scene_.integrator.type = "volpath";
  } else if (subsurface && scene_.integrator.type == "lighttracer") {
    warn(iloc,
         "integrator \"lighttracer\" does not walk inside \"subsurface\" materials in "
         "lensim: they render as their dielectric boundary (use \"volpath\")");
  }
  if (used && (scene_.integrator.type == "path" || scene_.integrator.type == "directlighting"))
    warn(
        scene_.integrator.loc.valid() ? scene_.integrator.loc : scene_.camera.loc,
        fmt::format("the scene has participating media but integrator \"{}\" ignores them; "
                    "use \"volpath\"",
                    scene_.integrator.type_as_written.empty() ? "path"
                                                              : scene_.integrator.type_as_written));
}

}  // namespace lensim::scene::detail
