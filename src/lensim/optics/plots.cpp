#include "lensim/optics/plots.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "lensim/optics/chief_ray.h"
#include "lensim/optics/field_rays.h"
#include "lensim/util/plot.h"

namespace lensim::optics {

namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string lensSubtitle(const FocusedLens& fl) {
  return fmt::format("{} · f/{:.2f} · focus {}", fl.lens->prescription().name, fl.paraxial.f_number,
                     std::isinf(fl.focus_distance_m)
                         ? std::string("infinity")
                         : fmt::format("{:.4g} m", fl.focus_distance_m));
}

}  // namespace

std::vector<SpotField> computeSpots(const FocusedLens& fl, const std::vector<double>& fields,
                                    double film_diagonal_mm, int rings) {
  const LensSystem& lens = *fl.lens;
  std::vector<SpotField> out;
  // Drawn: every step-th ring and every step-th ray on it, a hexapolar pattern of ~16 rings.
  const int step = std::max(1, rings / 16);
  for (double frac : fields) {
    const double h = frac * film_diagonal_mm / 2;
    auto bundle = FieldBundle::fromFilmHeight(fl, lens, h);
    if (!bundle) continue;
    auto region = bundle->pupilRegion(lens);
    if (!region) continue;
    SpotField sf;
    sf.film_height_mm = h;
    sf.field_angle_deg = bundle->field_angle_deg;
    sf.rings = rings;
    std::vector<Vec2> hits;
    std::vector<double> weights;
    for (const PupilPoint& pp : hexapolarPupil(*region, rings)) {
      ++sf.rays_traced;
      auto q = FieldBundle::hitPlane(lens, bundle->sceneRay(pp.offset_mm), lens.filmZ_mm());
      if (!q) continue;
      if (pp.ring % step == 0 && pp.index % step == 0)
        sf.display.push_back(static_cast<int>(hits.size()));
      hits.push_back(*q);
      weights.push_back(pp.weight);
    }
    if (hits.empty()) continue;
    // Centroid and RMS radius weighted by each ray's share of the pupil's area.
    Vec2 mean{0, 0};
    double wsum = 0;
    for (size_t k = 0; k < hits.size(); ++k) {
      mean = mean + hits[k] * weights[k];
      wsum += weights[k];
    }
    mean = mean * (1.0 / wsum);
    double s2 = 0;
    for (size_t k = 0; k < hits.size(); ++k) {
      const Vec2 dq = hits[k] - mean;
      sf.points_mm.push_back(dq);
      s2 += weights[k] * (dq.x * dq.x + dq.y * dq.y);
    }
    sf.centroid_mm = mean;
    sf.rms_radius_mm = std::sqrt(s2 / wsum);
    out.push_back(std::move(sf));
  }
  return out;
}

DistortionData computeDistortion(const FocusedLens& fl, double film_diagonal_mm, int samples) {
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  DistortionData d;
  const FieldOfView fov = fieldOfView(lens, p, film_diagonal_mm);
  const double max_deg = 0.5 * (fov.real_deg ? *fov.real_deg : *fov.real_max_deg);
  // Reference focal length on this film plane: the small-angle limit of h / tan(theta).
  const double small = 0.05;
  auto c0 = chiefRayFromScene(lens, p, small);
  if (!c0) throw Error("no chief ray near the axis: cannot compute distortion");
  d.f_reference_mm = c0->film_height_mm / std::tan(small / kDeg);
  for (int k = 0; k <= samples; ++k) {
    const double th = max_deg * k / samples;
    double h = 0;
    if (k > 0) {
      auto c = chiefRayFromScene(lens, p, th);
      if (!c) continue;
      h = c->film_height_mm;
    }
    const double f = d.f_reference_mm, t = th / kDeg;
    d.angle_deg.push_back(th);
    d.height_mm.push_back(h);
    auto pct = [&](double model) { return k == 0 ? 0.0 : 100 * (h - model) / model; };
    d.percent_tan.push_back(th < 89.5 ? pct(f * std::tan(t)) : std::nan(""));
    d.percent_equidistant.push_back(pct(f * t));
    d.percent_equisolid.push_back(pct(2 * f * std::sin(t / 2)));
  }
  return d;
}

