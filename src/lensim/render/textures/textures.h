// Textures and constant inputs of materials and lights, prepared from the scene descriptions
// for evaluation at surface points over sampled wavelengths (pbrt-v4 semantics: textures
// evaluate to spectra; RGB values become spectra through the sigmoid-polynomial upsampling).
//
// Texture classes: constant, scale, mix, directionmix (|n . dir| of tex1), checkerboard (2-D and
// 3-D), imagemap (any format io::readImage reads; bilinear lookup, wrap
// repeat/clamp/black/octahedralsphere as repeat, scale, invert; 8-bit files are sRGB-decoded
// unless "encoding" says otherwise), the
// procedural fbm, wrinkled, windy, marble, dots and bilerp (procedural.h). Mappings:
// uv, spherical, cylindrical, planar with uscale/vscale/udelta/vdelta.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lensim/render/spectra/spectrum.h"
#include "lensim/util/vec.h"

namespace lensim::scene {
struct Scene;
struct Input;
struct SpectrumValue;
}  // namespace lensim::scene

namespace lensim::render {

/// How an RGB value becomes a spectrum (pbrt-v4's SpectrumType).
enum class SpectrumType { Albedo, Unbounded, Illuminant };

/// The surface point a texture is evaluated at (world space).
struct TextureEvalContext {
  Vec3 p;
  Vec2 uv;
  Vec3 n{0, 0, 0};  ///< shading normal (for directionmix); zero when unknown
};

/// A spectrum from a scene value (RGB, blackbody, tabulated, named or file).
SpectrumPtr makeSpectrum(const scene::SpectrumValue& v, SpectrumType type);
/// pbrt-v4 named spectra that render/spectrum.h does not tabulate: glass-BK7 (Schott's Sellmeier
/// formula), glass-BAF10, -FK51A, -LASF9, -F5, -F10, -F11 (Schott N-BAF10, N-FK51A, N-LASF9, SF5,
/// SF10, SF11 from the glass catalogue) and stdillum-A (blackbody 2856 K) exactly; other glasses
/// a constant 1.5, other metals
/// copper, other illuminants D65, each with a warning (once per name).
SpectrumPtr fallbackNamedSpectrum(const std::string& name);
/// Luminance Y of a spectrum relative to an equal-energy spectrum of value 1 (lensim's
/// normalisation of CIE Y); the factor pbrt-v4 divides light spectra by is this Y.
double luminance(const Spectrum& s);

class Textures {
 public:
  /// Loads every image texture of the scene; throws lensim::Error for unreadable images.
  explicit Textures(const scene::Scene& scene);
  ~Textures();
  /// The value of a float input at ctx.
  double evalFloat(const scene::Input& in, const TextureEvalContext& ctx) const;
  /// The value of a spectrum input at ctx (a texture, or the constant upsampled as `type`).
  SampledSpectrum evalSpectrum(const scene::Input& in, const TextureEvalContext& ctx,
                               const SampledWavelengths& lambda, SpectrumType type) const;
  /// The constant of a spectrum input as a spectrum (cached; thread-safe).
  SpectrumPtr constant(const scene::SpectrumValue& v, SpectrumType type) const;
  /// The same spectrum, for per-hit use: a per-thread cache lookup, no lock and no reference
  /// count. Valid while this Textures lives.
  const Spectrum& constantRef(const scene::SpectrumValue& v, SpectrumType type) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace lensim::render
