// Texture evaluation. Facts from pbrt-v4 (Pharr, Jakob, Humphreys, 4th ed., ch. 10): image
// textures flip t (row 0 is the top of the image), bilinear lookups put texel centres at
// half-integers, the checkerboard alternates on floor(s) + floor(t), the spherical mapping is
// (theta / pi, phi / 2pi) of the direction from the texture-space origin, the cylindrical
// ((pi + atan2(y, x)) / 2pi, z).
#include "lensim/render/textures/textures.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <unordered_map>

#include "lensim/io/image.h"
#include "lensim/optics/glass.h"
#include "lensim/render/textures/procedural.h"
#include "lensim/sampling/sampling.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "lensim/util/file.h"
#include "lensim/util/log.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

struct RgbImage {
  int width = 0, height = 0;
  std::vector<float> rgb;  ///< 3 per texel, linear
};

RgbImage loadRgb(const scene::Texture& t) {
  // 8- and 16-bit files are decoded with the texture's "encoding" (sRGB by default), float files
  // are linear (io/image.h).
  io::Image im = io::readImage(t.filename, {.encoding = t.encoding});
  RgbImage out;
  out.width = im.width;
  out.height = im.height;
  out.rgb.resize(size_t(im.width) * size_t(im.height) * 3);
  const int nc = im.channelCount();
  // R, G, B by name; a grey image (Y, or Y and A) gives Y to all three; else the first channels.
  const auto y = im.channelIndex("Y");
  auto ch = [&](const char* name, int fallback) {
    if (auto c = im.channelIndex(name)) return *c;
    if (y) return *y;
    return std::min(fallback, nc - 1);
  };
  const int cr = ch("R", 0), cg = ch("G", 1), cb = ch("B", 2);
  for (int yy = 0; yy < im.height; ++yy)
    for (int x = 0; x < im.width; ++x) {
      float* o = &out.rgb[(size_t(yy) * im.width + x) * 3];
      o[0] = im.at(x, yy, cr);
      o[1] = im.at(x, yy, cg);
      o[2] = im.at(x, yy, cb);
    }
  return out;
}

}  // namespace

struct Textures::Impl {
  // A texture's class, wrap mode, mapping and filter, decided once from its strings when the
  // textures are prepared (not per lookup).
  enum class Kind : uint8_t {
    Constant,
    Scale,
    Mix,
    DirectionMix,
    Checkerboard,
    ImageMap,
    Fbm,
    Wrinkled,
    Windy,
    Dots,
    Bilerp,
    Marble,
    Other
  };
  enum class Wrap : uint8_t { Repeat, Black, Clamp };
  enum class Mapping : uint8_t { UV, Spherical, Cylindrical, Planar };
  struct Decided {
    Kind kind = Kind::Other;
    Wrap wrap = Wrap::Repeat;
    Mapping mapping = Mapping::UV;
    bool point_filter = false;
  };
  static Decided decide(const scene::Texture& t) {
    Decided d;
    static const std::pair<const char*, Kind> kinds[] = {{"constant", Kind::Constant},
                                                         {"scale", Kind::Scale},
                                                         {"mix", Kind::Mix},
                                                         {"directionmix", Kind::DirectionMix},
                                                         {"checkerboard", Kind::Checkerboard},
                                                         {"imagemap", Kind::ImageMap},
                                                         {"fbm", Kind::Fbm},
                                                         {"wrinkled", Kind::Wrinkled},
                                                         {"windy", Kind::Windy},
                                                         {"dots", Kind::Dots},
                                                         {"bilerp", Kind::Bilerp},
                                                         {"marble", Kind::Marble}};
    for (const auto& [name, kind] : kinds)
      if (t.type == name) d.kind = kind;
    d.wrap = t.wrap == "black" ? Wrap::Black : t.wrap == "clamp" ? Wrap::Clamp : Wrap::Repeat;
    d.mapping = t.mapping == "spherical"     ? Mapping::Spherical
                : t.mapping == "cylindrical" ? Mapping::Cylindrical
                : t.mapping == "planar"      ? Mapping::Planar
                                             : Mapping::UV;
    d.point_filter = t.filter == "point";
    return d;
  }

