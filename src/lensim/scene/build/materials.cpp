// Builder: materials (Material, MakeNamedMaterial) and the default material.
#include "lensim/scene/build/builder_internal.h"
#include "lensim/util/file.h"

namespace lensim::scene::detail {

namespace {
using Names = ParamSet::Names;
}  // namespace

// Reads the parameters of each material kind, one function per kind; the table in
// Builder::material maps the type names of the file to them.
struct MaterialReader {
  Builder& b;
  const std::string& type;  ///< as written
  ParamSet& ps;
  const FileLoc& loc;

  Input floatIn(Names names, double def) { return b.floatInput(ps, names, def); }
  Input spectrumIn(Names names, double def) { return b.spectrumInput(ps, names, def); }
  /// "roughness", or "uroughness" and "vroughness", with the prefix (pbrt-v4's "interface."
  /// and "conductor."), and "remaproughness".
  Roughness roughness(double def, const std::string& prefix = "") {
    const std::string both_name = prefix + "roughness", u_name = prefix + "uroughness",
                      v_name = prefix + "vroughness";
    Roughness r;
    const Input both = b.floatInput(ps, {both_name}, def);
    r.u = b.floatInput(ps, {u_name}).value_or(both);
    r.v = b.floatInput(ps, {v_name}).value_or(both);
    r.remap = ps.getBool({"remaproughness"}, true);
    return r;
  }
  /// A dielectric's index: a float (default 1.5), a float texture or a spectrum.
  Input dielectricEta(Names names) {
    Input eta;
    eta.value = 1.5;
    const Param* p = ps.find(names, {ParamType::Float, ParamType::Spectrum, ParamType::Texture});
    if (!p) return eta;
    if (p->type == ParamType::Float) {
      ps.expectCount(*p, 1);
      eta.value = p->numbers[0];
    } else if (p->type == ParamType::Texture) {
      eta.texture = b.textureIndex(p->strings[0], TextureKind::Float, p->loc);
    } else {
      eta.spectrum = b.spectrumOf(*p);
    }
    return eta;
  }
  /// eta and k spectra (copper by default).
  std::pair<Input, Input> conductorEtaK(const char* eta_name, const char* k_name) {
    return {
        b.spectrumInput(ps, {eta_name})
            .value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-eta")}),
        b.spectrumInput(ps, {k_name}).value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-k")})};
  }
  LayerInputs layer() {
    LayerInputs l;
    l.thickness = floatIn({"thickness"}, 0.01);
    l.albedo = spectrumIn({"albedo"}, 0);
    l.g = floatIn({"g"}, 0);
    l.max_depth = ps.getInt({"maxdepth"}, 10);
    l.n_samples = ps.getInt({"nsamples"}, 1);
    return l;
  }

  MaterialParams diffuse() {
    DiffuseParams d;
    d.reflectance = spectrumIn({"reflectance", "Kd"}, 0.5);
    if (type == "matte") d.sigma = floatIn({"sigma"}, 0);  // Oren–Nayar, degrees
    return d;
  }
  MaterialParams coatedDiffuse() {
    CoatedDiffuseParams c;
    c.reflectance = spectrumIn({"reflectance", "Kd"}, 0.5);
    c.roughness = roughness(0);
    c.layer = layer();
    c.eta = dielectricEta({"eta"});
    return c;
  }
  MaterialParams coatedConductor() {
    CoatedConductorParams c;
    c.interface_roughness = roughness(0, "interface.");
    c.conductor_roughness = roughness(0, "conductor.");
    c.interface_eta = dielectricEta({"interface.eta"});
    std::tie(c.conductor.eta, c.conductor.k) = conductorEtaK("conductor.eta", "conductor.k");
    if (auto r = b.spectrumInput(ps, {"reflectance"})) {
      c.conductor.reflectance = *r;
      c.conductor.has_reflectance = true;
    }
    c.layer = layer();
    return c;
  }
  MaterialParams conductor() {
    ConductorParams c;
    std::tie(c.index.eta, c.index.k) = conductorEtaK("eta", "k");
    if (auto r = b.spectrumInput(ps, {"reflectance"})) {
      c.index.reflectance = *r;
      c.index.has_reflectance = true;
    }
    c.roughness = roughness(0);
    return c;
  }
  MaterialParams dielectric() {
    DielectricParams d;
    d.eta = dielectricEta({"eta", "index"});
    d.roughness = roughness(0);
    return d;
  }
  MaterialParams thinDielectric() { return ThinDielectricParams{dielectricEta({"eta", "index"})}; }
  MaterialParams diffuseTransmission() {
    DiffuseTransmissionParams d;
    d.reflectance = spectrumIn({"reflectance"}, 0.25);
    d.transmittance = spectrumIn({"transmittance"}, 0.25);
    d.scale = ps.getFloat({"scale"}, 1);
    return d;
  }
  MaterialParams mix() {
    MixParams m;
    std::vector<std::string> names;
    if (const Param* p = ps.find({"materials"}, {ParamType::String}))
      names = p->strings;
    else
      names = {ps.getString({"namedmaterial1"}, ""), ps.getString({"namedmaterial2"}, "")};
    if (names.size() != 2)
      throw Error(loc, fmt::format("mix: expected 2 materials, got {}", names.size()));
    for (int i = 0; i < 2; ++i) {
      const int named = b.namedMaterial(names[size_t(i)]);
      if (named < 0)
        throw Error(loc, fmt::format("mix: unknown material \"{}\"", names[size_t(i)]));
      m.materials[size_t(i)] = named;
    }
    m.amount = floatIn({"amount"}, 0.5);
    return m;
  }
  MaterialParams interface() { return InterfaceParams{}; }
  // Rendered by a volumetric random walk inside the shape (render/media/subsurface.h).
  MaterialParams subsurface() {
    SubsurfaceParams s;
    b.subsurfaceCoefficients(s, ps, loc);
    s.eta = dielectricEta({"eta"});
    if (!ps.peek({"eta"})) s.eta.value = 1.33;  // pbrt-v4's default for subsurface
    s.roughness = roughness(0);
    return s;
  }
  // pbrt-v4: an RGL measured BSDF (`.bsdf` tensor file, render/materials/measured_rgl.h);
  // pbrt-v2: the irregular isotropic `.brdf` text format (render/materials/measured.h).
  // Chosen by content (the tensor-file header), else by extension.
  MaterialParams measured() {
    const Param* f = ps.find({"filename"}, {ParamType::String});
    if (!f) throw Error(loc, "measured: missing \"string filename\"");
    const std::string& name = f->strings[0];
    MeasuredParams m;
    m.file = b.resolve(name, f->loc, "measured BRDF file");
    m.rgl =
        name.ends_with(".bsdf") || fileStartsWith(m.file, std::string_view("tensor_file\0", 12));
    if (!m.rgl && !name.ends_with(".brdf"))
      ps.fail(*f,
              "expected an RGL measured BSDF (a .bsdf tensor file) or a pbrt-v2 irregular "
              "isotropic .brdf file");
    return m;
  }
  MaterialParams hair() { return b.hairMaterial(ps, loc); }
  // pbrt-v3's materials, rendered as pbrt-v3 defines them (render/v3materials.h), with
  // pbrt-v3's defaults (src/materials/*.cpp).
  MaterialParams plastic() {
    PlasticParams p;
    p.kd = spectrumIn({"Kd", "reflectance"}, 0.25);
    p.ks = spectrumIn({"Ks"}, 0.25);
    p.roughness = roughness(0.1);
    return p;
  }
  MaterialParams substrate() {
    SubstrateParams s;
    s.kd = spectrumIn({"Kd", "reflectance"}, 0.5);
    s.ks = spectrumIn({"Ks"}, 0.5);
    s.roughness = roughness(0.1);
    return s;
  }
  MaterialParams uber() {
    UberParams u;
    u.kd = spectrumIn({"Kd", "reflectance"}, 0.25);
    u.ks = spectrumIn({"Ks"}, 0.25);
    u.roughness = roughness(0.1);
    u.kr = spectrumIn({"Kr"}, 0);
    u.kt = spectrumIn({"Kt"}, 0);
    u.opacity = spectrumIn({"opacity"}, 1);
    u.eta = dielectricEta({"eta", "index"});
    return u;
  }
  MaterialParams translucent() {
    TranslucentParams t;
    t.kd = spectrumIn({"Kd", "reflectance"}, 0.25);
    t.ks = spectrumIn({"Ks"}, 0.25);
    t.roughness = roughness(0.1);
    t.reflect = spectrumIn({"reflect"}, 0.5);
    t.transmit = spectrumIn({"transmit"}, 0.5);
    return t;
  }
  MaterialParams glass() {
    GlassParams g;
    g.eta = dielectricEta({"eta", "index"});
    g.roughness = roughness(0);
    g.kr = spectrumIn({"Kr"}, 1);
    g.kt = spectrumIn({"Kt"}, 1);
    return g;
  }
  MaterialParams metal() {
    MetalParams m;
    std::tie(m.eta, m.k) = conductorEtaK("eta", "k");
    m.roughness = roughness(0.01);
    return m;
  }
  MaterialParams mirror() { return MirrorParams{spectrumIn({"Kr"}, 0.9)}; }
  // pbrt-v3's tabulated BSDF (src/materials/fourier.cpp: "bsdffile", and "bumpmap" read by
  // Builder::material); the table is read when the render starts (render/materials/fourier.h).
  MaterialParams fourier() {
    const Param* f = ps.find({"bsdffile"}, {ParamType::String});
    if (!f) throw Error(loc, "fourier: missing \"string bsdffile\" (a pbrt-v3 tabulated BSDF)");
    return FourierParams{b.resolve(f->strings[0], f->loc, "tabulated BSDF file")};
  }
};

Material Builder::material(const std::string& type, ParamSet& ps, const FileLoc& loc) {
  // The type names of the file: the kind's name lensim reports and its reader.
  struct Kind {
    std::string_view name, renders_as;
    MaterialParams (MaterialReader::*read)();
  };
  using R = MaterialReader;
  static constexpr std::array<Kind, 23> kKinds{{
      {"diffuse", "diffuse", &R::diffuse},
      {"matte", "diffuse", &R::diffuse},
      {"coateddiffuse", "coateddiffuse", &R::coatedDiffuse},
      {"coatedconductor", "coatedconductor", &R::coatedConductor},
      {"conductor", "conductor", &R::conductor},
      {"dielectric", "dielectric", &R::dielectric},
      {"thindielectric", "thindielectric", &R::thinDielectric},
      {"diffusetransmission", "diffusetransmission", &R::diffuseTransmission},
      {"mix", "mix", &R::mix},
      {"interface", "interface", &R::interface},
      {"", "interface", &R::interface},
      {"none", "interface", &R::interface},
      {"subsurface", "subsurface", &R::subsurface},
      {"measured", "measured", &R::measured},
      {"hair", "hair", &R::hair},
      {"plastic", "plastic", &R::plastic},
      {"substrate", "substrate", &R::substrate},
      {"uber", "uber", &R::uber},
      {"translucent", "translucent", &R::translucent},
      {"glass", "glass", &R::glass},
      {"metal", "metal", &R::metal},
      {"mirror", "mirror", &R::mirror},
      {"fourier", "fourier", &R::fourier},
  }};
  Material m;
  m.type_as_written = type;
  m.loc = loc;
  m.displacement = floatInput(ps, {"displacement", "bumpmap"});  // bump mapping
  if (const Param* nm = ps.find({"normalmap"}, {ParamType::String}))
    if (!nm->strings[0].empty()) m.normal_map = resolve(nm->strings[0], nm->loc, "normal map");
  auto it =
      std::find_if(kKinds.begin(), kKinds.end(), [&](const Kind& k) { return k.name == type; });
  if (it != kKinds.end()) {
    MaterialReader reader{*this, type, ps, loc};
    m.params = (reader.*(it->read))();
    m.type = it->renders_as;
    return m;
  }
  ps.markAllUsed();
  m.type = "diffuse";
  m.params = DiffuseParams{.reflectance = {-1, 0, SpectrumValue::gray(0.5)}, .sigma = {}};
  m.fallback = true;
  warnOnce("material " + type, loc,
           fmt::format("material \"{}\" is not rendered by lensim; it renders as diffuse grey "
                       "(reflectance 0.5)",
                       type));
  return m;
}

int Builder::currentMaterial() {
  if (!gs_.scoped_material_name.empty()) {
    const int named = namedMaterial(gs_.scoped_material_name);
    if (named >= 0) return named;
    // pbrt-v3 (GraphicsState::CreateMaterial) silently falls back to the current Material.
    warnOnce("scoped material " + gs_.scoped_material_name + gs_.scoped_material_loc.str(),
             gs_.scoped_material_loc,
             fmt::format("NamedMaterial \"{}\": no MakeNamedMaterial of that name in this "
                         "AttributeBegin block or around it (pbrt-v1–v3 scope named materials "
                         "by block); the current Material is used, as pbrt-v3 does",
                         gs_.scoped_material_name));
  }
  if (gs_.material >= 0) return gs_.material;
  if (default_material_ < 0) {
    Material m;
    m.type = "diffuse";
    m.type_as_written = "(default)";
    m.params = DiffuseParams{.reflectance = {-1, 0, SpectrumValue::gray(0.5)}, .sigma = {}};
    scene_.materials.push_back(m);
    default_material_ = static_cast<int>(scene_.materials.size()) - 1;
  }
  return default_material_;
}

void Builder::resolveNamedMaterials() {
  std::set<std::pair<std::string, std::string>> reported;  // each bad name once per place
  for (const PendingMaterial& pm : pending_materials_) {
    auto it = named_materials_.find(pm.name);
    if (it != named_materials_.end()) {
      scene_.shapes[static_cast<size_t>(pm.shape)].material = it->second;
    } else if (reported.insert({pm.loc.str(), pm.name}).second) {
      scene_.diagnostics.push_back(
          {Severity::Error, pm.loc,
           fmt::format("NamedMaterial: unknown material \"{}\" (no MakeNamedMaterial defines it)",
                       pm.name)});
    }
  }
}

// pbrt-v4's SubsurfaceMaterial::Create (materials.cpp): the scattering coefficients from one of
// `name` (measured, reduced sigma_s, g forced to 0), sigma_a with sigma_s, reflectance with
// mfp, or the default (whole milk, Jensen et al. 2001), all times `scale`.
void Builder::subsurfaceCoefficients(SubsurfaceParams& m, ParamSet& ps, const FileLoc& loc) {
  m.g = ps.getFloat({"g"}, 0);
  if (!(m.g > -1 && m.g < 1))
    throw Error(ps.peek({"g"})->loc, fmt::format("subsurface: g {} outside (-1, 1)", m.g));
  // Each coefficient a constant or a spectrum texture, as pbrt-v4's GetSpectrumTextureOrNull
  // takes them (src/pbrt/paramdict.cpp: a float texture there is an error).
  auto input = [&](const char* pname, Input& out) {
    std::optional<Input> in = spectrumInput(ps, {pname});
    if (in) out = *in;
    return in.has_value();
  };
  if (const Param* p = ps.find({"name"}, {ParamType::String})) {
    m.preset = p->strings[0];
    if (!mediumPreset(m.preset, m.sigma_a.spectrum, m.sigma_s.spectrum)) {
      ps.fail(*p, fmt::format("unknown measured medium \"{}\"{}", m.preset,
                              didYouMean(m.preset, mediumPresetNames(), 4)));
    }
    if (m.g != 0)
      warn(ps.peek({"g"})->loc,
           "subsurface: \"g\" is ignored with a named measured medium "
           "(its sigma_s is the reduced scattering coefficient), as in "
           "pbrt-v4");
    m.g = 0;
  } else {
    const bool a = input("sigma_a", m.sigma_a), s = input("sigma_s", m.sigma_s);
    if (a != s)
      throw Error(loc, a ? "subsurface: \"sigma_a\" given without \"sigma_s\""
                         : "subsurface: \"sigma_s\" given without \"sigma_a\"");
    if (!a) {
      if (input("reflectance", m.reflectance)) {
        m.from_reflectance = true;
        m.mfp = spectrumInput(ps, {"mfp"}, 1);
      } else {
        m.sigma_a.spectrum.rgb = {.0011, .0024, .014};
        m.sigma_s.spectrum.rgb = {2.55, 3.21, 3.77};
      }
    }
  }
  m.scale = ps.getFloat({"scale"}, 1);
  if (!(m.scale >= 0))
    throw Error(ps.peek({"scale"})->loc,
                fmt::format("subsurface: scale {} must not be negative", m.scale));
}

}  // namespace lensim::scene::detail
