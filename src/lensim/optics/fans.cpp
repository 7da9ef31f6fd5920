#include "lensim/optics/fans.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "lensim/optics/mtf.h"
#include "lensim/util/plot.h"

namespace lensim::optics {

std::vector<FanField> computeRayFans(const SpectralLens& sl, double film_diagonal_mm,
                                     const std::vector<double>& fields, int rays, double extent) {
  const FocusedLens& fl = *sl.focused;
  const LensSystem& lens0 = sl.at(sl.primaryNm());
  const double film_z = fl.lens->filmZ_mm();
  rays = std::max(3, rays);
  std::vector<FanField> out;
  for (double frac : fields) {
    auto b = FieldBundle::fromFilmHeight(fl, lens0, frac * film_diagonal_mm / 2);
    if (!b) continue;
    auto p0 = chiefImagePoint(lens0, *b, film_z);
    if (!p0) continue;
    FanField ff;
    ff.field_fraction = frac;
    ff.film_height_mm = b->film_height_mm;
    ff.field_angle_deg = b->field_angle_deg;
    for (const WeightedWavelength& w : sl.wavelengths) {
      const LensSystem& lens = sl.at(w.nm);
      RayFan fan;
      fan.wavelength_nm = w.nm;
      for (int k = 0; k < rays; ++k) {
        const double p = -extent + 2 * extent * k / (rays - 1);
        const double o = p * b->pupil_radius_mm;
        if (auto q = FieldBundle::hitPlane(lens, b->sceneRay({o, 0}), film_z)) {
          fan.tangential_pupil.push_back(p);
          fan.tangential_ex_mm.push_back(q->x - p0->x);
        }
        if (auto q = FieldBundle::hitPlane(lens, b->sceneRay({0, o}), film_z)) {
          fan.sagittal_pupil.push_back(p);
          fan.sagittal_ey_mm.push_back(q->y - p0->y);
          fan.sagittal_ex_mm.push_back(q->x - p0->x);
        }
      }
      ff.fans.push_back(std::move(fan));
    }
    out.push_back(std::move(ff));
  }
  return out;
}

std::string rayFanSvg(const FocusedLens& fl, const std::vector<FanField>& fans,
                      const std::vector<WeightedWavelength>& wl) {
  const int rows = std::max<int>(1, static_cast<int>(fans.size()));
  const double pw = 400, ph = 260;
  svg::Document doc(2 * pw, ph * rows + 30);
  doc.rect(0, 0, 2 * pw, ph * rows + 30, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Ray fans — " + analysisSubtitle(fl, wl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  // One vertical scale for all panels.
  double e = 1e-4;
  for (const FanField& f : fans)
    for (const RayFan& r : f.fans) {
      for (double v : r.tangential_ex_mm) e = std::max(e, std::abs(v));
      for (double v : r.sagittal_ey_mm) e = std::max(e, std::abs(v));
    }
  e *= 1.05;
  for (size_t i = 0; i < fans.size(); ++i) {
    const FanField& f = fans[i];
    for (int side = 0; side < 2; ++side) {
      plot::Chart c;
      c.title = fmt::format("{} · film {:.2f} mm · {:.2f}°", side == 0 ? "tangential" : "sagittal",
                            f.film_height_mm, f.field_angle_deg);
      c.x_label = side == 0 ? "pupil x (entrance-pupil radii)" : "pupil y (entrance-pupil radii)";
      c.y_label = side == 0 ? "ex (mm)" : "ey (mm)";
      c.y_range = {-e, e};
      for (size_t j = 0; j < f.fans.size(); ++j) {
        const RayFan& r = f.fans[j];
        const auto& px = side == 0 ? r.tangential_pupil : r.sagittal_pupil;
        const auto& py = side == 0 ? r.tangential_ex_mm : r.sagittal_ey_mm;
        plot::Series s{i == 0 ? fmt::format("{:.1f} nm", r.wavelength_nm) : std::string(),
                       plot::paletteColor(static_cast<int>(j)),
                       plot::Style::Line,
                       {}};
        // Break the line where blocked rays leave a gap.
        double step = 1e300;
        for (size_t k = 1; k < px.size(); ++k) step = std::min(step, px[k] - px[k - 1]);
        for (size_t k = 0; k < px.size(); ++k) {
          if (k > 0 && px[k] - px[k - 1] > 1.5 * step && !s.points.empty()) {
            c.series.push_back(s);
            s.points.clear();
            s.name.clear();
          }
          s.points.push_back({px[k], py[k]});
        }
        c.series.push_back(std::move(s));
      }
      c.render(doc, side * pw, 30 + ph * i, pw, ph);
    }
  }
  return doc.str();
}

}  // namespace lensim::optics