  const scene::Scene* scene = nullptr;
  uint64_t serial = 0;
  std::vector<std::shared_ptr<RgbImage>> images;  ///< per texture (null for non-image)
  std::vector<Decided> decided;                   ///< per texture
  /// The decisions for t, an element of scene->textures.
  const Decided& of(const scene::Texture& t) const {
    return decided[size_t(&t - scene->textures.data())];
  }
  mutable std::mutex mutex;
  mutable std::map<std::pair<const scene::SpectrumValue*, int>, SpectrumPtr> constants;

  Vec2 mapping(const scene::Texture& t, const TextureEvalContext& ctx) const {
    const Mapping m = of(t).mapping;
    if (m != Mapping::UV) {
      const Vec3 p = t.texture_from_world.applyPoint(ctx.p);
      if (m == Mapping::Planar) return {t.udelta + dot(t.v1, p), t.vdelta + dot(t.v2, p)};
      if (m == Mapping::Cylindrical) return {(M_PI + std::atan2(p.y, p.x)) / (2 * M_PI), p.z};
      const double len = length(p);
      const Vec3 v = len > 0 ? p / len : Vec3{0, 0, 1};
      double phi = std::atan2(v.y, v.x);
      if (phi < 0) phi += 2 * M_PI;
      return {std::acos(std::clamp(v.z, -1.0, 1.0)) / M_PI, phi / (2 * M_PI)};
    }
    return {t.uscale * ctx.uv.x + t.udelta, t.vscale * ctx.uv.y + t.vdelta};
  }

  /// RGB lookup at st (pbrt-v3/v4 orientation: t = 0 at the bottom row; pbrt-v1/v2 scenes: at
  /// the top row): nearest texel for the "point" filter, bilinear for the others (no
  /// MIP-mapping: lensim has no ray differentials).
  Vec3 lookup(const scene::Texture& t, const RgbImage& im, Vec2 st) const {
    const double row_t = t.rows_from_top ? st.y : 1 - st.y;
    const double x = st.x * im.width - 0.5, y = row_t * im.height - 0.5;
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    const Decided& d = of(t);
    auto texel = [&](int xi, int yi) -> Vec3 {
      if (d.wrap == Wrap::Black) {
        if (xi < 0 || yi < 0 || xi >= im.width || yi >= im.height) return {0, 0, 0};
      } else if (d.wrap == Wrap::Clamp) {
        xi = std::clamp(xi, 0, im.width - 1);
        yi = std::clamp(yi, 0, im.height - 1);
      } else {
        xi = ((xi % im.width) + im.width) % im.width;
        yi = ((yi % im.height) + im.height) % im.height;
      }
      const float* c = &im.rgb[(size_t(yi) * im.width + xi) * 3];
      return {c[0], c[1], c[2]};
    };
    Vec3 v;
    if (d.point_filter)
      v = texel(int(std::floor(st.x * im.width)), int(std::floor(row_t * im.height)));
    else
      v = (texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx) * (1 - fy) +
          (texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx) * fy;
    v = v * t.scale;
    if (t.invert) v = {std::max(0.0, 1 - v.x), std::max(0.0, 1 - v.y), std::max(0.0, 1 - v.z)};
    return v;
  }

  bool checker(const scene::Texture& t, const TextureEvalContext& ctx) const {
    if (t.dimension == 3) {
      const Vec3 p = t.texture_from_world.applyPoint(ctx.p);
      const long s = long(std::floor(p.x)) + long(std::floor(p.y)) + long(std::floor(p.z));
      return s % 2 == 0;
    }
    const Vec2 st = mapping(t, ctx);
    const long s = long(std::floor(st.x)) + long(std::floor(st.y));
    return s % 2 == 0;
  }
};

