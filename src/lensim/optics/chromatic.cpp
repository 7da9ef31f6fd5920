#include "lensim/optics/chromatic.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "lensim/optics/chief_ray.h"
#include "lensim/util/plot.h"

namespace lensim::optics {

namespace {

std::string subtitle(const FocusedLens& fl) {
  return fmt::format("{} · f/{:.2f} · focus {} at {:.1f} nm", fl.lens->prescription().name,
                     fl.paraxial.f_number,
                     std::isinf(fl.focus_distance_m) ? std::string("infinity")
                                                     : fmt::format("{:.4g} m", fl.focus_distance_m),
                     primaryWavelength_nm(fl.lens->prescription()));
}

}  // namespace

FocusedLens focusedAtWavelength(const FocusedLens& fl, double lambda_nm) {
  FocusedLens out;
  out.lens = std::make_unique<LensSystem>(fl.lens->atWavelength(lambda_nm));
  out.paraxial = computeParaxial(*out.lens);
  out.focus_distance_m = fl.focus_distance_m;
  return out;
}

ChromaticFocus computeChromaticFocus(const FocusedLens& fl, double from_nm, double to_nm,
                                     int samples) {
  ChromaticFocus c;
  const double primary = primaryWavelength_nm(fl.lens->prescription());
  c.primary_nm = primary;
  auto at = [&](double l, double& paraxial, double& real) {
    const FocusedLens f = focusedAtWavelength(fl, l);
    paraxial = filmDistanceForFocus(*f.lens, f.paraxial, fl.focus_distance_m, FocusMethod::Thick);
    real = std::nan("");
    try {
      real = filmDistanceForFocus(*f.lens, f.paraxial, fl.focus_distance_m, FocusMethod::Exact);
    } catch (const Error&) {
      // no real focus behind the rear vertex
    }
  };
  at(primary, c.paraxial_primary_mm, c.real_primary_mm);
  double unused;
  at(kLineF_nm, c.paraxial_F_mm, unused);
  at(kLineC_nm, c.paraxial_C_mm, unused);
  for (int k = 0; k < samples; ++k) {
    const double l = from_nm + (to_nm - from_nm) * k / std::max(1, samples - 1);
    double p, r;
    at(l, p, r);
    c.wavelength_nm.push_back(l);
    c.paraxial_mm.push_back(p);
    c.real_mm.push_back(r);
  }
  return c;
}

double chiefRayHeightAt(const FocusedLens& fl, double field_deg, double lambda_nm) {
  const FocusedLens f = focusedAtWavelength(fl, lambda_nm);
  const std::optional<ChiefRay> c = chiefRayFromScene(*f.lens, f.paraxial, field_deg);
  return c ? c->film_height_mm : std::nan("");
}

LateralColor computeLateralColor(const FocusedLens& fl, double film_diagonal_mm, int samples,
                                 double short_nm, double long_nm) {
  LateralColor c;
  c.short_nm = short_nm, c.long_nm = long_nm;
  c.primary_nm = primaryWavelength_nm(fl.lens->prescription());
  const FocusedLens fs = focusedAtWavelength(fl, short_nm), fL = focusedAtWavelength(fl, long_nm);
  const FocusedLens fp = focusedAtWavelength(fl, c.primary_nm);
  const FieldOfView fov = fieldOfView(*fp.lens, fp.paraxial, film_diagonal_mm);
  const double max_deg = 0.5 * (fov.real_deg ? *fov.real_deg : *fov.real_max_deg);
  auto height = [](const FocusedLens& f, double th) {
    const std::optional<ChiefRay> r = chiefRayFromScene(*f.lens, f.paraxial, th);
    return r ? r->film_height_mm : std::nan("");
  };
  for (int k = 0; k <= samples; ++k) {
    const double th = max_deg * k / samples;
    const double hp = height(fp, th), hs = height(fs, th), hl = height(fL, th);
    if (!std::isfinite(hp)) continue;
    c.field_deg.push_back(th);
    c.height_primary_mm.push_back(hp);
    c.short_minus_primary_mm.push_back(hs - hp);
    c.long_minus_primary_mm.push_back(hl - hp);
  }
  return c;
}

std::vector<ColorSpotField> computeSpotsAtWavelengths(const FocusedLens& fl,
                                                      const std::vector<double>& fields,
                                                      double film_diagonal_mm,
                                                      const std::vector<double>& wavelengths_nm,
                                                      int grid) {
  const double primary = primaryWavelength_nm(fl.lens->prescription());
  const FocusedLens fp = focusedAtWavelength(fl, primary);
  std::vector<FocusedLens> at;
  for (double l : wavelengths_nm) at.push_back(focusedAtWavelength(fl, l));
  const ParaxialData& p = fp.paraxial;
  const double r_aim = 2.0 * p.entrance_pupil_diameter_mm / 2;
  std::vector<ColorSpotField> out;
  for (double frac : fields) {
    const double h = frac * film_diagonal_mm / 2;
    const auto chief = chiefRayFromFilm(*fp.lens, p, h);
    if (!chief) continue;
    ColorSpotField sf;
    sf.film_height_mm = h;
    sf.field_angle_deg = chief->field_angle_deg;
    // The object point (or direction) of the primary wavelength's chief ray, as computeSpots.
    const Ray& c = chief->scene_ray;
    const Vec3 pupil_centre =
        c.origin + c.direction * ((p.entrance_pupil_z_mm - c.origin.z) / c.direction.z);
    std::optional<Vec3> object;
    if (!std::isinf(fl.focus_distance_m)) {
      const double z_obj = fp.lens->filmZ_mm() - fl.focus_distance_m * 1000;
      object = c.origin + c.direction * ((z_obj - c.origin.z) / c.direction.z);
    }
    // Where the bundle from the object through a grid over the entrance pupil meets the film.
    auto bundleHits = [&](const LensSystem& lens) {
      std::vector<Vec2> pts;
      for (int iy = 0; iy < grid; ++iy)
        for (int ix = 0; ix < grid; ++ix) {
          const double u = (2.0 * (ix + 0.5) / grid - 1), v = (2.0 * (iy + 0.5) / grid - 1);
          if (u * u + v * v > 1) continue;
          const Vec3 aim = pupil_centre + Vec3{u * r_aim, v * r_aim, 0};
          Ray ray;
          if (object) {
            ray = {*object, normalize(aim - *object)};
          } else {
            const Vec3 d = -c.direction;
            ray = {aim - d * ((aim.z + 10 * r_aim + 10) / d.z), d};
          }
          const TraceResult r = lens.tracer().traceFromScene(ray);
          if (!r.ok() || !(r.ray.direction.z > 0)) continue;
          const double t = (lens.filmZ_mm() - r.ray.origin.z) / r.ray.direction.z;
          const Vec3 q = r.ray.origin + r.ray.direction * t;
          pts.push_back({q.x, q.y});
        }
      return pts;
    };
    std::vector<std::vector<Vec2>> hits(at.size());
    for (size_t w = 0; w < at.size(); ++w) hits[w] = bundleHits(*at[w].lens);
    // The reference: the primary wavelength's centroid (its own bundle, traced the same way).
    const std::vector<Vec2> primary_hits = bundleHits(*fp.lens);
    if (primary_hits.empty()) continue;
    Vec2 ref{0, 0};
    for (const Vec2& q : primary_hits) ref = ref + q;
    ref = ref * (1.0 / primary_hits.size());
    for (size_t w = 0; w < at.size(); ++w) {
      Vec2 mean{0, 0};
      for (const Vec2& q : hits[w]) mean = mean + q;
      if (!hits[w].empty()) mean = mean * (1.0 / hits[w].size());
      double s2 = 0;
      std::vector<Vec2> rel;
      for (const Vec2& q : hits[w]) {
        const Vec2 dq = q - mean;
        s2 += dq.x * dq.x + dq.y * dq.y;
        rel.push_back(q - ref);
      }
      sf.wavelength_nm.push_back(wavelengths_nm[w]);
      sf.points_mm.push_back(std::move(rel));
      sf.centroid_mm.push_back(hits[w].empty() ? Vec2{std::nan(""), std::nan("")} : mean);
      sf.rms_radius_mm.push_back(hits[w].empty() ? std::nan("") : std::sqrt(s2 / hits[w].size()));
    }
    out.push_back(std::move(sf));
  }
  return out;
}

std::string wavelengthColor(double l) {
  // A hue ramp over the visible spectrum (violet-blue-cyan-green-yellow-red), dimmed toward the
  // ends, for telling wavelengths apart on plots (not a colorimetric conversion).
  double r = 0, g = 0, b = 0;
  if (l < 440)
    r = -(l - 440) / 60, b = 1;
  else if (l < 490)
    g = (l - 440) / 50, b = 1;
  else if (l < 510)
    g = 1, b = -(l - 510) / 20;
  else if (l < 580)
    r = (l - 510) / 70, g = 1;
  else if (l < 645)
    r = 1, g = -(l - 645) / 65;
  else
    r = 1;
  double f = 1;
  if (l < 420)
    f = 0.3 + 0.7 * std::max(0.0, l - 380) / 40;
  else if (l > 680)
    f = 0.3 + 0.7 * std::max(0.0, 780 - l) / 100;
  auto c = [&](double x) {
    return std::clamp(int(std::lround(255 * std::clamp(x * f, 0.0, 1.0) * 0.85)), 0, 255);
  };
  return fmt::format("#{:02x}{:02x}{:02x}", c(r), c(g), c(b));
}

std::string chromaticFocusSvg(const FocusedLens& fl, const ChromaticFocus& c) {
  svg::Document doc(640, 450);
  doc.rect(0, 0, 640, 450, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Longitudinal colour — " + subtitle(fl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  plot::Chart ch;
  ch.title = fmt::format("focal shift from the paraxial focus at {:.1f} nm", c.primary_nm);
  ch.x_label = "wavelength (nm)";
  ch.y_label = "focal shift (mm)";
  ch.include_zero_y = true;
  plot::Series par{"paraxial", plot::paletteColor(0), plot::Style::Line, {}};
  plot::Series real{"real best focus (RMS)", plot::paletteColor(1), plot::Style::Markers, {}};
  real.marker_radius = 2.2;
  for (size_t k = 0; k < c.wavelength_nm.size(); ++k) {
    par.points.push_back({c.wavelength_nm[k], c.paraxial_mm[k] - c.paraxial_primary_mm});
    if (std::isfinite(c.real_mm[k]))
      real.points.push_back({c.wavelength_nm[k], c.real_mm[k] - c.paraxial_primary_mm});
  }
  ch.series.push_back(par);
  ch.series.push_back(real);
  ch.notes.push_back(fmt::format("paraxial F − C: {:+.4f} mm", c.paraxial_F_mm - c.paraxial_C_mm));
  ch.render(doc, 0, 30, 640, 420);
  return doc.str();
}

std::string lateralColorSvg(const FocusedLens& fl, const LateralColor& c) {
  svg::Document doc(640, 450);
  doc.rect(0, 0, 640, 450, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Lateral colour — " + subtitle(fl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  plot::Chart ch;
  ch.title = "real chief ray: image height minus the primary wavelength's";
  ch.x_label = "field angle (deg)";
  ch.y_label = "image height difference (µm)";
  ch.include_zero_y = true;
  plot::Series s{fmt::format("{:.1f} nm − {:.1f} nm", c.short_nm, c.primary_nm),
                 wavelengthColor(c.short_nm),
                 plot::Style::Line,
                 {}};
  plot::Series l{fmt::format("{:.1f} nm − {:.1f} nm", c.long_nm, c.primary_nm),
                 wavelengthColor(c.long_nm),
                 plot::Style::Line,
                 {}};
  for (size_t k = 0; k < c.field_deg.size(); ++k) {
    if (std::isfinite(c.short_minus_primary_mm[k]))
      s.points.push_back({c.field_deg[k], 1000 * c.short_minus_primary_mm[k]});
    if (std::isfinite(c.long_minus_primary_mm[k]))
      l.points.push_back({c.field_deg[k], 1000 * c.long_minus_primary_mm[k]});
  }
  ch.series.push_back(s);
  ch.series.push_back(l);
  if (!c.field_deg.empty())
    ch.notes.push_back(fmt::format("at {:.1f}°: {:+.2f} / {:+.2f} µm", c.field_deg.back(),
                                   1000 * c.short_minus_primary_mm.back(),
                                   1000 * c.long_minus_primary_mm.back()));
  ch.render(doc, 0, 30, 640, 420);
  return doc.str();
}

std::string colorSpotSvg(const FocusedLens& fl, const std::vector<ColorSpotField>& spots) {
  const int n = std::max<int>(1, static_cast<int>(spots.size()));
  const double pw = 300, ph = 320;
  svg::Document doc(pw * n, ph + 30);
  doc.rect(0, 0, pw * n, ph + 30, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Spot diagrams by wavelength — " + subtitle(fl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  double extent = 1e-4;
  for (const ColorSpotField& s : spots)
    for (const auto& pts : s.points_mm)
      for (const Vec2& q : pts) extent = std::max({extent, std::abs(q.x), std::abs(q.y)});
  extent *= 1.1;
  for (size_t i = 0; i < spots.size(); ++i) {
    const ColorSpotField& s = spots[i];
    plot::Chart chart;
    chart.title = fmt::format("film {:.2f} mm · {:.2f}°", s.film_height_mm, s.field_angle_deg);
    chart.x_label = "x − primary wavelength's centroid (mm)";
    chart.y_label = "y − centroid (mm)";
    chart.equal_aspect = true;
    chart.x_range = {-extent, extent};
    chart.y_range = {-extent, extent};
    for (size_t w = 0; w < s.wavelength_nm.size(); ++w) {
      plot::Series pts;
      pts.style = plot::Style::Markers;
      pts.color = wavelengthColor(s.wavelength_nm[w]);
      pts.name = fmt::format("{:.1f} nm · RMS {:.4f} mm", s.wavelength_nm[w], s.rms_radius_mm[w]);
      pts.marker_radius = 0.9;
      for (const Vec2& q : s.points_mm[w]) pts.points.push_back({q.x, q.y});
      chart.series.push_back(std::move(pts));
    }
    chart.render(doc, pw * i, 30, pw, ph);
  }
  return doc.str();
}

}  // namespace lensim::optics