VignettingData computeVignetting(const FocusedLens& fl, double film_diagonal_mm, int samples,
                                 int grid) {
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  VignettingData v;
  const double rr = 1.5 * lens.interfaces().back().semi_aperture_mm;
  const double z = lens.filmDistance_mm();  // film to the sampling (rear-vertex) plane
  // The region of the rear-vertex plane through which light reaches film point (h, 0) is an
  // intersection of (projected) discs, star-shaped about any point inside it. Its area and its
  // cos^4-weighted area are integrated in polar coordinates about a passing point (the real
  // chief ray's crossing where it gets through), with the boundary found by bisection along each
  // direction: smooth in h, unlike counting grid cells.
  const int angles = std::max(16, 2 * grid);
  auto measure = [&](double h, double& area, double& weighted) {
    area = weighted = 0;
    // The outer boundary (central obscurations not subtracted: see lens_system.h).
    auto passes = [&](Vec2 a) { return lens.traceFromFilmPoint({h, 0}, a, kOuterBoundary).ok(); };
    const std::optional<Vec2> start = passingRearAim(lens, p, h);
    if (!start) return;
    const Vec2 c = *start;
    // Irradiance at the film: L cos(theta) cos(theta') / d^2 dA = L cos^4(theta) / z^2 dA for a
    // plane parallel to the film at axial distance z.
    auto weight = [&](Vec2 a) {
      const double dx = a.x - h, dy = a.y;
      const double cos2 = z * z / (dx * dx + dy * dy + z * z);
      return cos2 * cos2;
    };
    // 8-point Gauss-Legendre nodes and weights on [0, 1].
    static const double kX[8] = {0.0198550717512319, 0.1016667612931866, 0.2372337950418355,
                                 0.4082826787521751, 0.5917173212478249, 0.7627662049581645,
                                 0.8983332387068134, 0.9801449282487681};
    static const double kW[8] = {0.0506142681451881, 0.1111905172266872, 0.1568533229389436,
                                 0.1813418916891810, 0.1813418916891810, 0.1568533229389436,
                                 0.1111905172266872, 0.0506142681451881};
    const double dphi = 2 * std::numbers::pi / angles;
    for (int k = 0; k < angles; ++k) {
      const double phi = (k + 0.5) * dphi;
      const Vec2 u{std::cos(phi), std::sin(phi)};
      // Double the distance until a ray is blocked, then bisect the boundary (scale-free: the
      // region may be microns or centimetres across).
      double lo = 0, hi = 1e-6 * rr;
      while (hi < 4 * rr && passes(c + u * hi)) {
        lo = hi;
        hi *= 2;
      }
      for (int it = 0; it < 40; ++it) {
        const double mid = 0.5 * (lo + hi);
        (passes(c + u * mid) ? lo : hi) = mid;
      }
      const double R = 0.5 * (lo + hi);
      area += 0.5 * R * R * dphi;
      double wsum = 0;
      for (int g = 0; g < 8; ++g) {
        const double r = R * kX[g];
        wsum += kW[g] * weight(c + u * r) * r;
      }
      weighted += wsum * R * dphi;
    }
  };
  double area0 = 0, weighted0 = 0;
  measure(0, area0, weighted0);
  if (area0 == 0) throw Error("no ray from the film centre gets through the lens");
  const double r_max = film_diagonal_mm / 2;
  for (int k = 0; k <= samples; ++k) {
    const double h = r_max * k / samples;
    double area, weighted;
    measure(h, area, weighted);
    v.film_radius_mm.push_back(h);
    v.unobstructed.push_back(area / area0);
    v.relative_illumination.push_back(weighted / weighted0);
    double c4 = std::nan("");
    if (auto c = chiefRayFromFilm(lens, p, h)) {
      const double cz = std::abs(c->film_ray.direction.z);
      c4 = cz * cz * cz * cz;
    }
    v.cos4.push_back(c4);
  }
  return v;
}

