#include "lensim/optics/diagram.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lensim/optics/anamorphic.h"
#include "lensim/optics/chief_ray.h"
#include "lensim/optics/coating/ghost_trace.h"
#include "lensim/util/plot.h"

namespace lensim::optics {

namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

// Sag of an interface at height h in the y-z section (aspheric profiles included).
double interfaceSag(const Interface& s, double h) {
  if (s.shape.isSpherical()) return sphericalSag(s.radius_mm, h);
  if (auto g = surfaceSag(s.radius_mm, s.shape, 0.0, h)) return g->z;
  return sphericalSag(s.radius_mm, h);
}

std::vector<Vec2> profile(const Interface& s, double h_from, double h_to, int steps = 48) {
  std::vector<Vec2> pts;
  for (int k = 0; k <= steps; ++k) {
    const double h = h_from + (h_to - h_from) * k / steps;
    pts.push_back({s.z_mm + interfaceSag(s, h), h});
  }
  return pts;
}

// Outline of the glass between surfaces a and b: front profile, rim, back profile, rim. Where
// the apertures differ, the smaller surface continues as a flat annulus to the larger height.
std::vector<Vec2> elementOutline(const Interface& a, const Interface& b) {
  const double ha = a.semi_aperture_mm, hb = b.semi_aperture_mm;
  const double za = a.z_mm + interfaceSag(a, ha);
  const double zb = b.z_mm + interfaceSag(b, hb);
  std::vector<Vec2> out = profile(a, ha, -ha);
  if (ha > hb) {
    out.push_back({zb, -ha});
  } else if (hb > ha) {
    out.push_back({za, -hb});
  }
  for (const Vec2& p : profile(b, -hb, hb)) out.push_back(p);
  if (ha > hb) {
    out.push_back({zb, ha});
  } else if (hb > ha) {
    out.push_back({za, hb});
  }
  return out;
}

// The interval of aim parameters a for which the ray `make(a)` gets through, scanned finely;
// nullopt if none gets through.
template <typename Make, typename Trace>
std::optional<std::pair<double, double>> passingRange(double lo, double hi, Make make,
                                                      Trace trace) {
  constexpr int kScan = 600;
  std::optional<std::pair<double, double>> range;
  const double step = (hi - lo) / kScan;
  for (int k = 0; k <= kScan; ++k) {
    const double a = lo + step * k;
    if (trace(make(a)).ok()) {
      if (!range) range = {a, a};
      range->second = a;
    }
  }
  if (range) {  // widen by half a step so that the edge rays sit on the rim of the beam
    range->first -= 0.5 * step;
    range->second += 0.5 * step;
  }
  return range;
}

// The diagram's glass: elements, mirrors, obscurations, bare surfaces, the stop and the film.
void addLensOutline(LensDiagram& d, const LensSystem& lens, const DiagramOptions& opts) {
  const auto& s = lens.interfaces();
  const int n = lens.surfaceCount();
  // Elements and bare surfaces.
  std::vector<bool> in_element(n, false);
  for (int i = 0; i + 1 < n; ++i) {
    if (s[i].ior_after > 1.0) {
      d.elements.push_back({i, elementOutline(s[i], s[i + 1])});
      in_element[i] = in_element[i + 1] = true;
    }
  }
  for (int i = 0; i < n; ++i) {
    const double semi = s[i].semi_aperture_mm, inner = s[i].obscuration_radius_mm;
    if (s[i].is_mirror) {
      if (inner > 0) {
        d.mirrors.push_back(profile(s[i], -semi, -inner));
        d.mirrors.push_back(profile(s[i], inner, semi));
      } else {
        d.mirrors.push_back(profile(s[i], -semi, semi));
      }
      continue;
    }
    if (inner > 0) d.obscurations.push_back(profile(s[i], -inner, inner));
    if (!in_element[i] && !s[i].is_stop) d.bare_surfaces.push_back(profile(s[i], -semi, semi));
  }
  if (lens.stopIndex() && !s[*lens.stopIndex()].is_mirror) {  // a mirror stop is its own rim
    const Interface& st = s[*lens.stopIndex()];
    d.stop_z_mm = st.z_mm;
    d.stop_opening_mm = st.semi_aperture_mm;
    d.stop_outer_mm = std::max(*lens.maxStopDiameter_mm() / 2 * 1.25, st.semi_aperture_mm + 1.5);
  }
  d.film_z_mm = lens.realFilmZ_mm();  // where it is (image space folded back by the mirrors)
  d.film_half_height_mm = opts.film_diagonal_mm / 2;
  d.rear_vertex_z_mm = lens.rearVertexZ_mm();
}

// The film in the drawn section: a line through its axial point along `dir`, with normal
// `normal` (both in the section's x-z plane); bundles start at `centre_mm + f * half_length_mm`
// along it.
struct FilmSection {
  Vec3 axial_point, dir{1, 0, 0}, normal{0, 0, 1};
  double centre_mm = 0, half_length_mm = 0;
  bool placed = false;
  Vec3 at(double along_mm) const { return axial_point + dir * along_mm; }
  // The ray parameter where o + t d meets the film plane.
  double hit(const Vec3& o, const Vec3& d) const {
    return dot(normal, axial_point - o) / dot(normal, d);
  }
};

// For a tilted or shifted lens: the section through the lens axis that holds the film's normal
// (or the film's centre when only shifted), turned about the axis onto the x-z plane (exact for a
// rotationally symmetric lens), and where the film crosses it.
FilmSection filmSection(LensDiagram& d, const LensSystem& lens, const DiagramOptions& opts) {
  FilmSection f;
  f.axial_point = {0, 0, lens.filmZ_mm()};
  f.half_length_mm = d.film_half_height_mm;
  if (!opts.tilt_shift.any()) return f;
  const FileLoc where{lens.prescription().path};
  if (lens.imageSpaceReversed() || lens.realFilmZ_mm() != lens.filmZ_mm())
    throw Error(where, "lens diagram: a lens with mirrors cannot be drawn tilted or shifted");
  const FilmPlacement place(opts.tilt_shift, lens.filmZ_mm());
  const Vec3 n = place.filmNormal(), c = place.lensFromFilm({0, 0});
  const bool tilted = std::hypot(n.x, n.y) > 1e-12;
  const double phi = tilted ? std::atan2(n.y, n.x) : std::atan2(c.y, c.x);
  if (std::abs(std::sin(phi)) > 1e-12 && !isRotationallySymmetric(lens.prescription()))
    throw Error(where, fmt::format("lens diagram: this tilt and shift is seen in the section "
                                   "{:.4g} deg from the lens's x-z plane, and the lens is not "
                                   "rotationally symmetric (draw it tilted about y and shifted "
                                   "along x only)",
                                   phi * kDeg));
  const double cp = std::cos(phi), sp = std::sin(phi);
  auto turn = [&](const Vec3& v) { return Vec3{v.x * cp + v.y * sp, -v.x * sp + v.y * cp, v.z}; };
  f.placed = true;
  f.normal = turn(n);
  f.normal.y = 0;
  f.normal = normalize(f.normal);
  f.dir = Vec3{f.normal.z, 0, -f.normal.x};
  const Vec3 centre = turn(c);
  f.centre_mm = dot(centre - f.axial_point, f.dir);
  const double off = std::abs(centre.y);  // the film centre's distance from the section
  f.half_length_mm =
      std::sqrt(std::max(0.0, d.film_half_height_mm * d.film_half_height_mm - off * off));
  const Vec3 a = f.at(f.centre_mm - f.half_length_mm), b = f.at(f.centre_mm + f.half_length_mm);
  d.film_segment = std::array<Vec2, 2>{Vec2{a.z, a.x}, Vec2{b.z, b.x}};
  d.annotations.push_back(fmt::format(
      "tilt ({:g}, {:g})°, shift ({:g}, {:g}) mm: section at {:.1f}° from x; film "
      "{:.1f}° to the lens plane, its centre {:.2f} mm off the section",
      opts.tilt_shift.tilt_deg.x, opts.tilt_shift.tilt_deg.y, opts.tilt_shift.shift_mm.x,
      opts.tilt_shift.shift_mm.y, phi * kDeg, std::acos(std::min(1.0, f.normal.z)) * kDeg, off));
  return f;
}

}  // namespace