namespace {

/// BK7's refractive index by Schott's Sellmeier formula (published catalogue coefficients,
/// wavelength in micrometres): n^2 = 1 + sum B_i l^2 / (l^2 - C_i).
class SellmeierSpectrum final : public Spectrum {
 public:
  SellmeierSpectrum(std::array<double, 3> b, std::array<double, 3> c) : b_(b), c_(c) {}
  double eval(double lambda_nm) const override {
    const double l2 = (lambda_nm / 1000) * (lambda_nm / 1000);
    double n2 = 1;
    for (int i = 0; i < 3; ++i) n2 += b_[size_t(i)] * l2 / (l2 - c_[size_t(i)]);
    return std::sqrt(n2);
  }
  double maxValue() const override { return eval(kLambdaMin_nm); }

 private:
  std::array<double, 3> b_, c_;
};

/// The index of a catalogue glass (optics/glass.h): its vendor's dispersion formula.
class GlassSpectrum final : public Spectrum {
 public:
  explicit GlassSpectrum(optics::Glass g) : g_(std::move(g)) {}
  double eval(double lambda_nm) const override { return g_.index(lambda_nm); }
  double maxValue() const override { return g_.index(kLambdaMin_nm); }

 private:
  optics::Glass g_;
};

}  // namespace

SpectrumPtr fallbackNamedSpectrum(const std::string& name) {
  // pbrt-v4 names whose data lensim does not tabulate: what can be computed exactly is, the
  // rest falls back (said once per name).
  if (name == "glass-BK7")
    return std::make_shared<SellmeierSpectrum>(
        std::array<double, 3>{1.03961212, 0.231792344, 1.01046945},
        std::array<double, 3>{0.00600069867, 0.0200179144, 103.560653});
  // pbrt-v4's other glasses (its tables are these Schott glasses' formulas, sampled): the
  // formulas themselves from the glass catalogue.
  static const std::pair<const char*, const char*> kGlasses[] = {
      {"glass-BAF10", "schott:N-BAF10"}, {"glass-FK51A", "schott:N-FK51A"},
      {"glass-LASF9", "schott:N-LASF9"}, {"glass-F5", "schott:SF5"},
      {"glass-F10", "schott:SF10"},      {"glass-F11", "schott:SF11"}};
  for (const auto& [pbrt_name, catalogue_name] : kGlasses)
    if (name == pbrt_name)
      if (const optics::CatalogGlass* g = optics::GlassCatalog::builtin().find(catalogue_name))
        return std::make_shared<GlassSpectrum>(g->glass);
  if (name == "stdillum-A") {
    // CIE illuminant A is by definition Planckian radiation at 2856 K.
    return std::make_shared<BlackbodySpectrum>(2856);
  }
  static std::mutex mutex;
  static std::set<std::string> warned;
  SpectrumPtr fallback;
  std::string what;
  if (name.rfind("glass-", 0) == 0) {
    fallback = std::make_shared<ConstantSpectrum>(1.5);
    what = "a constant index of 1.5";
  } else if (name.rfind("metal-", 0) == 0) {
    fallback = namedSpectrum(
        name.size() > 2 && name.substr(name.size() - 2) == "-k" ? "metal-Cu-k" : "metal-Cu-eta");
    what = "copper's";
  } else {
    fallback = RGBColorSpace::sRGB().illuminant();
    what = "D65";
  }
  {
    std::lock_guard lock(mutex);
    if (warned.insert(name).second)
      logWarning(
          fmt::format("named spectrum \"{}\" is not tabulated in lensim; {} is used", name, what));
  }
  return fallback;
}

