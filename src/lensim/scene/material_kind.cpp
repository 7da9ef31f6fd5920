// scene::MaterialKind from the material type names the builder sets (scene/build/materials.cpp).
#include <array>
#include <utility>

#include "lensim/scene/builder.h"

namespace lensim::scene {

std::optional<MaterialKind> materialKindOf(std::string_view type) {
  using K = MaterialKind;
  static constexpr std::array<std::pair<std::string_view, MaterialKind>, 20> kNames{{
      {"diffuse", K::Diffuse},
      {"coateddiffuse", K::CoatedDiffuse},
      {"coatedconductor", K::CoatedConductor},
      {"conductor", K::Conductor},
      {"dielectric", K::Dielectric},
      {"thindielectric", K::ThinDielectric},
      {"diffusetransmission", K::DiffuseTransmission},
      {"mix", K::Mix},
      {"interface", K::Interface},
      {"subsurface", K::Subsurface},
      {"measured", K::Measured},
      {"hair", K::Hair},
      {"plastic", K::Plastic},
      {"substrate", K::Substrate},
      {"uber", K::Uber},
      {"translucent", K::Translucent},
      {"glass", K::Glass},
      {"metal", K::Metal},
      {"mirror", K::Mirror},
      {"fourier", K::Fourier},
  }};
  for (const auto& [name, kind] : kNames)
    if (name == type) return kind;
  return std::nullopt;
}

}  // namespace lensim::scene
