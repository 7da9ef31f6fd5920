// Participating media. See media.h.
#include "lensim/render/media.h"

#include "lensim/render/textures.h"
#include "lensim/scene/builder.h"

namespace lensim::render {

HomogeneousMedium::HomogeneousMedium(const scene::Medium& m) {
  // pbrt-v4: sigma_a and sigma_s are unbounded spectra; Le an illuminant, divided by its
  // luminance unless given as RGB (whose illuminant already has unit luminance here).
  sigma_a_ = makeSpectrum(m.sigma_a, SpectrumType::Unbounded);
  sigma_s_ = makeSpectrum(m.sigma_s, SpectrumType::Unbounded);
  const bool rgb = m.Le.kind == scene::SpectrumValue::Kind::Rgb;
  Le_ = makeSpectrum(m.Le, rgb ? SpectrumType::Illuminant : SpectrumType::Unbounded);
  scale_ = m.scale;
  Le_scale_ = m.Le_scale;
  if (!rgb) {
    const double y = luminance(*Le_);
    Le_scale_ = y > 0 ? Le_scale_ / y : 0;
  }
  g_ = m.g;
  emissive_ = Le_->maxValue() * Le_scale_ > 0;
}

MediumProperties HomogeneousMedium::at(const Vec3&, const SampledWavelengths& lambda) const {
  MediumProperties mp;
  mp.sigma_a = sigma_a_->sample(lambda) * scale_;
  mp.sigma_s = sigma_s_->sample(lambda) * scale_;
  if (emissive_) mp.Le = Le_->sample(lambda) * Le_scale_;
  return mp;
}

void HomogeneousMedium::majorants(const Vec3&, const Vec3&, double tmax,
                                  const SampledWavelengths& lambda, const SegmentFn& fn) const {
  fn(0, tmax, (sigma_a_->sample(lambda) + sigma_s_->sample(lambda)) * scale_);
}

Media::Media(const scene::Scene& scene) {
  for (const scene::Medium& m : scene.media) {
    if (m.type == "homogeneous")
      media_.push_back(std::make_unique<HomogeneousMedium>(m));
    else
      media_.push_back(nullptr);
    any_ = any_ || media_.back() != nullptr;
  }
}

Media::~Media() = default;

}  // namespace lensim::render
