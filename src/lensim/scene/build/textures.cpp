// Builder: the Texture directive.
#include "lensim/scene/build/builder_internal.h"

namespace lensim::scene::detail {

namespace {

// The 2-D mapping of imagemap, checkerboard, dots and bilerp: "mapping", its scales and
// offsets, and the planar axes.
void readMapping(Texture& t, ParamSet& ps) {
  t.mapping = ps.getString({"mapping"}, "uv");
  t.uscale = ps.getFloat({"uscale"}, 1);
  t.vscale = ps.getFloat({"vscale"}, 1);
  t.udelta = ps.getFloat({"udelta"}, 0);
  t.vdelta = ps.getFloat({"vdelta"}, 0);
  for (auto [name, v] : {std::pair{"v1", &t.v1}, std::pair{"v2", &t.v2}})
    if (const Param* p = ps.find({name}, {ParamType::Vector3})) {
      ps.expectCount(*p, 1);
      *v = {p->numbers[0], p->numbers[1], p->numbers[2]};
    }
}

// pbrt-v4 (src/pbrt/textures.cpp): fbm, wrinkled and windy are float textures, marble a
// spectrum texture; 3-D mapping by the inverse of the declaration's transform.
void noiseTexture(Texture& t, ParamSet& ps, const FileLoc& loc, bool is_float) {
  if ((t.type == "marble") == is_float)
    throw Error(loc, fmt::format("texture \"{}\": \"{}\" is a {} texture in pbrt", t.name, t.type,
                                 is_float ? "spectrum" : "float"));
  if (t.type != "windy") {
    t.octaves = ps.getInt({"octaves"}, 8);
    t.omega = ps.getFloat({"roughness"}, 0.5);
    if (t.octaves < 0 || t.octaves > 64)
      throw Error(loc,
                  fmt::format("texture \"{}\": octaves {} (expected 0 to 64)", t.name, t.octaves));
  }
  if (t.type == "marble") {
    t.scale = ps.getFloat({"scale"}, 1);
    t.variation = ps.getFloat({"variation"}, 0.2);
  }
  if (t.texture_from_world.isSingular())
    throw Error(loc, fmt::format("texture \"{}\": its 3-D mapping uses the current "
                                 "transformation matrix, which is singular (not invertible)",
                                 t.name));
}

}  // namespace

// imagemap: the mapping, the image file and how its values are read.
void Builder::imageMapTexture(Texture& t, ParamSet& ps, const FileLoc& loc) {
  readMapping(t, ps);
  const Param* fn = ps.find({"filename"}, {ParamType::String});
  if (!fn)
    throw Error(loc, fmt::format("texture \"{}\": imagemap needs \"string filename\"", t.name));
  t.filename_as_written = fn->strings[0];
  t.filename = resolve(fn->strings[0], fn->loc, "image file");
  t.wrap = ps.getString({"wrap"}, "repeat");
  t.scale = ps.getFloat({"scale"}, 1);
  t.invert = ps.getBool({"invert"}, false);
  t.encoding = ps.getString({"encoding"}, "");
  t.filter = ps.getString({"filter"}, "bilinear");
  t.max_anisotropy = ps.getFloat({"maxanisotropy"}, 8);
  if (ps.getBool({"trilinear"}, false)) t.filter = "trilinear";  // pbrt-v2/v3
  // pbrt-v2: "float gamma"; pbrt-v3: "bool gamma" (true: sRGB).
  if (const Param* g = ps.find({"gamma"}, {ParamType::Float, ParamType::Bool})) {
    ps.expectCount(*g, 1);
    if (g->type == ParamType::Float)
      t.encoding = fmt::format("gamma {}", g->numbers[0]);
    else
      t.encoding = g->bools[0] ? "sRGB" : "linear";
  }
  // "sRGB", "linear" or "gamma G" with a positive G, checked here at the parameter.
  if (!t.encoding.empty() && t.encoding != "sRGB" && t.encoding != "linear") {
    double gamma = 0;
    const std::string_view e = t.encoding;
    const bool ok =
        e.rfind("gamma ", 0) == 0 &&
        std::from_chars(e.data() + 6, e.data() + e.size(), gamma).ptr == e.data() + e.size() &&
        gamma > 0 && gamma <= 100;
    if (!ok) {
      const Param* ep = ps.find({"encoding", "gamma"}, {ParamType::String, ParamType::Float});
      throw Error(ep ? ep->loc : loc,
                  fmt::format("image texture encoding \"{}\"; expected \"sRGB\", \"linear\" "
                              "or \"gamma G\" with G in (0, 100]",
                              t.encoding));
    }
  }
}

void Builder::texture(const Directive& d) {
  const std::string &name = d.strings[0], &kind_s = d.strings[1], &cls = d.strings[2];
  Texture t;
  t.name = name;
  t.loc = d.loc;
  t.type_as_written = cls;
  if (kind_s == "float")
    t.kind = TextureKind::Float;
  else if (kind_s == "spectrum" || kind_s == "color" || kind_s == "rgb")
    t.kind = TextureKind::Spectrum;
  else
    throw Error(d.loc, fmt::format("texture \"{}\": unknown texture type \"{}\" (expected "
                                   "\"float\" or \"spectrum\")",
                                   name, kind_s));
  t.texture_from_world = inverse(gs_.ctm[0]);
  warnIfAnimated(d.loc, "texture transforms");
  ParamSet ps(d.params, d.loc, fmt::format("Texture \"{}\"", cls));
  ps.addDefaults(gs_.texture_attrs);
  const bool f = t.kind == TextureKind::Float;
  auto in = [&](ParamSet::Names names, double def) {
    return f ? floatInput(ps, names, def) : spectrumInput(ps, names, def);
  };
  if (cls == "imagemap") {
    t.type = cls;
    imageMapTexture(t, ps, d.loc);
  } else if (cls == "scale") {
    t.type = cls;
    t.tex1 = in({"tex", "tex1"}, 1);
    if (auto s = floatInput(ps, {"scale"})) {
      t.tex2 = *s;
      t.scale_is_float = true;
    } else {
      t.tex2 = in({"tex2"}, 1);
    }
  } else if (cls == "mix") {
    t.type = cls;
    t.tex1 = in({"tex1"}, 0);
    t.tex2 = in({"tex2"}, 1);
    t.amount = floatInput(ps, {"amount"}, 0.5);
  } else if (cls == "directionmix") {
    t.type = cls;
    t.tex1 = in({"tex1"}, 0);
    t.tex2 = in({"tex2"}, 1);
    if (const Param* p = ps.find({"dir"}, {ParamType::Vector3})) {
      ps.expectCount(*p, 1);
      t.direction = {p->numbers[0], p->numbers[1], p->numbers[2]};
    }
    // pbrt-v4: the direction is given in the texture's space; kept in world space here.
    t.direction = inverse(t.texture_from_world).applyVector(t.direction);
    if (length(t.direction) == 0) throw Error(d.loc, "directionmix: \"dir\" must not be zero");
    t.direction = normalize(t.direction);
  } else if (cls == "checkerboard") {
    t.type = cls;
    readMapping(t, ps);
    t.tex1 = in({"tex1"}, 1);
    t.tex2 = in({"tex2"}, 0);
    t.dimension = ps.getInt({"dimension"}, 2);
    ps.getString({"aamode"}, "closedform");  // pbrt-v2/v3
    if (t.dimension != 2 && t.dimension != 3)
      throw Error(d.loc, fmt::format("checkerboard dimension {} (expected 2 or 3)", t.dimension));
  } else if (cls == "constant") {
    t.type = cls;
    t.tex1 = in({"value"}, 1);
  } else if (cls == "fbm" || cls == "wrinkled" || cls == "windy" || cls == "marble") {
    t.type = cls;
    noiseTexture(t, ps, d.loc, f);
  } else if (cls == "dots") {
    t.type = cls;
    readMapping(t, ps);
    t.tex1 = in({"inside"}, 1);
    t.tex2 = in({"outside"}, 0);
  } else if (cls == "bilerp") {
    t.type = cls;
    readMapping(t, ps);
    t.v00 = in({"v00"}, 0);
    t.v01 = in({"v01"}, 1);
    t.v10 = in({"v10"}, 0);
    t.v11 = in({"v11"}, 1);
  } else {
    ps.markAllUsed();
    t.type = "constant";
    t.tex1 = f ? floatInput(ps, {"__none__"}, 0.5) : spectrumInput(ps, {"__none__"}, 0.5);
    warnOnce(
        "texture " + cls, d.loc,
        fmt::format("texture \"{}\" is not rendered by lensim; it renders as a constant 0.5", cls));
  }
  if ((t.mapping != "uv" || (t.type == "checkerboard" && t.dimension == 3)) &&
      t.texture_from_world.isSingular())
    throw Error(d.loc, fmt::format("texture \"{}\": its {} mapping uses the current "
                                   "transformation matrix, which is singular (not invertible)",
                                   name, t.mapping != "uv" ? t.mapping : "3-D"));
  finish(ps);
  auto& map = f ? float_textures_ : spectrum_textures_;
  if (map.count(name))
    warn(d.loc, fmt::format("{} texture \"{}\" redefined", f ? "float" : "spectrum", name));
  scene_.textures.push_back(std::move(t));
  map[name] = static_cast<int>(scene_.textures.size()) - 1;
}

}  // namespace lensim::scene::detail
