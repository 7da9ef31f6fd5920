// Builder: LightSource and AreaLightSource, light scale.
#include "lensim/scene/build/builder_internal.h"

namespace lensim::scene::detail {

namespace {

// pbrt-v1–v3's per-light "nsamples" (pbrt-v3: Light::nSamples = max(1, nsamples)), the samples
// per hit of the directlighting integrator's "all" strategy; at most 65536.
int lightSamples(ParamSet& ps) {
  const int n = ps.getInt({"nsamples", "samples"}, 1);
  if (n > 65536)
    throw Error(ps.peek({"nsamples", "samples"})->loc,
                fmt::format("nsamples {} is more than 65536 light samples per hit", n));
  return std::max(1, n);
}

}  // namespace

// ---- light scale ---------------------------------------------------------------------------
// pbrt-v4 reads a light's "scale" as a float; pbrt-v3 as a spectrum (`"rgb scale"`, `"color
// scale"`, `"spectrum scale"`: pbrt-v3's CreatePointLight & co. call
// paramSet.FindOneSpectrum("scale", Spectrum(1.0)) and multiply the emission by it in RGB).
const Param* Builder::findLightScale(ParamSet& ps) {
  return ps.find({"scale"}, {ParamType::Float, ParamType::Rgb, ParamType::Spectrum});
}

void Builder::applyLightScale(const Param* p, Light& l) {
  if (!p) return;
  if (p->type == ParamType::Float) {
    if (p->numbers.size() != 1)
      throw Error(p->loc,
                  fmt::format("\"{}\": expected 1 value, got {}", p->name, p->numbers.size()));
    l.scale = p->numbers[0];
    return;
  }
  SpectrumValue sv = spectrumOf(*p);
  if (sv.kind == SpectrumValue::Kind::Rgb) {
    const Vec3 c = sv.rgb;
    if (c.x == c.y && c.y == c.z) {
      l.scale = c.x;  // grey: a plain factor
      return;
    }
    if (l.emission.kind == SpectrumValue::Kind::Rgb && l.filename.empty()) {
      // pbrt-v3 multiplies RGB emission by the RGB scale channel by channel; so does this.
      l.emission.rgb = {l.emission.rgb.x * c.x, l.emission.rgb.y * c.y, l.emission.rgb.z * c.z};
      return;
    }
    l.scale = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
    warn(p->loc, fmt::format("\"{}\": a coloured scale of a light whose emission is an image "
                             "or a spectrum is applied as its luminance {:.4g}",
                             p->name, l.scale));
    return;
  }
  double mean = 1;
  if (sv.kind == SpectrumValue::Kind::Sampled && !sv.samples.empty()) {
    mean = 0;
    for (const auto& [lambda, v] : sv.samples) mean += v;
    mean /= static_cast<double>(sv.samples.size());
  }
  l.scale = mean;
  warn(p->loc, fmt::format("\"{}\": a spectrum-valued light scale is applied as its mean value "
                           "{:.4g}",
                           p->name, mean));
}

// ---- lights --------------------------------------------------------------------------------
void Builder::light(const Directive& d) {
  const std::string& type = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("LightSource \"{}\"", type));
  ps.addDefaults(gs_.light_attrs);
  Light l;
  l.type = type;
  l.type_as_written = type;
  l.loc = d.loc;
  l.transform = gs_.ctm[0];
  const Param* scale_param = findLightScale(ps);
  l.power = ps.findFloat({"power", "illuminance"});
  l.n_samples = lightSamples(ps);  // pbrt-v1–v3 sample count
  auto emission = [&](ParamSet::Names names) {
    const Param* p = ps.find(names, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody});
    if (p) l.emission = spectrumOf(*p);
  };
  if (type == "point" || type == "spot") {
    emission({"I"});
    l.from = ps.findPoint3({"from"}).value_or(Vec3{0, 0, 0});
    if (type == "spot") {
      l.to = ps.findPoint3({"to"}).value_or(Vec3{0, 0, 1});
      l.cone_angle_deg = ps.getFloat({"coneangle"}, 30);
      l.cone_delta_deg = ps.getFloat({"conedeltaangle"}, 5);
      if (l.from == l.to)
        throw Error(d.loc,
                    "spot light: \"from\" and \"to\" are the same point; they give "
                    "the light's direction");
    }
  } else if (type == "projection") {
    l.fov_deg = ps.getFloat({"fov"}, 90);
    const Param* p = ps.find({"filename", "mapname"}, {ParamType::String});
    if (!p || p->strings[0].empty())
      throw Error(d.loc, "projection light: missing \"string filename\"");
    l.filename = resolve(p->strings[0], p->loc, "projection image");
    if (l.fov_deg <= 0 || l.fov_deg >= 180)
      throw Error(d.loc, fmt::format("projection light: fov {} is not in (0, 180)", l.fov_deg));
  } else if (type == "goniometric") {
    emission({"I"});
    if (const Param* p = ps.find({"filename", "mapname"}, {ParamType::String}))
      if (!p->strings[0].empty()) l.filename = resolve(p->strings[0], p->loc, "goniometric image");
  } else if (type == "distant") {
    emission({"L"});
    l.from = ps.findPoint3({"from"}).value_or(Vec3{0, 0, 0});
    l.to = ps.findPoint3({"to"}).value_or(Vec3{0, 0, 1});
    if (l.from == l.to)
      throw Error(d.loc,
                  "distant light: \"from\" and \"to\" are the same point; they give "
                  "the light's direction");
  } else if (type == "infinite") {
    emission({"L"});
    if (const Param* p = ps.find({"filename", "mapname"}, {ParamType::String}))
      if (!p->strings[0].empty()) l.filename = resolve(p->strings[0], p->loc, "environment map");
    l.portal = ps.getVec3s({"portal"}, {ParamType::Point3});
    if (!l.portal.empty() && l.portal.size() != 4)
      ps.fail(*ps.peek({"portal"}), fmt::format("expected 4 points, got {}", l.portal.size()));
  } else {
    ps.markAllUsed();
    warnOnce("light " + type, d.loc,
             fmt::format("light \"{}\" is not rendered by lensim; it is left out", type));
    return;
  }
  applyLightScale(scale_param, l);
  requireInvertible(d.loc, fmt::format("LightSource \"{}\"", type));
  finish(ps);
  scene_.lights.push_back(std::move(l));
}

