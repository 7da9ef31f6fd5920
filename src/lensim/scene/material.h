// The materials of a scene: what every material has (name, where it was written, bump or normal
// map) and the parameters of its kind, one struct per kind, read by scene/build/materials.cpp
// (pbrt-v4's names and defaults; pbrt-v3's for its materials) and turned into a BxDF by
// render/materials/ (materials.cpp dispatches on the kind). Adding a material: see
// docs/developer-guide.md, "Adding a material".
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>

#include "lensim/scene/scene_values.h"
#include "lensim/util/error.h"

namespace lensim::scene {

/// Microfacet roughness along u and v (float inputs, 0 = smooth), remapped to the distribution's
/// alpha unless `remap` is false.
struct Roughness {
  Input u, v;
  bool remap = true;
};

/// The medium between a coating and its base (pbrt-v4's layered materials): its thickness,
/// single-scattering albedo and asymmetry g, and the random walk's length and walk count.
struct LayerInputs {
  Input thickness, albedo, g;
  int max_depth = 10, n_samples = 1;
};

/// A conductor's complex index: eta and k spectra, or (pbrt-v4's "reflectance") eta 1 and the k
/// of the given normal-incidence reflectance when `has_reflectance`.
struct ConductorIndex {
  Input eta, k, reflectance;
  bool has_reflectance = false;
};

/// "diffuse" (pbrt-v4) and "matte" (pbrt-v1–v3: Oren–Nayar when sigma, in degrees, is > 0).
struct DiffuseParams {
  Input reflectance, sigma;
};
/// "coateddiffuse": a dielectric of index eta over a diffuse base.
struct CoatedDiffuseParams {
  Input reflectance;
  Roughness roughness;
  Input eta;  ///< a float in `value`, a float texture or a spectrum
  LayerInputs layer;
};
/// "coatedconductor": a dielectric interface over a conductor.
struct CoatedConductorParams {
  Roughness interface_roughness, conductor_roughness;
  Input interface_eta;
  ConductorIndex conductor;
  LayerInputs layer;
};
/// "conductor" (pbrt-v4).
struct ConductorParams {
  ConductorIndex index;
  Roughness roughness;
};
/// "dielectric".
struct DielectricParams {
  Input eta;
  Roughness roughness;
};
/// "thindielectric".
struct ThinDielectricParams {
  Input eta;
};
/// "diffusetransmission": reflectance and transmittance, both times `scale`.
struct DiffuseTransmissionParams {
  Input reflectance, transmittance;
  double scale = 1;
};
/// "mix": two materials (indices into Scene::materials); `amount` is the probability of the
/// second.
struct MixParams {
  std::array<int, 2> materials{-1, -1};
  Input amount;
};
/// "interface" (and pbrt's "" / "none"): marks a medium boundary; rays pass.
struct InterfaceParams {};
/// "subsurface" (pbrt-v4's SubsurfaceMaterial): a dielectric boundary of `eta` and roughness
/// over a volume whose sigma_a and sigma_s (1/scene unit, times `scale`) come from `preset` (a
/// measured medium, g 0) or are given; or from `reflectance` with the mean free path `mfp`.
/// Each a constant or a spectrum texture, evaluated where a path enters the shape
/// (render/media/subsurface.h).
struct SubsurfaceParams {
  Input eta;
  Roughness roughness;
  Input sigma_a, sigma_s, reflectance, mfp;
  bool from_reflectance = false;
  std::string preset;
  double g = 0;
  double scale = 1;
};
/// "measured": an RGL .bsdf tensor file or a pbrt-v2 .brdf text file (resolved path).
struct MeasuredParams {
  std::string file;
  bool rgl = false;
};
/// "hair" (pbrt-v4's HairMaterial, render/materials/hair.h): the absorption from one of sigma_a,
/// reflectance or the melanin concentrations; eta (float), beta_m, beta_n and alpha (degrees).
struct HairParams {
  enum class Absorption { SigmaA, Reflectance, Melanin };
  Absorption absorption = Absorption::Melanin;
  Input sigma_a, reflectance, eumelanin, pheomelanin;
  Input eta, beta_m, beta_n, alpha;
};
// pbrt-v3's materials, rendered as pbrt-v3 defines them (render/materials/v3materials.h).
/// "plastic": Kd Lambertian and Ks microfacet reflection.
struct PlasticParams {
  Input kd, ks;
  Roughness roughness;
};
/// "substrate": pbrt-v3's FresnelBlend of Kd and Ks.
struct SubstrateParams {
  Input kd, ks;
  Roughness roughness;
};
/// "uber": Kd, Ks, Kr, Kt and opacity; eta a float or float texture.
struct UberParams {
  Input kd, ks, kr, kt, opacity, eta;
  Roughness roughness;
};
/// "translucent": Kd and Ks, scaled by `reflect` and `transmit`.
struct TranslucentParams {
  Input kd, ks, reflect, transmit;
  Roughness roughness;
};
/// "glass": Kr, Kt and eta; smooth or microfacet.
struct GlassParams {
  Input kr, kt, eta;
  Roughness roughness;
};
/// "metal": pbrt-v3's conductor (its roughness remapped as pbrt-v3 does).
struct MetalParams {
  Input eta, k;
  Roughness roughness;
};
/// "mirror": a specular reflection of Kr at every angle.
struct MirrorParams {
  Input kr;
};
/// "fourier": pbrt-v3's tabulated BSDF (resolved path of its "bsdffile").
struct FourierParams {
  std::string file;
};

/// The parameters of each kind; the alternative's index is its MaterialKind.
using MaterialParams =
    std::variant<DiffuseParams, CoatedDiffuseParams, CoatedConductorParams, ConductorParams,
                 DielectricParams, ThinDielectricParams, DiffuseTransmissionParams, MixParams,
                 InterfaceParams, SubsurfaceParams, MeasuredParams, HairParams, PlasticParams,
                 SubstrateParams, UberParams, TranslucentParams, GlassParams, MetalParams,
                 MirrorParams, FourierParams>;

/// The material lensim renders, decided once when the scene is built, so that shading switches
/// on it instead of comparing type names per hit; the index of its MaterialParams alternative.
enum class MaterialKind : uint8_t {
  Diffuse,
  CoatedDiffuse,
  CoatedConductor,
  Conductor,
  Dielectric,
  ThinDielectric,
  DiffuseTransmission,
  Mix,
  Interface,
  Subsurface,
  Measured,
  Hair,
  // pbrt-v3 materials, rendered as pbrt-v3 defines them (render/materials/v3materials.h).
  Plastic,
  Substrate,
  Uber,
  Translucent,
  Glass,
  Metal,
  Mirror,
  Fourier,
};
static_assert(std::variant_size_v<MaterialParams> == size_t(MaterialKind::Fourier) + 1);
static_assert(
    std::is_same_v<std::variant_alternative_t<size_t(MaterialKind::Fourier), MaterialParams>,
                   FourierParams>);

/// True for the pbrt-v3 kinds of render/materials/v3materials.h (plastic ... mirror).
inline bool isV3Kind(MaterialKind k) {
  return k >= MaterialKind::Plastic && k <= MaterialKind::Mirror;
}

/// A material description. `type` is the name of the kind lensim renders (pbrt-v4's diffuse,
/// coateddiffuse, coatedconductor, conductor, dielectric, thindielectric, diffusetransmission,
/// mix, interface, subsurface, measured, hair; pbrt-v3's plastic, substrate, uber, translucent,
/// glass, metal, mirror, fourier); `params` holds that kind's parameters.
struct Material {
  std::string name;  ///< set for MakeNamedMaterial
  std::string type;
  std::string type_as_written;
  FileLoc loc;
  MaterialParams params;
  std::optional<Input> displacement;
  std::string normal_map;  ///< resolved path
  /// The type in the file is not rendered; the material renders as diffuse grey 0.5.
  bool fallback = false;

  MaterialKind kind() const { return static_cast<MaterialKind>(params.index()); }
  /// The parameters of kind P; throws std::bad_variant_access for another kind.
  template <class P>
  const P& as() const {
    return std::get<P>(params);
  }
};

}  // namespace lensim::scene