LensDiagram buildLensDiagram(const FocusedLens& fl, const DiagramOptions& opts) {
  const LensSystem& lens = *fl.lens;
  const ParaxialData& p = fl.paraxial;
  const auto& s = lens.interfaces();
  LensDiagram d;
  d.source = opts.source;
  d.title = lens.prescription().name;
  d.annotations.push_back(
      fmt::format("f = {:.2f} mm · f/{:.2f} · film distance {:.2f} mm · focus {}",
                  p.effective_focal_length_mm, p.f_number, lens.filmDistance_mm(),
                  std::isinf(fl.focus_distance_m) ? std::string("at infinity")
                                                  : fmt::format("{:.4g} m", fl.focus_distance_m)));

  addLensOutline(d, lens, opts);
  const FilmSection film = filmSection(d, lens, opts);

  double semi_max = 0;
  for (const Interface& si : s) semi_max = std::max(semi_max, si.semi_aperture_mm);
  const double length = lens.filmZ_mm();
  const double extension = std::max(0.35 * length, 2.0 * semi_max);
  const double z_front = -extension;
  const double x_limit = 1.3 * std::max(semi_max, opts.film_diagonal_mm / 2);
  // Continues a ray that left the lens toward the scene up to z_front, or to where it leaves
  // the drawing (|x| = x_limit).
  auto extendToFront = [&](DiagramRay& ray, double z_stop) {
    const Ray& out = ray.result.ray;
    double t = (z_stop - out.origin.z) / out.direction.z;
    if (out.direction.x != 0)
      t = std::min(t, (std::copysign(x_limit, out.direction.x) - out.origin.x) / out.direction.x);
    if (t > 0) ray.points.push_back(out.origin + out.direction * t);
  };

  // Bundles.
  const int rays = std::max(1, opts.rays);
  FieldOfView fov = fieldOfView(lens, p, opts.film_diagonal_mm);
  const double half_fov_deg = 0.5 * (fov.real_deg ? *fov.real_deg : *fov.real_max_deg);
  // Spreads `rays` rays across the range of aim parameters that gets through, traces them, and
  // lets `finish` extend the ones that got out.
  auto bundle = [&](int field, double range_mm, auto make, auto trace, auto finish) {
    auto passing =
        passingRange(-range_mm, range_mm, make, [&](const Ray& r) { return trace(r, nullptr); });
    const auto [lo, hi] =
        passing ? *passing : std::pair<double, double>{-range_mm / 1.5, range_mm / 1.5};
    for (int k = 0; k < rays; ++k) {
      DiagramRay ray;
      ray.field = field;
      const double a = rays == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * k / (rays - 1);
      ray.start = make(a);
      ray.result = trace(ray.start, &ray.points);
      finish(ray);
      d.rays.push_back(std::move(ray));
    }
  };
  // Film-side aim plane: the exit pupil when it lies in front of the film (aiming there is well
  // conditioned even when the film sits close to the rear vertex), else the rear vertex.
  const bool aim_at_xp =
      p.exit_pupil_z_mm < lens.filmZ_mm() - 0.02 * std::abs(p.effective_focal_length_mm);
  const double z_aim = aim_at_xp ? p.exit_pupil_z_mm : lens.rearVertexZ_mm();
  for (size_t f = 0; f < opts.fields.size(); ++f) {
    const double frac = opts.fields[f];
    const int field = static_cast<int>(f);
    if (opts.source == DiagramSource::Film) {
      const double h = frac * film.half_length_mm;
      d.field_values.push_back(h);
      const Vec3 from = film.at(film.centre_mm + h);
      const double range = aim_at_xp ? 1.5 * p.exit_pupil_diameter_mm / 2 + std::abs(from.x)
                                     : 1.5 * s.back().semi_aperture_mm;
      bundle(
          field, range,
          [&](double a) {
            return Ray{from, normalize(Vec3{a, 0, z_aim} - from)};
          },
          [&](const Ray& r, std::vector<Vec3>* path) {
            return lens.tracer().traceFromFilm(r, {}, path);
          },
          [&](DiagramRay& ray) {
            if (ray.result.ok())
              extendToFront(ray, z_front);
            else if (ray.result.reason == BlockReason::Miss)  // show where it was heading
              extendToFront(ray, s[ray.result.blocked_surface].z_mm);
          });
    } else {
      const double th = frac * half_fov_deg;
      d.field_values.push_back(th);
      const Vec3 dir{std::sin(th / kDeg), 0, std::cos(th / kDeg)};
      const double range = 1.5 * s.front().semi_aperture_mm +
                           std::abs(std::tan(th / kDeg)) * std::abs(p.entrance_pupil_z_mm);
      bundle(
          field, range,
          [&](double a) {
            // Start on the plane z_front, or where the ray enters the drawing (|x| = x_limit).
            const Vec3 at{a, 0, p.entrance_pupil_z_mm};
            double t = (z_front - at.z) / dir.z;
            if (dir.x != 0) t = std::max(t, (-std::copysign(x_limit, dir.x) - at.x) / dir.x);
            return Ray{at + dir * t, dir};
          },
          [&](const Ray& r, std::vector<Vec3>* path) {
            return lens.tracer().traceFromScene(r, {}, path);
          },
          [&](DiagramRay& ray) {
            const Ray& out = ray.result.ray;
            if (ray.result.ok() && out.direction.z > 0) {
              const double t = film.hit(out.origin, out.direction);
              Vec3 q = out.origin + out.direction * t;
              // The tracer unfolds image space after an odd number of mirrors; fold it back.
              if (lens.imageSpaceReversed()) q.z = 2 * lens.rearVertexZ_mm() - q.z;
              if (t > 0) ray.points.push_back(q);
            }
          });
    }
  }

  // Extent.
  double z_lo = std::min(0.0, d.film_z_mm), z_hi = d.film_z_mm;
  for (const Interface& si : s) z_lo = std::min(z_lo, si.z_mm), z_hi = std::max(z_hi, si.z_mm);
  d.z_min = std::min(z_front, z_lo - 0.03 * length);
  d.z_max = z_hi + 0.03 * length;
  d.x_max = std::max({semi_max, d.film_half_height_mm, d.stop_outer_mm.value_or(0)});
  if (d.film_segment)
    for (const Vec2& e : *d.film_segment) {
      d.z_max = std::max(d.z_max, e.x + 0.03 * length);
      d.x_max = std::max(d.x_max, std::abs(e.y));
    }
  for (const DiagramRay& r : d.rays)
    for (const Vec3& q : r.points) d.x_max = std::max(d.x_max, std::abs(q.x));
  d.x_max = std::min(d.x_max, x_limit);
  return d;
}