void Builder::areaLight(const Directive& d) {
  const std::string& type = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("AreaLightSource \"{}\"", type));
  ps.addDefaults(gs_.light_attrs);
  Light l;
  l.type = "diffuse";
  l.type_as_written = type;
  l.loc = d.loc;
  l.transform = gs_.ctm[0];
  if (type != "diffuse" && type != "area") {
    ps.markAllUsed();
    warnOnce("arealight " + type, d.loc,
             fmt::format("area light \"{}\" is not rendered by lensim; it renders as "
                         "\"diffuse\" with L = 1",
                         type));
  } else {
    const Param* p = ps.find({"L"}, {ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody});
    if (p) l.emission = spectrumOf(*p);
    const Param* scale_param = findLightScale(ps);
    l.two_sided = ps.getBool({"twosided"}, false);
    l.power = ps.findFloat({"power"});
    l.n_samples = lightSamples(ps);  // pbrt-v1–v3 sample count
    if (const Param* fn = ps.find({"filename"}, {ParamType::String})) {
      l.filename = resolve(fn->strings[0], fn->loc, "image file");
    }
    applyLightScale(scale_param, l);
  }
  finish(ps);
  scene_.lights.push_back(std::move(l));
  gs_.area_light = static_cast<int>(scene_.lights.size()) - 1;
}

}  // namespace lensim::scene::detail
