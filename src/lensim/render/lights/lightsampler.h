// Light samplers: how next-event estimation picks one light, as pbrt-v4 does (src/pbrt/
// lightsamplers.{h,cpp}), selected by the integrator's "string lightsampler":
//   - "bvh" (the default): a bounding-volume hierarchy over the lights with positions, each node
//     holding LightBounds (box, emission cone, power); descended by the nodes' importance to the
//     shading point, so near, bright lights that face the point are chosen more often. Lights
//     without a position (infinite, distant) share 1 / (their count + 1) uniformly.
//   - "power": in proportion to emitted power; "uniform": 1 / count;
//   - "exhaustive": the bvh importance of every light, evaluated for every choice (for tests).
// Every sampler is unbiased: a light that can illuminate the point has a non-zero probability,
// and pmf() returns exactly the probability sample() uses (the tests check both).
//
// Power is the luminance-weighted power Light::power() (pbrt-v4 takes the spectrum's maximum);
// that changes only which light is chosen how often, never the expected image.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lensim/util/transform.h"
#include "lensim/util/vec.h"

namespace lensim::render {

class Light;

/// A cone of directions around unit w with half-angle acos(cos_theta); cos_theta = -1 is the
/// whole sphere.
struct DirectionCone {
  Vec3 w{0, 0, 1};
  double cos_theta = 1;
  bool empty = true;
  static DirectionCone entireSphere() { return {{0, 0, 1}, -1, false}; }
};
/// The smallest cone (as pbrt-v4's Union(DirectionCone, DirectionCone)) holding both.
DirectionCone unionCones(const DirectionCone& a, const DirectionCone& b);
/// The cone of directions from p that reach the box (its bounding sphere); the whole sphere
/// if p is inside.
DirectionCone boundSubtendedDirections(const Bounds3& b, const Vec3& p);

/// What a light sampler knows of a light (pbrt-v4's LightBounds): where it is (world box), in
/// which directions its surface normals point (w, cos_theta_o), how far beyond them it emits
/// (cos_theta_e), and its power phi.
struct LightBounds {
  Bounds3 bounds;
  Vec3 w{0, 0, 1};
  double phi = 0;
  double cos_theta_o = 1;
  double cos_theta_e = 1;
  bool two_sided = false;

  Vec3 centroid() const { return (bounds.min + bounds.max) * 0.5; }
  /// pbrt-v4's LightBounds::Importance: an upper-bound-like estimate of the light's
  /// contribution at p with shading normal n (n = 0: no cosine factor); 0 where it cannot
  /// illuminate p.
  double importance(const Vec3& p, const Vec3& n) const;
};
LightBounds unionBounds(const LightBounds& a, const LightBounds& b);

/// Where a light is chosen for: the shading point and its shading normal.
struct LightSampleContext {
  Vec3 p;
  Vec3 n{0, 0, 0};
};

struct SampledLight {
  const Light* light = nullptr;
  double pmf = 0;
};

class LightSampler {
 public:
  virtual ~LightSampler() = default;
  /// Chooses a light for ctx with the uniform number u in [0, 1); nullopt if none can
  /// contribute.
  virtual std::optional<SampledLight> sample(const LightSampleContext& ctx, double u) const = 0;
  /// The probability that sample(ctx, .) chooses `light`.
  virtual double pmf(const LightSampleContext& ctx, const Light* light) const = 0;

  /// "bvh", "power", "uniform" or "exhaustive"; throws lensim::Error for another name. Each
  /// light's `index` must be its position in `lights`.
  static std::unique_ptr<LightSampler> create(const std::string& name,
                                              const std::vector<const Light*>& lights);
  /// The names create() accepts.
  static const std::vector<std::string>& names();
};

}  // namespace lensim::render