SpectrumPtr makeSpectrum(const scene::SpectrumValue& v, SpectrumType type) {
  using K = scene::SpectrumValue::Kind;
  const RGBColorSpace& cs = RGBColorSpace::sRGB();
  switch (v.kind) {
    case K::Rgb: {
      const Vec3 c = v.rgb;
      if (type == SpectrumType::Albedo)
        return std::make_shared<RGBAlbedoSpectrum>(
            cs,
            Vec3{std::clamp(c.x, 0.0, 1.0), std::clamp(c.y, 0.0, 1.0), std::clamp(c.z, 0.0, 1.0)});
      if (type == SpectrumType::Unbounded) return std::make_shared<RGBUnboundedSpectrum>(cs, c);
      return std::make_shared<RGBIlluminantSpectrum>(cs, c);
    }
    case K::Blackbody: {
      auto b = std::make_shared<BlackbodySpectrum>(v.temperature_k);
      if (v.blackbody_scale == 1) return b;
      std::vector<double> l, s;
      for (double x = kLambdaMin_nm; x <= kLambdaMax_nm; x += 1) {
        l.push_back(x);
        s.push_back(b->eval(x) * v.blackbody_scale);
      }
      return std::make_shared<PiecewiseLinearSpectrum>(l, s);
    }
    case K::Sampled: {
      std::vector<double> l, s;
      for (auto [a, b] : v.samples) l.push_back(a), s.push_back(b);
      return std::make_shared<PiecewiseLinearSpectrum>(l, s);
    }
    case K::Named: {
      if (SpectrumPtr s = namedSpectrum(v.name)) return s;
      return fallbackNamedSpectrum(v.name);
    }
    case K::File: {
      // Only a regular file of at most 64 MiB (no FIFO or device).
      std::istringstream in(readRegularFile(v.name, "spectrum file", uint64_t{64} << 20));
      std::string line, text;
      while (std::getline(in, line)) text += line.substr(0, line.find('#')) + "\n";
      std::istringstream ss(text);
      std::vector<double> l, s;
      double a, b;
      while (ss >> a >> b) l.push_back(a), s.push_back(b);
      if (l.size() < 2) throw Error(fmt::format("{}: no (wavelength, value) pairs", v.name));
      return std::make_shared<PiecewiseLinearSpectrum>(l, s);
    }
  }
  return std::make_shared<ConstantSpectrum>(0);
}

double luminance(const Spectrum& s) {
  return spectrumToXyz(s).y;
}

Textures::Textures(const scene::Scene& scene) : impl_(std::make_unique<Impl>()) {
  static std::atomic<uint64_t> next_serial{1};
  impl_->scene = &scene;
  impl_->serial = next_serial++;
  impl_->images.resize(scene.textures.size());
  impl_->decided.reserve(scene.textures.size());
  for (const scene::Texture& t : scene.textures) impl_->decided.push_back(Impl::decide(t));
  std::map<std::string, std::shared_ptr<RgbImage>> by_key;
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const scene::Texture& t = scene.textures[i];
    if (t.type != "imagemap") continue;
    const std::string key = t.filename + "|" + t.encoding;
    auto it = by_key.find(key);
    if (it == by_key.end()) {
      try {
        it = by_key.emplace(key, std::make_shared<RgbImage>(loadRgb(t))).first;
      } catch (const Error& e) {
        throw Error(t.loc, fmt::format("texture \"{}\": {}", t.name, nestedMessage(e)));
      }
    }
    impl_->images[i] = it->second;
  }
}

Textures::~Textures() = default;

SpectrumPtr Textures::constant(const scene::SpectrumValue& v, SpectrumType type) const {
  std::lock_guard lock(impl_->mutex);
  const auto key = std::make_pair(&v, int(type));
  auto it = impl_->constants.find(key);
  if (it == impl_->constants.end()) it = impl_->constants.emplace(key, makeSpectrum(v, type)).first;
  return it->second;
}