FocusCurve computeFocusCurve(const FocusedLens& fl, int samples) {
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  FocusCurve c;
  c.closest_m = closestFocusDistance_m(lens, p);
  const double lo = c.closest_m * 1.05, hi = 1000 * std::abs(p.effective_focal_length_mm) / 1000;
  const double top = std::max(hi, 20 * lo);
  for (int k = 0; k < samples; ++k) {
    const double D = lo * std::pow(top / lo, static_cast<double>(k) / (samples - 1));
    c.focus_distance_m.push_back(D);
    c.film_distance_thick_mm.push_back(filmDistanceForFocus(lens, p, D, FocusMethod::Thick));
    double exact = std::nan("");
    try {
      exact = filmDistanceForFocus(lens, p, D, FocusMethod::Exact);
    } catch (const Error&) {
      // No real-ray solution this close (e.g. the object would sit inside the lens).
    }
    c.film_distance_exact_mm.push_back(exact);
  }
  c.infinity_thick_mm = filmDistanceForFocus(lens, p, kInf, FocusMethod::Thick);
  c.infinity_exact_mm = std::nan("");
  try {
    c.infinity_exact_mm = filmDistanceForFocus(lens, p, kInf, FocusMethod::Exact);
  } catch (const Error&) {
    // e.g. the best real focus lies in front of the rear vertex
  }
  return c;
}

// ------------------------------------------------------------------------------------ SVG

