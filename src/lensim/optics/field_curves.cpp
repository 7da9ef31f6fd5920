#include "lensim/optics/field_curves.h"

#include <fmt/format.h>

#include <cmath>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/mtf.h"
#include "lensim/util/plot.h"

namespace lensim::optics {

namespace {

struct Emerging {
  Vec3 o, d;
};

std::optional<Emerging> emerge(const LensSystem& lens, const Ray& ray) {
  // Apertures ignored: the thin bundle about a vignetted chief ray still has its foci.
  TraceResult r = lens.tracer().traceFromScene(ray, TraceOptions{false});
  if (!r.ok() || !(r.ray.direction.z > 0)) return std::nullopt;
  return Emerging{r.ray.origin, r.ray.direction};
}

}  // namespace

FieldCurves computeFieldCurves(const SpectralLens& sl, double film_diagonal_mm, int samples) {
  const FocusedLens& fl = *sl.focused;
  const LensSystem& lens0 = sl.at(sl.primaryNm());
  const double film_z = fl.lens->filmZ_mm();
  FieldCurves c;
  c.wavelengths = sl.wavelengths;
  c.distortion = computeDistortion(fl, film_diagonal_mm);
  const FieldOfView fov = fieldOfView(lens0, fl.paraxial, film_diagonal_mm);
  const double h_max =
      fov.real_deg ? film_diagonal_mm / 2 : 0.999 * *fov.image_circle_diameter_mm / 2;
  c.tangential_mm.resize(sl.wavelengths.size());
  c.sagittal_mm.resize(sl.wavelengths.size());
  for (int k = 0; k <= samples; ++k) {
    const double h = h_max * k / samples;
    auto b = FieldBundle::fromFilmHeight(fl, lens0, h);
    if (!b) continue;
    c.film_height_mm.push_back(b->film_height_mm);
    c.field_angle_deg.push_back(b->field_angle_deg);
    const double delta = 1e-3 * b->pupil_radius_mm;
    for (size_t w = 0; w < sl.wavelengths.size(); ++w) {
      const LensSystem& lens = sl.at(sl.wavelengths[w].nm);
      double zt = std::nan(""), zs = std::nan("");
      auto a = emerge(lens, b->sceneRay({-delta, 0}));
      auto bb = emerge(lens, b->sceneRay({delta, 0}));
      if (a && bb) {
        // x_a + m_a (z - z_a) = x_b + m_b (z - z_b)
        const double ma = a->d.x / a->d.z, mb = bb->d.x / bb->d.z;
        const double xa = a->o.x - ma * a->o.z, xb = bb->o.x - mb * bb->o.z;  // at z = 0
        if (std::abs(ma - mb) > 1e-15) zt = (xb - xa) / (ma - mb);
      }
      if (auto s = emerge(lens, b->sceneRay({0, delta}))) {
        if (std::abs(s->d.y) > 1e-15) zs = s->o.z - s->o.y * s->d.z / s->d.y;
      }
      c.tangential_mm[w].push_back(zt - film_z);
      c.sagittal_mm[w].push_back(zs - film_z);
    }
  }
  return c;
}

std::string fieldCurvesSvg(const FocusedLens& fl, const FieldCurves& c) {
  svg::Document doc(1000, 470);
  doc.rect(0, 0, 1000, 470, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Field curvature and distortion — " + analysisSubtitle(fl, c.wavelengths),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  plot::Chart fc;
  fc.title = "focus of thin bundles about the chief ray; solid T, dashed S";
  fc.x_label = "focus behind the film (mm)";
  fc.y_label = "field angle (deg)";
  double e = 1e-3;
  for (size_t w = 0; w < c.wavelengths.size(); ++w)
    for (size_t k = 0; k < c.field_angle_deg.size(); ++k)
      for (double v : {c.tangential_mm[w][k], c.sagittal_mm[w][k]})
        if (std::isfinite(v)) e = std::max(e, std::abs(v));
  fc.x_range = {-1.05 * e, 1.05 * e};
  for (size_t w = 0; w < c.wavelengths.size(); ++w) {
    const std::string col = plot::paletteColor(static_cast<int>(w));
    plot::Series t{fmt::format("T {:.1f} nm", c.wavelengths[w].nm), col, plot::Style::Line, {}};
    plot::Series s{fmt::format("S {:.1f} nm", c.wavelengths[w].nm), col, plot::Style::Dashed, {}};
    for (size_t k = 0; k < c.field_angle_deg.size(); ++k) {
      if (std::isfinite(c.tangential_mm[w][k]))
        t.points.push_back({c.tangential_mm[w][k], c.field_angle_deg[k]});
      if (std::isfinite(c.sagittal_mm[w][k]))
        s.points.push_back({c.sagittal_mm[w][k], c.field_angle_deg[k]});
    }
    fc.series.push_back(std::move(t));
    fc.series.push_back(std::move(s));
  }
  fc.render(doc, 0, 30, 500, 440);
  plot::Chart dc;
  dc.title = "distortion relative to f tan θ";
  dc.x_label = "distortion (%)";
  dc.y_label = "field angle (deg)";
  dc.include_zero_y = true;
  plot::Series ds{"chief ray", plot::paletteColor(0), plot::Style::Line, {}};
  for (size_t k = 0; k < c.distortion.angle_deg.size(); ++k)
    if (std::isfinite(c.distortion.percent_tan[k]))
      ds.points.push_back({c.distortion.percent_tan[k], c.distortion.angle_deg[k]});
  dc.series.push_back(std::move(ds));
  double dm = 0.1;
  for (const auto& p : dc.series[0].points) dm = std::max(dm, std::abs(p.first));
  dc.x_range = {-1.05 * dm, 1.05 * dm};
  if (!c.distortion.percent_tan.empty() && std::isfinite(c.distortion.percent_tan.back()))
    dc.notes.push_back(fmt::format("{:+.2f}% at {:.1f}°", c.distortion.percent_tan.back(),
                                   c.distortion.angle_deg.back()));
  dc.render(doc, 500, 30, 500, 440);
  return doc.str();
}

}  // namespace lensim::optics