const Spectrum& Textures::constantRef(const scene::SpectrumValue& v, SpectrumType type) const {
  // Material constants are looked up at every hit: per-thread caches in front of the shared map
  // (whose lock would serialise the threads, and whose shared_ptr copies would make them contend
  // for the reference count). First a small direct-mapped table, then a hash map. Keys carry
  // this object's serial number so that a later Textures at the same address never sees stale
  // entries; the shared map keeps every spectrum alive as long as this object.
  struct Key {
    uint64_t serial = 0;
    const void* value = nullptr;
    int type = -1;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return size_t(
          hashValues({k.serial, uint64_t(reinterpret_cast<uintptr_t>(k.value)), uint64_t(k.type)}));
    }
  };
  struct Entry {
    Key key;
    const Spectrum* spectrum = nullptr;
  };
  constexpr size_t kDirect = 64;
  thread_local std::array<Entry, kDirect> direct;
  thread_local std::unordered_map<Key, const Spectrum*, KeyHash> local;
  const Key key{impl_->serial, &v, int(type)};
  const uintptr_t a = reinterpret_cast<uintptr_t>(&v);
  Entry& e = direct[((a >> 3) ^ (a >> 9) ^ (uintptr_t(type) << 4)) & (kDirect - 1)];
  if (e.key == key) return *e.spectrum;
  const Spectrum* s;
  if (auto it = local.find(key); it != local.end()) {
    s = it->second;
  } else {
    s = constant(v, type).get();
    if (local.size() > 4096) local.clear();
    local.emplace(key, s);
  }
  e = {key, s};
  return *s;
}

double Textures::evalFloat(const scene::Input& in, const TextureEvalContext& ctx) const {
  if (in.texture < 0) return in.value;
  const scene::Texture& t = impl_->scene->textures[size_t(in.texture)];
  using Kind = Impl::Kind;
  const Kind kind = impl_->decided[size_t(in.texture)].kind;
  if (kind == Kind::Constant) return evalFloat(t.tex1, ctx);
  if (kind == Kind::Scale) return evalFloat(t.tex1, ctx) * evalFloat(t.tex2, ctx);
  if (kind == Kind::Mix) {
    const double a = evalFloat(t.amount, ctx);
    return (1 - a) * evalFloat(t.tex1, ctx) + a * evalFloat(t.tex2, ctx);
  }
  if (kind == Kind::DirectionMix) {
    const double a = std::abs(dot(ctx.n, t.direction));
    return a * evalFloat(t.tex1, ctx) + (1 - a) * evalFloat(t.tex2, ctx);
  }
  if (kind == Kind::Checkerboard)
    return impl_->checker(t, ctx) ? evalFloat(t.tex1, ctx) : evalFloat(t.tex2, ctx);
  if (kind == Kind::ImageMap) {
    const Vec3 v = impl_->lookup(t, *impl_->images[size_t(in.texture)], impl_->mapping(t, ctx));
    return (v.x + v.y + v.z) / 3;
  }
  if (kind == Kind::Fbm || kind == Kind::Wrinkled || kind == Kind::Windy) {
    const Vec3 p = t.texture_from_world.applyPoint(ctx.p);
    if (kind == Kind::Fbm) return fbm(p, t.omega, t.octaves);
    if (kind == Kind::Wrinkled) return turbulence(p, t.omega, t.octaves);
    return windy(p);
  }
  if (kind == Kind::Dots)
    return insidePolkaDot(impl_->mapping(t, ctx)) ? evalFloat(t.tex1, ctx) : evalFloat(t.tex2, ctx);
  if (kind == Kind::Bilerp) {
    const Vec2 st = impl_->mapping(t, ctx);
    return (1 - st.x) * (1 - st.y) * evalFloat(t.v00, ctx) +
           st.x * (1 - st.y) * evalFloat(t.v10, ctx) + (1 - st.x) * st.y * evalFloat(t.v01, ctx) +
           st.x * st.y * evalFloat(t.v11, ctx);
  }
  return 0.5;
}