std::string spotSvg(const FocusedLens& fl, const std::vector<SpotField>& spots) {
  const int n = std::max<int>(1, static_cast<int>(spots.size()));
  const double pw = 300, ph = 320;
  svg::Document doc(pw * n, ph + 30);
  doc.rect(0, 0, pw * n, ph + 30, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Spot diagrams — " + lensSubtitle(fl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  // One scale for all panels: the largest spot decides.
  double extent = 1e-4;
  for (const SpotField& s : spots)
    for (const Vec2& q : s.points_mm) extent = std::max({extent, std::abs(q.x), std::abs(q.y)});
  extent *= 1.1;
  for (size_t i = 0; i < spots.size(); ++i) {
    const SpotField& s = spots[i];
    plot::Chart chart;
    chart.title = fmt::format("film {:.2f} mm · {:.2f}°", s.film_height_mm, s.field_angle_deg);
    chart.x_label = "x − centroid (mm)";
    chart.y_label = "y − centroid (mm)";
    chart.equal_aspect = true;
    chart.x_range = {-extent, extent};
    chart.y_range = {-extent, extent};
    chart.notes.push_back(fmt::format("RMS radius {:.4f} mm", s.rms_radius_mm));
    chart.notes.push_back(fmt::format("{} of {} rays through ({} drawn)", s.points_mm.size(),
                                      s.rays_traced, s.display.size()));
    plot::Series pts;
    pts.style = plot::Style::Markers;
    pts.color = plot::paletteColor(static_cast<int>(i));
    pts.marker_radius = 1.0;
    for (int k : s.display) pts.points.push_back({s.points_mm[k].x, s.points_mm[k].y});
    chart.series.push_back(std::move(pts));
    chart.render(doc, pw * i, 30, pw, ph);
  }
  return doc.str();
}

std::string distortionSvg(const FocusedLens& fl, const DistortionData& d, bool fisheye_models) {
  svg::Document doc(1000, 430);
  doc.rect(0, 0, 1000, 430, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Distortion — " + lensSubtitle(fl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  const double f = d.f_reference_mm;
  plot::Chart h;
  h.title = "chief-ray image height";
  h.x_label = "field angle (deg)";
  h.y_label = "image height (mm)";
  auto series = [&](const std::string& name, int color, plot::Style style, auto fn) {
    plot::Series s{name, plot::paletteColor(color), style, {}};
    for (size_t k = 0; k < d.angle_deg.size(); ++k) {
      const double y = fn(k);
      if (std::isfinite(y)) s.points.push_back({d.angle_deg[k], y});
    }
    return s;
  };
  h.series.push_back(
      series("traced", 0, plot::Style::Line, [&](size_t k) { return d.height_mm[k]; }));
  h.series.push_back(
      series(fmt::format("f tan θ (f = {:.2f} mm)", f), 1, plot::Style::Dashed, [&](size_t k) {
        const double t = d.angle_deg[k] / kDeg;
        return d.angle_deg[k] < 80 ? f * std::tan(t) : std::nan("");
      }));
  if (fisheye_models) {
    h.series.push_back(series("f θ (equidistant)", 2, plot::Style::Dashed,
                              [&](size_t k) { return f * d.angle_deg[k] / kDeg; }));
    h.series.push_back(series("2f sin(θ/2) (equisolid)", 3, plot::Style::Dashed, [&](size_t k) {
      return 2 * f * std::sin(d.angle_deg[k] / kDeg / 2);
    }));
  }
  h.render(doc, 0, 30, 500, 400);
  plot::Chart pc;
  pc.title = "distortion";
  pc.x_label = "field angle (deg)";
  pc.y_label = "distortion (%)";
  pc.include_zero_y = true;
  pc.series.push_back(series("relative to f tan θ", 1, plot::Style::Line,
                             [&](size_t k) { return d.percent_tan[k]; }));
  if (fisheye_models) {
    pc.series.push_back(series("relative to f θ", 2, plot::Style::Line,
                               [&](size_t k) { return d.percent_equidistant[k]; }));
    pc.series.push_back(series("relative to 2f sin(θ/2)", 3, plot::Style::Line,
                               [&](size_t k) { return d.percent_equisolid[k]; }));
  }
  if (!d.percent_tan.empty() && std::isfinite(d.percent_tan.back()))
    pc.notes.push_back(
        fmt::format("{:+.2f}% at {:.1f}°", d.percent_tan.back(), d.angle_deg.back()));
  pc.render(doc, 500, 30, 500, 400);
  return doc.str();
}

std::string vignettingSvg(const FocusedLens& fl, const VignettingData& v) {
  svg::Document doc(640, 450);
  doc.rect(0, 0, 640, 450, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Relative illumination — " + lensSubtitle(fl),
           {{"font-size", "14"}, {"font-weight", "bold"}});
  plot::Chart c;
  c.title = "normalised to the film centre";
  c.x_label = "film radius (mm)";
  c.y_label = "relative value";
  c.y_range = {0, 1.05};
  auto series = [&](const std::string& name, int color, plot::Style style,
                    const std::vector<double>& ys) {
    plot::Series s{name, plot::paletteColor(color), style, {}};
    for (size_t k = 0; k < ys.size(); ++k)
      if (std::isfinite(ys[k])) s.points.push_back({v.film_radius_mm[k], ys[k]});
    return s;
  };
  c.series.push_back(series("unobstructed pupil (traced)", 0, plot::Style::Line, v.unobstructed));
  c.series.push_back(series("cos⁴ θ (chief ray)", 1, plot::Style::Dashed, v.cos4));
  c.series.push_back(
      series("relative illumination (traced)", 2, plot::Style::Line, v.relative_illumination));
  c.render(doc, 0, 30, 640, 420);
  return doc.str();
}

std::string focusSvg(const FocusedLens& fl, const FocusCurve& curve) {
  svg::Document doc(640, 450);
  doc.rect(0, 0, 640, 450, {{"fill", "#ffffff"}});
  doc.text(12, 20, "Focus — " + fl.lens->prescription().name,
           {{"font-size", "14"}, {"font-weight", "bold"}});
  plot::Chart c;
  c.title = fmt::format("closest focus {:.3f} m; dashed: infinity", curve.closest_m);
  c.x_label = "focus distance from the film (m, log scale)";
  c.y_label = "film distance behind the rear vertex (mm)";
  c.x_log = true;
  plot::Series thick{"thick lens", plot::paletteColor(0), plot::Style::Line, {}};
  plot::Series exact{"exact (real rays)", plot::paletteColor(1), plot::Style::Markers, {}};
  exact.marker_radius = 2.2;
  for (size_t k = 0; k < curve.focus_distance_m.size(); ++k) {
    thick.points.push_back({curve.focus_distance_m[k], curve.film_distance_thick_mm[k]});
    if (std::isfinite(curve.film_distance_exact_mm[k]))
      exact.points.push_back({curve.focus_distance_m[k], curve.film_distance_exact_mm[k]});
  }
  const double x0 = curve.focus_distance_m.front(), x1 = curve.focus_distance_m.back();
  c.series.push_back(thick);
  c.series.push_back(exact);
  c.series.push_back({"",
                      plot::paletteColor(0),
                      plot::Style::Dashed,
                      {{x0, curve.infinity_thick_mm}, {x1, curve.infinity_thick_mm}}});
  if (std::isfinite(curve.infinity_exact_mm))
    c.series.push_back({"",
                        plot::paletteColor(1),
                        plot::Style::Dashed,
                        {{x0, curve.infinity_exact_mm}, {x1, curve.infinity_exact_mm}}});
  c.render(doc, 0, 30, 640, 420);
  return doc.str();
}

}  // namespace lensim::optics
