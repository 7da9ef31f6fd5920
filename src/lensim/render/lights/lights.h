// Lights with pbrt-v4's semantics: point, spot, goniometric, projection, distant, diffuse area
// lights on any shape (one-sided unless "twosided"), uniform infinite lights and image infinite
// lights (environment maps: equal-area octahedral for square images as pbrt-v4 writes them, else
// latitude-longitude as pbrt-v2's "mapname"), importance sampled by luminance. Emission spectra are
// normalised to unit luminance except RGB (whose illuminant already has Y = 1), then multiplied by
// "scale", and "power" (or illuminance for distant lights) rescales them as pbrt-v4 does.
//
// Units: radiance L in the film's units (an RGB L of (1,1,1) reads (1,1,1) on the film),
// intensity I = radiance x m^2; pdfs per steradian of the direction from the shading point.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "lensim/render/lights/lightsampler.h"
#include "lensim/render/shapes/accel.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/sampling/sampling.h"

namespace lensim::scene {
struct Light;
struct Scene;
}  // namespace lensim::scene

namespace lensim::render {

class Textures;

/// Incident radiance sampled from a light toward a point.
struct LightLiSample {
  SampledSpectrum L;  ///< radiance arriving along -wi (weighted by 1/r^2 for point lights)
  Vec3 wi;            ///< unit direction from the point toward the light
  double pdf = 0;     ///< per steradian, or 1 for delta lights
  Vec3 p_light;       ///< point on the light (far away for distant/infinite lights)
  bool infinite = false;
  Vec3 n_light{0, 0, 0};  ///< the surface normal at p_light (area lights); zero otherwise
};

/// A ray leaving a light (light tracing, bidirectional methods): pbrt-v4's LightLeSample.
struct LightLeSample {
  Vec3 o, d;                ///< origin on the light, unit direction
  SampledSpectrum L;        ///< radiance leaving along d (intensity for point lights)
  double pdf_pos = 0;       ///< per unit area of the light's surface (1 for a point light: a delta)
  double pdf_dir = 0;       ///< per steradian of d
  bool on_surface = false;  ///< an area light: n is its surface normal at o (the side of d
                            ///< for two-sided lights is not implied)
  Vec3 n;
  Vec2 uv;  ///< surface (u, v) at o (area lights; for image emission)
};

class Light {
 public:
  virtual ~Light() = default;
  /// Position in the list given to the light sampler (set by LightSet; -1 outside one), so that
  /// samplers find a light's data without a hash lookup.
  int index = -1;
  /// pbrt-v1–v3 "nsamples": the light samples per hit of the directlighting integrator's "all"
  /// strategy (set by LightSet from the scene light).
  int n_samples = 1;
  /// The medium light paths start in (Scene::media index; -1 vacuum): area lights, that of
  /// their shape `shape` on the side they leave by (lightMedium, bdpt.h); other lights, the
  /// outside medium of the MediumInterface current at their LightSource (pbrt-v4).
  int shape = -1;
  int medium = -1;
  /// Point and directional lights (no surface to hit).
  virtual bool isDelta() const { return false; }
  virtual bool isInfinite() const { return false; }
  /// Light arriving from one direction (distant lights): no point on it can be connected to
  /// (pbrt-v4's LightType::DeltaDirection).
  virtual bool isDeltaDirection() const { return false; }
  /// A sample of incident light at world point p.
  virtual std::optional<LightLiSample> sampleLi(const Vec3& p, Vec2 u,
                                                const SampledWavelengths& lambda) const = 0;
  /// Solid-angle density of sampleLi at p producing direction wi that reaches the light at
  /// `hit` (area lights) or escapes (infinite lights; hit is null).
  virtual double pdfLi(const Vec3& p, const Vec3& wi, const SurfaceHit* hit) const {
    (void)p, (void)wi, (void)hit;
    return 0;
  }
  /// Radiance an area light emits from its surface point `hit` toward w.
  virtual SampledSpectrum L(const SurfaceHit& hit, const Vec3& w,
                            const SampledWavelengths& lambda) const {
    (void)hit, (void)w, (void)lambda;
    return {};
  }
  /// Radiance an infinite light sends along a ray that escapes in direction dir.
  virtual SampledSpectrum Le(const Vec3& dir, const SampledWavelengths& lambda) const {
    (void)dir, (void)lambda;
    return {};
  }
  /// A ray leaving the light, u1 choosing the point and u2 the direction; nullopt if it emits
  /// none there. Lights without emission sampling (supportsLe() false) give nullopt always.
  virtual std::optional<LightLeSample> sampleLe(Vec2 u1, Vec2 u2,
                                                const SampledWavelengths& lambda) const {
    (void)u1, (void)u2, (void)lambda;
    return std::nullopt;
  }
  /// Densities of sampleLe giving the ray from the light point o (normal n; unused for point
  /// lights) in direction d: {pdf_pos, pdf_dir}.
  virtual std::pair<double, double> pdfLe(const Vec3& o, const Vec3& n, const Vec3& d) const {
    (void)o, (void)n, (void)d;
    return {0, 0};
  }
  /// Whether sampleLe is implemented (every light type lensim has).
  virtual bool supportsLe() const { return false; }
  /// The light's type, for messages.
  virtual const char* typeName() const { return "unnamed"; }
  /// Emitted power (luminance-weighted), for choosing lights in proportion to it.
  virtual double power() const = 0;
  /// Where the light is and where it emits, for the BVH light sampler (pbrt-v4's
  /// Light::Bounds()); nullopt for lights without a position (infinite, distant).
  virtual std::optional<LightBounds> bounds() const { return std::nullopt; }
};

/// All lights of a scene and the light choice for next-event estimation: the scene's
/// integrator "lightsampler" (bvh, the default; power; uniform; exhaustive), see lightsampler.h.
class LightSet {
 public:
  LightSet(const scene::Scene& scene, const Accel& accel, const Textures& textures);
  ~LightSet();
  size_t size() const { return lights_.size(); }
  const Light& light(size_t i) const { return *lights_[i]; }
  /// Lights that rays escaping the scene see.
  const std::vector<const Light*>& infinite() const { return infinite_; }
  /// The area light of a shape's face, or nullptr.
  const Light* areaLight(int shape, int prim) const;
  /// Chooses a light for the shading point ctx (see the class comment); nullopt if none can
  /// contribute there.
  struct Choice {
    const Light* light;
    double pmf;
  };
  std::optional<Choice> sample(const LightSampleContext& ctx, double u) const;
  /// Probability that sample(ctx, .) chooses `light`.
  double pmf(const LightSampleContext& ctx, const Light* light) const;
  /// The light sampler's name.
  const std::string& samplerName() const { return sampler_name_; }

 private:
  /// Adds the light `l` (a type other than "diffuse"); radius and centre bound the scene.
  void addLight(const scene::Light& l, const Textures& textures, double radius,
                const Vec3& centre);
  /// Adds the lights of the shapes with an area light (area_lights.cpp).
  void addAreaLights(const scene::Scene& scene, const Accel& accel, const Textures& textures);

  std::vector<std::unique_ptr<Light>> lights_;
  std::vector<const Light*> infinite_;
  std::vector<int> shape_first_light_;  ///< per shape: index of its first light, or -1
  std::unique_ptr<LightSampler> sampler_;
  std::string sampler_name_;
};

}  // namespace lensim::render