void setGhostBundle(LensDiagram& d, const FocusedLens& fl, int first, int second, int rays) {
  const LensSystem& lens = *fl.lens;
  const LensTracer<double> tracer = ghostTracer(lens, first, second);  // throws for a bad pair
  const auto& s = lens.interfaces();
  double semi_max = 0;
  for (const Interface& si : s) semi_max = std::max(semi_max, si.semi_aperture_mm);
  const double x_limit = 1.3 * std::max(semi_max, d.film_half_height_mm);
  const double z_front = d.z_min;
  const std::string name = fmt::format("{},{}", first, second);
  auto make = [&](double h) { return Ray{{h, 0, z_front}, {0, 0, 1}}; };
  auto trace = [&](const Ray& r) { return tracer.traceFromScene(r); };
  const double range = 1.5 * s.front().semi_aperture_mm;
  const auto passing = passingRange(-range, range, make, trace);
  const auto [lo, hi] = passing ? *passing : std::pair<double, double>{-range / 1.5, range / 1.5};
  d.rays.clear();
  d.field_values.clear();
  const int count = std::max(1, rays);
  for (int k = 0; k < count; ++k) {
    DiagramRay ray;
    ray.ghost = name;
    ray.color = "#c0392b";
    const double h = count == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * k / (count - 1);
    ray.start = make(h);
    ray.result = tracer.traceFromScene(ray.start, {}, &ray.points);
    if (!ray.result.ok())  // the lens surface where it stopped, not the position on the path
      ray.result.blocked_surface = ghostPathSurface(first, second, ray.result.blocked_surface);
    const Ray& out = ray.result.ray;
    if (ray.result.ok() && out.direction.z > 0) {
      // On to the film, or to where the ray leaves the drawing (|x| = x_limit).
      double t = (lens.filmZ_mm() - out.origin.z) / out.direction.z;
      if (out.direction.x != 0)
        t = std::min(t, (std::copysign(x_limit, out.direction.x) - out.origin.x) / out.direction.x);
      if (t > 0) ray.points.push_back(out.origin + out.direction * t);
    }
    d.rays.push_back(std::move(ray));
  }
  d.annotations.push_back(fmt::format(
      "ghost {}: an axial beam from infinity reflected at surface {}, then at surface {}", name,
      first, second));
  for (const DiagramRay& r : d.rays)
    for (const Vec3& q : r.points) d.x_max = std::max(d.x_max, std::min(std::abs(q.x), x_limit));
}

