// Builder: pbrt-v4's "hair" material, its parameters as HairMaterial::Create reads them
// (pbrt-v4 src/pbrt/materials.cpp): the absorption from "sigma_a", else "reflectance" (or its
// older name "color", which pbrt-v3 scenes use), else "eumelanin"/"pheomelanin"; with none of
// them eumelanin 1.3 (brown). The others are ignored with a warning, as pbrt-v4 does. "eta"
// 1.55, "beta_m" 0.3, "beta_n" 0.3 and "alpha" 2 (degrees), all float textures.
#include "lensim/scene/build/builder_internal.h"

namespace lensim::scene::detail {

HairParams Builder::hairMaterial(ParamSet& ps, const FileLoc& loc) {
  HairParams m;
  const std::optional<Input> sigma_a = spectrumInput(ps, {"sigma_a"});
  const char* reflectance_name = ps.peek({"reflectance"}) ? "reflectance" : "color";
  const std::optional<Input> reflectance = spectrumInput(ps, {reflectance_name});
  const std::optional<Input> eumelanin = floatInput(ps, {"eumelanin"});
  const std::optional<Input> pheomelanin = floatInput(ps, {"pheomelanin"});
  auto ignoring = [&](const char* name, bool given, const char* because) {
    if (given)
      warn(ps.peek({name}) ? ps.peek({name})->loc : loc,
           fmt::format("hair: \"{}\" is ignored since \"{}\" was given (as in pbrt-v4)", name,
                       because));
  };
  if (sigma_a) {
    m.absorption = HairParams::Absorption::SigmaA;
    m.sigma_a = *sigma_a;
    ignoring(reflectance_name, reflectance.has_value(), "sigma_a");
    ignoring("eumelanin", eumelanin.has_value(), "sigma_a");
    ignoring("pheomelanin", pheomelanin.has_value(), "sigma_a");
  } else if (reflectance) {
    m.absorption = HairParams::Absorption::Reflectance;
    m.reflectance = *reflectance;
    ignoring("eumelanin", eumelanin.has_value(), reflectance_name);
    ignoring("pheomelanin", pheomelanin.has_value(), reflectance_name);
  } else {
    m.absorption = HairParams::Absorption::Melanin;
    if (eumelanin || pheomelanin) {
      m.eumelanin = eumelanin.value_or(Input{});
      m.pheomelanin = pheomelanin.value_or(Input{});
    } else {
      m.eumelanin.value = 1.3;  // pbrt-v4's default: brown hair
    }
  }
  m.eta = floatInput(ps, {"eta"}, 1.55);
  m.beta_m = floatInput(ps, {"beta_m"}, 0.3);
  m.beta_n = floatInput(ps, {"beta_n"}, 0.3);
  m.alpha = floatInput(ps, {"alpha"}, 2);
  return m;
}

}  // namespace lensim::scene::detail