SampledSpectrum Textures::evalSpectrum(const scene::Input& in, const TextureEvalContext& ctx,
                                       const SampledWavelengths& lambda, SpectrumType type) const {
  if (in.texture < 0) return constantRef(in.spectrum, type).sample(lambda);
  const scene::Texture& t = impl_->scene->textures[size_t(in.texture)];
  using Kind = Impl::Kind;
  const Kind kind = impl_->decided[size_t(in.texture)].kind;
  if (kind == Kind::Constant) return evalSpectrum(t.tex1, ctx, lambda, type);
  if (kind == Kind::Scale) {
    const SampledSpectrum a = evalSpectrum(t.tex1, ctx, lambda, type);
    if (t.scale_is_float) return a * evalFloat(t.tex2, ctx);
    return a * evalSpectrum(t.tex2, ctx, lambda, type);
  }
  if (kind == Kind::Mix) {
    const double a = evalFloat(t.amount, ctx);
    return evalSpectrum(t.tex1, ctx, lambda, type) * (1 - a) +
           evalSpectrum(t.tex2, ctx, lambda, type) * a;
  }
  if (kind == Kind::DirectionMix) {
    const double a = std::abs(dot(ctx.n, t.direction));
    return evalSpectrum(t.tex1, ctx, lambda, type) * a +
           evalSpectrum(t.tex2, ctx, lambda, type) * (1 - a);
  }
  if (kind == Kind::Checkerboard)
    return impl_->checker(t, ctx) ? evalSpectrum(t.tex1, ctx, lambda, type)
                                  : evalSpectrum(t.tex2, ctx, lambda, type);
  if (kind == Kind::ImageMap) {
    Vec3 rgb = impl_->lookup(t, *impl_->images[size_t(in.texture)], impl_->mapping(t, ctx));
    rgb = {std::max(0.0, rgb.x), std::max(0.0, rgb.y), std::max(0.0, rgb.z)};
    double scale = 1;
    if (type == SpectrumType::Albedo) {
      rgb = {std::min(1.0, rgb.x), std::min(1.0, rgb.y), std::min(1.0, rgb.z)};
    } else {
      const double m = std::max({rgb.x, rgb.y, rgb.z});
      scale = 2 * m;
      if (scale > 0) rgb = rgb / scale;
    }
    const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(rgb);
    SampledSpectrum s = poly.sample(lambda) * scale;
    if (type == SpectrumType::Illuminant) s *= RGBColorSpace::sRGB().illuminant()->sample(lambda);
    return s;
  }
  if (kind == Kind::Dots)
    return insidePolkaDot(impl_->mapping(t, ctx)) ? evalSpectrum(t.tex1, ctx, lambda, type)
                                                  : evalSpectrum(t.tex2, ctx, lambda, type);
  if (kind == Kind::Bilerp) {
    const Vec2 st = impl_->mapping(t, ctx);
    return evalSpectrum(t.v00, ctx, lambda, type) * ((1 - st.x) * (1 - st.y)) +
           evalSpectrum(t.v10, ctx, lambda, type) * (st.x * (1 - st.y)) +
           evalSpectrum(t.v01, ctx, lambda, type) * ((1 - st.x) * st.y) +
           evalSpectrum(t.v11, ctx, lambda, type) * (st.x * st.y);
  }
  if (kind == Kind::Marble) {
    // pbrt-v4's MarbleTexture: an RGB albedo whatever the spectrum type.
    const Vec3 p = t.texture_from_world.applyPoint(ctx.p) * t.scale;
    Vec3 rgb = marbleRgb(p, t.octaves, t.omega, t.variation);
    rgb = {std::clamp(rgb.x, 0.0, 1.0), std::clamp(rgb.y, 0.0, 1.0), std::clamp(rgb.z, 0.0, 1.0)};
    const SigmoidPolynomial poly = RGBColorSpace::sRGB().tableSigmoid(rgb);
    return poly.sample(lambda);
  }
  return SampledSpectrum(0.5);
}

}  // namespace lensim::render