double fitScale(const LensDiagram& d, double w, double h) {
  const double usable_w = w - 40, usable_h = h - 90;  // margins, title and annotations
  return std::min(usable_w / (d.z_max - d.z_min), usable_h / (2 * d.x_max));
}

void drawLensDiagram(svg::Document& doc, const LensDiagram& d, double x, double y, double w,
                     double h, double s) {
  // Lens space (z, x) to pixels: z to the right, x up, axis in the middle of the drawing area.
  const double draw_top = y + 44, draw_bottom = y + h - 40;
  const double cy = 0.5 * (draw_top + draw_bottom);
  const double cx = x + 0.5 * w - 0.5 * s * (d.z_min + d.z_max);
  auto P = [&](double z, double xx) { return std::pair<double, double>{cx + s * z, cy - s * xx}; };
  const double clip = d.x_max * 1.02;

  doc.beginGroup({{"class", "lens-diagram"}});
  doc.title(d.title);
  doc.text(x + 12, y + 20, d.title, {{"font-size", "14"}, {"font-weight", "bold"}});
  for (size_t i = 0; i < d.annotations.size(); ++i)
    doc.text(x + 12, y + 36 + 14 * static_cast<double>(i), d.annotations[i], {{"font-size", "11"}});

  // Optical axis, rear-vertex plane, film.
  doc.line(cx + s * d.z_min, cy, cx + s * d.z_max, cy,
           {{"class", "axis"}, {"stroke", "#777777"}, {"stroke-dasharray", "8 3 2 3"}});
  doc.line(cx + s * d.rear_vertex_z_mm, cy - s * clip, cx + s * d.rear_vertex_z_mm, cy + s * clip,
           {{"class", "rear-vertex-plane"}, {"stroke", "#aaaaaa"}, {"stroke-dasharray", "2 3"}});
  if (d.film_segment) {
    auto [ax, ay] = P((*d.film_segment)[0].x, (*d.film_segment)[0].y);
    auto [bx, by] = P((*d.film_segment)[1].x, (*d.film_segment)[1].y);
    doc.line(ax, ay, bx, by, {{"class", "film"}, {"stroke", "#000000"}, {"stroke-width", "3"}});
    doc.text(std::max(ax, bx) + 4, std::max(ay, by) + 12, "film (tilted/shifted)",
             {{"font-size", "10"}, {"text-anchor", "end"}});
  } else {
    auto [fx, fy0] = P(d.film_z_mm, d.film_half_height_mm);
    auto [fx1, fy1] = P(d.film_z_mm, -d.film_half_height_mm);
    doc.line(fx, fy0, fx1, fy1, {{"class", "film"}, {"stroke", "#000000"}, {"stroke-width", "3"}});
    doc.text(fx + 4, fy1 + 12, fmt::format("film ±{:.1f} mm", d.film_half_height_mm),
             {{"font-size", "10"}, {"text-anchor", "end"}});
  }

  // Glass elements and bare surfaces.
  for (const DiagramElement& e : d.elements) {
    std::vector<std::pair<double, double>> pts;
    for (const Vec2& q : e.outline) pts.push_back(P(q.x, q.y));
    doc.polygon(pts, {{"class", "element"},
                      {"data-surfaces", fmt::format("{}-{}", e.front_surface, e.front_surface + 1)},
                      {"fill", "#cfe3f3"},
                      {"stroke", "#2b5d84"},
                      {"stroke-width", "1.2"}});
  }
  for (const auto& prof : d.bare_surfaces) {
    std::vector<std::pair<double, double>> pts;
    for (const Vec2& q : prof) pts.push_back(P(q.x, q.y));
    doc.polyline(pts, {{"class", "surface"}, {"stroke", "#2b5d84"}, {"stroke-width", "1.2"}});
  }
  // Mirrors: thick dark curves; central obscurations: dark bars on their surface.
  for (const auto& prof : d.mirrors) {
    std::vector<std::pair<double, double>> pts;
    for (const Vec2& q : prof) pts.push_back(P(q.x, q.y));
    doc.polyline(pts, {{"class", "mirror"}, {"stroke", "#444444"}, {"stroke-width", "3"}});
  }
  for (const auto& prof : d.obscurations) {
    std::vector<std::pair<double, double>> pts;
    for (const Vec2& q : prof) pts.push_back(P(q.x, q.y));
    doc.polyline(pts, {{"class", "obscuration"}, {"stroke", "#111111"}, {"stroke-width", "4"}});
  }
  // Stop blades.
  if (d.stop_z_mm) {
    for (double sign : {1.0, -1.0}) {
      auto [x0, y0] = P(*d.stop_z_mm, sign * *d.stop_opening_mm);
      auto [x1, y1] = P(*d.stop_z_mm, sign * *d.stop_outer_mm);
      doc.line(x0, y0, x1, y1, {{"class", "stop"}, {"stroke", "#222222"}, {"stroke-width", "3.5"}});
    }
  }

  // Rays, one colour per field; blocked rays end with a mark.
  for (const DiagramRay& r : d.rays) {
    const std::string colour = r.color.empty() ? plot::paletteColor(r.field) : r.color;
    std::vector<std::pair<double, double>> pts;
    for (const Vec3& q : r.points) pts.push_back(P(q.z, std::clamp(q.x, -clip, clip)));
    svg::Attrs a{{"class", r.ghost.empty() ? "ray" : "ghost-ray"},
                 {"data-field", std::to_string(r.field)},
                 {"stroke", colour},
                 {"stroke-width", "0.9"},
                 {"stroke-opacity", "0.85"}};
    if (!r.ghost.empty()) a.push_back({"data-ghost", r.ghost});
    if (!r.result.ok()) {
      a.push_back({"data-blocked-at", std::to_string(r.result.blocked_surface)});
      a.push_back({"data-reason", blockReasonName(r.result.reason)});
    }
    doc.polyline(pts, a);
    if (!r.result.ok() && !pts.empty()) {
      auto [bx, by] = pts.back();
      doc.line(bx - 3, by - 3, bx + 3, by + 3,
               {{"class", "block-mark"}, {"stroke", colour}, {"stroke-width", "1.5"}});
      doc.line(bx - 3, by + 3, bx + 3, by - 3,
               {{"class", "block-mark"}, {"stroke", colour}, {"stroke-width", "1.5"}});
    }
  }

  // Legend of the fields and a millimetre scale bar.
  double ly = y + h - 12;
  double lx = x + 12;
  for (size_t f = 0; f < d.field_values.size(); ++f) {
    const std::string label = d.source == DiagramSource::Film
                                  ? fmt::format("film {:.1f} mm", d.field_values[f])
                                  : fmt::format("{:.1f}°", d.field_values[f]);
    doc.line(lx, ly - 4, lx + 16, ly - 4,
             {{"stroke", plot::paletteColor(static_cast<int>(f))}, {"stroke-width", "2"}});
    doc.text(lx + 20, ly, label, {{"font-size", "10"}});
    lx += 30 + 6.0 * static_cast<double>(label.size());
  }
  // The largest 1, 2 or 5 x 10^k millimetres that fits in a fifth of the cell.
  const double room_mm = 0.2 * w / s;
  double bar_mm = std::pow(10.0, std::floor(std::log10(room_mm)));
  for (double m : {5.0, 2.0})
    if (m * bar_mm <= room_mm) {
      bar_mm *= m;
      break;
    }
  const double bx = x + w - 20 - bar_mm * s;
  doc.rect(bx, ly - 7, bar_mm * s, 4, {{"class", "scale-bar"}, {"fill", "#000000"}});
  doc.text(bx + bar_mm * s / 2, ly - 10, fmt::format("{:g} mm", bar_mm),
           {{"font-size", "10"}, {"text-anchor", "middle"}});
  doc.endGroup();
}

std::string lensDiagramSheet(const std::vector<LensDiagram>& diagrams, bool same_scale,
                             int columns) {
  const int count = static_cast<int>(diagrams.size());
  const int cols = columns > 0 ? std::min(columns, std::max(count, 1)) : count > 1 ? 2 : 1;
  const int rows = (count + cols - 1) / cols;
  const double cw = 720, ch = 420;
  svg::Document doc(cw * cols, ch * rows);
  doc.rect(0, 0, cw * cols, ch * rows, {{"fill", "#ffffff"}});
  double common = 1e300;
  for (const LensDiagram& d : diagrams) common = std::min(common, fitScale(d, cw, ch));
  for (int i = 0; i < count; ++i) {
    const double x = cw * (i % cols), y = ch * (i / cols);
    doc.rect(x + 2, y + 2, cw - 4, ch - 4, {{"fill", "none"}, {"stroke", "#dddddd"}});
    const double s = same_scale ? common : fitScale(diagrams[i], cw, ch);
    drawLensDiagram(doc, diagrams[i], x, y, cw, ch, s);
  }
  return doc.str();
}

}  // namespace lensim::optics
