// Builder: materials (Material, MakeNamedMaterial) and the default material.
#include "lensim/scene/build/builder_internal.h"
#include "lensim/util/file.h"

namespace lensim::scene::detail {

Material Builder::material(const std::string& type, ParamSet& ps, const FileLoc& loc) {
  Material m;
  m.type_as_written = type;
  m.loc = loc;
  m.displacement = floatInput(ps, {"displacement", "bumpmap"});  // bump mapping
  if (const Param* nm = ps.find({"normalmap"}, {ParamType::String}))
    if (!nm->strings[0].empty()) m.normal_map = resolve(nm->strings[0], nm->loc, "normal map");
  auto roughness = [&](double def) {
    Input r = floatInput(ps, {"roughness"}, def);
    m.uroughness = floatInput(ps, {"uroughness"}).value_or(r);
    m.vroughness = floatInput(ps, {"vroughness"}).value_or(r);
    m.remap_roughness = ps.getBool({"remaproughness"}, true);
  };
  auto conductorDefaults = [&]() {
    m.eta = spectrumInput(ps, {"eta"}).value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-eta")});
    m.k = spectrumInput(ps, {"k"}).value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-k")});
  };
  auto dielectricEta = [&](ParamSet::Names names) {
    const Param* p = ps.find(names, {ParamType::Float, ParamType::Spectrum, ParamType::Texture});
    m.eta.value = 1.5;
    if (!p) return;
    if (p->type == ParamType::Float) {
      ps.expectCount(*p, 1);
      m.eta.value = p->numbers[0];
    } else if (p->type == ParamType::Texture) {
      m.eta.texture = textureIndex(p->strings[0], TextureKind::Float, p->loc);
    } else {
      m.eta.spectrum = spectrumOf(*p);
    }
  };
  if (type == "diffuse" || type == "matte") {
    m.type = "diffuse";
    m.reflectance = spectrumInput(ps, {"reflectance", "Kd"}, 0.5);
    m.has_reflectance = true;
    if (type == "matte") m.sigma = floatInput(ps, {"sigma"}, 0);  // Oren–Nayar, degrees
  } else if (type == "coateddiffuse") {
    m.type = "coateddiffuse";
    m.reflectance = spectrumInput(ps, {"reflectance", "Kd"}, 0.5);
    m.has_reflectance = true;
    roughness(0);
    m.thickness = floatInput(ps, {"thickness"}, 0.01);
    m.albedo = spectrumInput(ps, {"albedo"}, 0);
    m.g = floatInput(ps, {"g"}, 0);
    m.max_depth = ps.getInt({"maxdepth"}, 10);
    m.n_samples = ps.getInt({"nsamples"}, 1);
    dielectricEta({"eta"});
  } else if (type == "plastic" || type == "uber" || type == "substrate" || type == "translucent") {
    // pbrt-v3's materials, rendered as pbrt-v3 defines them (render/v3materials.h), with
    // pbrt-v3's defaults (src/materials/{plastic,uber,substrate,translucent}.cpp).
    m.type = type;
    const bool half = type == "substrate";
    m.reflectance = spectrumInput(ps, {"Kd", "reflectance"}, half ? 0.5 : 0.25);
    m.has_reflectance = true;
    m.specular = spectrumInput(ps, {"Ks"}, half ? 0.5 : 0.25);
    roughness(0.1);
    if (type == "uber") {
      m.kr = spectrumInput(ps, {"Kr"}, 0);
      m.kt = spectrumInput(ps, {"Kt"}, 0);
      m.opacity = spectrumInput(ps, {"opacity"}, 1);
      dielectricEta({"eta", "index"});
    } else if (type == "translucent") {
      m.v3_reflect = spectrumInput(ps, {"reflect"}, 0.5);
      m.transmittance = spectrumInput(ps, {"transmit"}, 0.5);
    }
  } else if (type == "conductor" || type == "metal") {
    // pbrt-v3's metal keeps its name: its roughness is remapped as pbrt-v3 does.
    m.type = type;
    conductorDefaults();
    if (type == "conductor")
      if (auto r = spectrumInput(ps, {"reflectance"})) {
        m.reflectance = *r;
        m.has_reflectance = true;
      }
    roughness(type == "metal" ? 0.01 : 0);
  } else if (type == "mirror") {
    m.type = "mirror";  // pbrt-v3: a specular reflection of Kr at every angle
    m.kr = spectrumInput(ps, {"Kr"}, 0.9);
  } else if (type == "dielectric" || type == "glass" || type == "thindielectric") {
    m.type = type;
    dielectricEta({"eta", "index"});
    if (type != "thindielectric") roughness(0);
    if (type == "glass") {
      m.kr = spectrumInput(ps, {"Kr"}, 1);
      m.kt = spectrumInput(ps, {"Kt"}, 1);
    }
  } else if (type == "coatedconductor") {
    m.type = type;
    Input r = floatInput(ps, {"interface.roughness"}, 0);
    m.uroughness = floatInput(ps, {"interface.uroughness"}).value_or(r);
    m.vroughness = floatInput(ps, {"interface.vroughness"}).value_or(r);
    Input cr = floatInput(ps, {"conductor.roughness"}, 0);
    m.conductor_uroughness = floatInput(ps, {"conductor.uroughness"}).value_or(cr);
    m.conductor_vroughness = floatInput(ps, {"conductor.vroughness"}).value_or(cr);
    m.remap_roughness = ps.getBool({"remaproughness"}, true);
    dielectricEta({"interface.eta"});
    m.conductor_eta = spectrumInput(ps, {"conductor.eta"})
                          .value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-eta")});
    m.conductor_k = spectrumInput(ps, {"conductor.k"})
                        .value_or(Input{-1, 0, SpectrumValue::named("metal-Cu-k")});
    if (auto rr = spectrumInput(ps, {"reflectance"})) {
      m.conductor_reflectance = *rr;
      m.conductor_has_reflectance = true;
    }
    m.thickness = floatInput(ps, {"thickness"}, 0.01);
    m.albedo = spectrumInput(ps, {"albedo"}, 0);
    m.g = floatInput(ps, {"g"}, 0);
    m.max_depth = ps.getInt({"maxdepth"}, 10);
    m.n_samples = ps.getInt({"nsamples"}, 1);
  } else if (type == "diffusetransmission") {
    m.type = "diffusetransmission";
    m.reflectance = spectrumInput(ps, {"reflectance"}, 0.25);
    m.transmittance = spectrumInput(ps, {"transmittance"}, 0.25);
    m.scale = ps.getFloat({"scale"}, 1);
    m.has_reflectance = true;
  } else if (type == "hair") {
    hairMaterial(m, ps, loc);
  } else if (type == "mix") {
    m.type = "mix";
    std::vector<std::string> names;
    if (const Param* p = ps.find({"materials"}, {ParamType::String}))
      names = p->strings;
    else
      names = {ps.getString({"namedmaterial1"}, ""), ps.getString({"namedmaterial2"}, "")};
    if (names.size() != 2)
      throw Error(loc, fmt::format("mix: expected 2 materials, got {}", names.size()));
    for (int i = 0; i < 2; ++i) {
      const int named = namedMaterial(names[size_t(i)]);
      if (named < 0)
        throw Error(loc, fmt::format("mix: unknown material \"{}\"", names[size_t(i)]));
      m.mix[size_t(i)] = named;
    }
    m.amount = floatInput(ps, {"amount"}, 0.5);
  } else if (type == "subsurface") {
    // Rendered by a volumetric random walk inside the shape (render/media/subsurface.h).
    m.type = "subsurface";
    subsurfaceCoefficients(m, ps, loc);
    dielectricEta({"eta"});
    if (!ps.peek({"eta"})) m.eta.value = 1.33;  // pbrt-v4's default for subsurface
    roughness(0);
  } else if (type == "interface" || type == "" || type == "none") {
    m.type = "interface";
  } else if (type == "fourier") {
    // pbrt-v3's tabulated BSDF (src/materials/fourier.cpp: "bsdffile", and "bumpmap" read
    // above); the table is read when the render starts (render/materials/fourier.h).
    const Param* f = ps.find({"bsdffile"}, {ParamType::String});
    if (!f) throw Error(loc, "fourier: missing \"string bsdffile\" (a pbrt-v3 tabulated BSDF)");
    m.type = "fourier";
    m.measured_file = resolve(f->strings[0], f->loc, "tabulated BSDF file");
  } else if (type == "measured") {
    // pbrt-v4: an RGL measured BSDF (`.bsdf` tensor file, render/materials/measured_rgl.h);
    // pbrt-v2: the irregular isotropic `.brdf` text format (render/materials/measured.h).
    // Chosen by content (the tensor-file header), else by extension.
    const Param* f = ps.find({"filename"}, {ParamType::String});
    if (!f) throw Error(loc, "measured: missing \"string filename\"");
    const std::string& name = f->strings[0];
    m.type = "measured";
    m.measured_file = resolve(name, f->loc, "measured BRDF file");
    m.measured_rgl = name.ends_with(".bsdf") ||
                     fileStartsWith(m.measured_file, std::string_view("tensor_file\0", 12));
    if (!m.measured_rgl && !name.ends_with(".brdf"))
      ps.fail(*f,
              "expected an RGL measured BSDF (a .bsdf tensor file) or a pbrt-v2 irregular "
              "isotropic .brdf file");
  } else {
    ps.markAllUsed();
    m.type = "diffuse";
    m.reflectance.spectrum = SpectrumValue::gray(0.5);
    m.has_reflectance = true;
    m.fallback = true;
    warnOnce("material " + type, loc,
             fmt::format("material \"{}\" is not rendered by lensim; it renders as diffuse grey "
                         "(reflectance 0.5)",
                         type));
  }
  const std::optional<MaterialKind> kind = materialKindOf(m.type);
  if (!kind)  // a type the branches above set but materialKindOf does not know: a lensim bug
    throw Error(loc,
                fmt::format("internal error: material type \"{}\" has no MaterialKind", m.type));
  m.kind = *kind;
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
    m.reflectance.spectrum = SpectrumValue::gray(0.5);
    m.has_reflectance = true;
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
void Builder::subsurfaceCoefficients(Material& m, ParamSet& ps, const FileLoc& loc) {
  m.ss_g = ps.getFloat({"g"}, 0);
  if (!(m.ss_g > -1 && m.ss_g < 1))
    throw Error(ps.peek({"g"})->loc, fmt::format("subsurface: g {} outside (-1, 1)", m.ss_g));
  // Each coefficient a constant or a spectrum texture, as pbrt-v4's GetSpectrumTextureOrNull
  // takes them (src/pbrt/paramdict.cpp: a float texture there is an error).
  auto input = [&](const char* pname, Input& out) {
    std::optional<Input> in = spectrumInput(ps, {pname});
    if (in) out = *in;
    return in.has_value();
  };
  if (const Param* p = ps.find({"name"}, {ParamType::String})) {
    m.ss_name = p->strings[0];
    if (!mediumPreset(m.ss_name, m.ss_sigma_a.spectrum, m.ss_sigma_s.spectrum)) {
      ps.fail(*p, fmt::format("unknown measured medium \"{}\"{}", m.ss_name,
                              didYouMean(m.ss_name, mediumPresetNames(), 4)));
    }
    if (m.ss_g != 0)
      warn(ps.peek({"g"})->loc,
           "subsurface: \"g\" is ignored with a named measured medium "
           "(its sigma_s is the reduced scattering coefficient), as in "
           "pbrt-v4");
    m.ss_g = 0;
  } else {
    const bool a = input("sigma_a", m.ss_sigma_a), s = input("sigma_s", m.ss_sigma_s);
    if (a != s)
      throw Error(loc, a ? "subsurface: \"sigma_a\" given without \"sigma_s\""
                         : "subsurface: \"sigma_s\" given without \"sigma_a\"");
    if (!a) {
      if (input("reflectance", m.ss_reflectance)) {
        m.ss_from_reflectance = true;
        m.ss_mfp = spectrumInput(ps, {"mfp"}, 1);
      } else {
        m.ss_sigma_a.spectrum.rgb = {.0011, .0024, .014};
        m.ss_sigma_s.spectrum.rgb = {2.55, 3.21, 3.77};
      }
    }
  }
  m.scale = ps.getFloat({"scale"}, 1);
  if (!(m.scale >= 0))
    throw Error(ps.peek({"scale"})->loc,
                fmt::format("subsurface: scale {} must not be negative", m.scale));
}

}  // namespace lensim::scene::detail
