#include "lensim/optics/psf.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "lensim/optics/mtf.h"
#include "lensim/optics/wavefront.h"
#include "lensim/util/plot.h"

namespace lensim::optics {

std::vector<PsfField> computePsf(const SpectralLens& sl, double film_diagonal_mm,
                                 const std::vector<double>& fields, double window_mm, int pixels,
                                 int pupil_cells) {
  const FocusedLens& fl = *sl.focused;
  const double primary = sl.primaryNm();
  const LensSystem& lens0 = sl.at(primary);
  const double film_z = fl.lens->filmZ_mm();
  pixels = std::clamp(pixels, 8, 1024);
  std::vector<PsfField> out;
  for (double frac : fields) {
    auto b = FieldBundle::fromFilmHeight(fl, lens0, frac * film_diagonal_mm / 2);
    if (!b) continue;
    auto p0 = chiefImagePoint(lens0, *b, film_z);
    if (!p0) continue;
    PsfField pf;
    pf.field_fraction = frac;
    pf.film_height_mm = b->film_height_mm;
    pf.field_angle_deg = b->field_angle_deg;
    pf.image_point_mm = *p0;
    std::vector<std::pair<FourierOptics, double>> fos;
    double wsum = 0;
    for (const WeightedWavelength& w : sl.wavelengths) {
      auto pupil = computePupilFunction(sl.at(w.nm), *b, film_z, *p0, w.nm, pupil_cells, 0.25, 512);
      if (!pupil) continue;
      if (w.nm == primary) {
        pf.pupil_cells = pupil->n;
        pf.airy_radius_mm = 1.22 * primary * 1e-6 / (2 * pupil->halfWidth());
      }
      fos.push_back({fourierOptics(*pupil), w.weight});
      pf.strehl += w.weight * fos.back().first.strehl;
      wsum += w.weight;
    }
    if (fos.empty()) continue;
    pf.strehl /= wsum;
    if (pf.airy_radius_mm == 0) pf.airy_radius_mm = fos.front().first.psf_pitch_mm * 2;
    // Energy centroid and the radius about P' holding 99% of the energy (primary wavelength).
    double half = window_mm;
    {
      const FourierOptics& fo = fos.front().first;
      const int m = fo.m;
      std::vector<std::pair<double, double>> re;
      Vec2 cen{0, 0};
      for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x) {
          const double v = fo.psf[size_t(y) * m + x];
          const double dx = (x - m / 2) * fo.psf_pitch_mm, dy = (y - m / 2) * fo.psf_pitch_mm;
          cen = cen + Vec2{dx, dy} * v;
          re.push_back({std::hypot(dx, dy), v});
        }
      pf.centroid_mm = cen;
      if (!(half > 0)) {
        std::sort(re.begin(), re.end());
        double acc = 0, r99 = re.back().first;
        for (const auto& [r, v] : re) {
          acc += v;
          if (acc >= 0.99) {
            r99 = r;
            break;
          }
        }
        half = std::max(6 * pf.airy_radius_mm, r99);
      }
    }
    pf.pixels = pixels;
    pf.pixel_mm = 2 * half / pixels;
    pf.image.assign(size_t(pixels) * pixels, 0.0);
    double peak = 0;
    for (int y = 0; y < pixels; ++y)
      for (int x = 0; x < pixels; ++x) {
        const double dx = -half + (x + 0.5) * pf.pixel_mm, dy = -half + (y + 0.5) * pf.pixel_mm;
        double v = 0;
        // Density per unit area: PSF samples sum to 1 over pitch^2 cells.
        for (const auto& [fo, w] : fos)
          v += w * fo.psfAt(dx, dy) / (fo.psf_pitch_mm * fo.psf_pitch_mm);
        pf.image[size_t(y) * pixels + x] = v;
        peak = std::max(peak, v);
      }
    if (peak > 0)
      for (double& v : pf.image) v /= peak;
    out.push_back(std::move(pf));
  }
  return out;
}

namespace {

// A perceptually ordered dark-to-light colour ramp (black, purple, orange, pale yellow).
std::string ramp(double t) {
  static const double stops[5][3] = {
      {0, 0, 4}, {81, 18, 124}, {183, 55, 121}, {252, 137, 97}, {252, 253, 191}};
  t = std::clamp(t, 0.0, 1.0) * 4;
  const int i = std::min(3, static_cast<int>(t));
  const double f = t - i;
  int c[3];
  for (int k = 0; k < 3; ++k)
    c[k] = static_cast<int>(std::lround(stops[i][k] * (1 - f) + stops[i + 1][k] * f));
  return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
}

}  // namespace

std::string psfSvg(const FocusedLens& fl, const std::vector<PsfField>& psfs,
                   const std::vector<WeightedWavelength>& wl, int decades) {
  const int n = std::max<int>(1, static_cast<int>(psfs.size()));
  const double pw = 300, ph = 360, img = 240;
  svg::Document doc(pw * n, ph + 30);
  doc.rect(0, 0, pw * n, ph + 30, {{"fill", "#ffffff"}});
  doc.text(12, 20, "PSF (log scale) — " + analysisSubtitle(fl, wl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  constexpr int kLevels = 32;  // colour levels: runs of equal colour become one rectangle
  for (size_t i = 0; i < psfs.size(); ++i) {
    const PsfField& p = psfs[i];
    const double x0 = pw * i + 30, y0 = 60;
    const double cell = img / p.pixels;
    doc.text(pw * i + 30, 50,
             fmt::format("film {:.2f} mm · {:.2f}° · Strehl {:.3f}", p.film_height_mm,
                         p.field_angle_deg, p.strehl),
             {{"font-size", "12"}});
    doc.beginGroup({{"shape-rendering", "crispEdges"}});
    doc.rect(x0, y0, img, img, {{"fill", ramp(0)}});
    for (int y = 0; y < p.pixels; ++y) {
      // Film +y up: row y of the image is drawn from the bottom.
      const double sy = y0 + img - (y + 1) * cell;
      int x = 0;
      while (x < p.pixels) {
        auto level = [&](int xx) {
          const double v = p.image[size_t(y) * p.pixels + xx];
          const double t = v > 0 ? 1 + std::log10(v) / decades : 0.0;
          return static_cast<int>(std::floor(std::clamp(t, 0.0, 1.0) * (kLevels - 1) + 0.5));
        };
        const int lv = level(x);
        int end = x + 1;
        while (end < p.pixels && level(end) == lv) ++end;
        if (lv > 0)
          doc.rect(x0 + x * cell, sy, (end - x) * cell + 0.01, cell + 0.01,
                   {{"fill", ramp(static_cast<double>(lv) / (kLevels - 1))}});
        x = end;
      }
    }
    doc.endGroup();
    doc.rect(x0, y0, img, img, {{"fill", "none"}, {"stroke", "#333333"}});
    const double half = p.pixels * p.pixel_mm / 2;
    doc.text(x0, y0 + img + 16,
             fmt::format("{:.4g} mm across · Airy radius {:.4g} mm", 2 * half, p.airy_radius_mm),
             {{"font-size", "11"}});
    doc.text(x0, y0 + img + 32,
             fmt::format("x: meridional; colour: 10^-{} to 1 of the peak", decades),
             {{"font-size", "11"}});
    // Colour bar.
    for (int k = 0; k < 20; ++k)
      doc.rect(x0 + k * img / 20, y0 + img + 40, img / 20 + 0.01, 8, {{"fill", ramp(k / 19.0)}});
  }
  return doc.str();
}

}  // namespace lensim::optics
