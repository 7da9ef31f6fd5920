// `lensim lens ghosts` and the coating lines of `lensim lens info` (issue 31).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "flare_report.h"
#include "lens_options.h"
#include "lensim/optics/coating/ghost_trace.h"
#include "lensim/optics/coating/ghosts.h"
#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/optics/diagram.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/util/file.h"
#include "lensim/util/log.h"
#include "lensim/util/plot.h"
#include "lensim/util/svg.h"

namespace lensim::cmd {

using json = nlohmann::json;
using namespace lensim::optics;

namespace {

// The wavelengths reflection losses are reported at: blue, green, red, and the visible band
// 400..700 nm in 10 nm steps (its mean: an equal-energy white light).
const double kReportWavelengths[] = {450, 550, 650};

std::vector<double> visibleBand() {
  std::vector<double> w;
  for (int l = 400; l <= 700; l += 10) w.push_back(l);
  return w;
}

double meanTransmittance(const LensSystem& lens, const LensCoatings& c) {
  double sum = 0;
  const std::vector<double> band = visibleBand();
  for (double l : band) sum += axialTransmittance(lens, c, l);
  return sum / double(band.size());
}

std::string fmtInf(double v, const char* f) {
  return std::isfinite(v) ? fmt::format(fmt::runtime(f), v) : std::string("inf");
}

json finiteOr(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

struct GhostArgs {
  std::string wavelengths;
  int top = 0;
  double focus_tolerance_mm = 0.05;
  std::string coating;  // overrides the lens-wide default coating
  bool as_json = false;
  /// Light angle off axis (deg, meridional x-z plane): each ghost's film spot traced with
  /// real rays; unset: the paraxial axial analysis only.
  std::optional<double> angle_deg;
  int grid = 64;  // rays across the entrance for the traced spots
};

// For a light at `angle_deg`: every ghost's traced film spot (nullopt for a pair that reflects
// nothing: the stop or a dummy surface) and the direct image's, and their light from the same
// real rays weighted by the coatings at each ray's angles (tracedPathEnergy); `order`: the
// ghosts' indices, brightest at that angle first.
struct TracedSpots {
  GhostSpot direct;
  std::vector<double> direct_energy;
  std::vector<std::optional<GhostSpot>> ghosts;
  /// Per ghost: its light over the direct image's, per wavelength and their mean.
  std::vector<std::vector<double>> relative_per_wavelength;
  std::vector<double> relative;
  std::vector<size_t> order;
};

TracedSpots traceSpots(const LensSystem& lens, const LensCoatings& coatings, const GhostAnalysis& g,
                       double angle_deg, int grid) {
  if (!(std::abs(angle_deg) < 89))
    throw Error(fmt::format("--angle {}: expected a light angle within -89..89 degrees",
                            angle_deg));
  const double a = angle_deg * std::numbers::pi / 180;
  const Interface& front = lens.interfaces().front();
  const std::vector<double>& wl = g.wavelengths_nm;
  TracedSpots t;
  t.direct = traceSpot(LensTracer<double>(lens.interfaces()), front, lens.filmZ_mm(), a, grid);
  t.direct_energy = tracedPathEnergy(lens, coatings, -1, -1, a, grid, wl);
  for (const Ghost& h : g.ghosts) {
    const auto& s = lens.interfaces();
    std::vector<double> rel(wl.size(), 0.0);
    double mean = 0;
    if (s[size_t(h.a)].ior_before == s[size_t(h.a)].ior_after ||
        s[size_t(h.b)].ior_before == s[size_t(h.b)].ior_after) {
      t.ghosts.emplace_back();
    } else {
      t.ghosts.emplace_back(
          traceSpot(ghostTracer(lens, h.b, h.a), front, lens.filmZ_mm(), a, grid));
      const std::vector<double> e = tracedPathEnergy(lens, coatings, h.b, h.a, a, grid, wl);
      for (size_t w = 0; w < wl.size(); ++w) {
        rel[w] = t.direct_energy[w] > 0 ? e[w] / t.direct_energy[w] : 0.0;
        mean += rel[w] / double(wl.size());
      }
    }
    t.relative_per_wavelength.push_back(std::move(rel));
    t.relative.push_back(mean);
  }
  for (size_t i = 0; i < g.ghosts.size(); ++i) t.order.push_back(i);
  std::stable_sort(t.order.begin(), t.order.end(),
                   [&](size_t x, size_t y) { return t.relative[x] > t.relative[y]; });
  return t;
}

json spotJson(const GhostSpot& s) {
  if (s.rays_arrived == 0) return json{{"rays_arrived", 0}, {"rays_launched", s.rays_launched}};
  return json{{"rays_arrived", s.rays_arrived},     {"rays_launched", s.rays_launched},
              {"centroid_x_mm", s.centroid_x_mm},   {"centroid_y_mm", s.centroid_y_mm},
              {"rms_radius_mm", s.rms_radius_mm},   {"extent_x_mm", s.extent_x_mm},
              {"extent_y_mm", s.extent_y_mm}};
}

std::string spotLine(const std::string& rank, const std::string& label, const GhostSpot& s,
                     double intensity) {
  if (s.rays_arrived == 0)
    return fmt::format("  {:>4} {:>7} {:>12} {:>9} {:>9}  no ray reaches the film\n", rank, label,
                       "", 0, s.rays_launched);
  return fmt::format(
      "  {:>4} {:>7} {:>12.4e} {:>9} {:>9} {:>11.4f} {:>11.4f} {:>10.4f} {:>10.4f} {:>10.4f}\n",
      rank, label, intensity, s.rays_arrived, s.rays_launched, s.centroid_x_mm, s.centroid_y_mm,
      s.rms_radius_mm, s.extent_x_mm, s.extent_y_mm);
}

void printSpots(const GhostAnalysis& g, size_t shown, const TracedSpots& t, double angle_deg,
                int grid) {
  std::cout << fmt::format(
      "\n  traced film spots of a point light {} deg off axis (x-z plane; {}x{} ray grid; lens "
      "wavelength), brightest at that angle first:\n\n  {:>4} {:>7} {:>12} {:>9} {:>9} {:>11} "
      "{:>11} {:>10} {:>10} {:>10}\n",
      angle_deg, grid, grid, "rank", "I,J", "intensity", "arrived", "launched", "centroid x",
      "centroid y", "rms r", "extent x", "extent y");
  std::cout << spotLine("", "direct", t.direct, 1.0);
  for (size_t r = 0; r < shown; ++r) {
    const size_t i = t.order[r];
    const std::string ij = fmt::format("{},{}", g.ghosts[i].b, g.ghosts[i].a);
    if (t.ghosts[i])
      std::cout << spotLine(std::to_string(r + 1), ij, *t.ghosts[i], t.relative[i]);
    else
      std::cout << fmt::format("  {:>4} {:>7}  reflects nothing (the stop or a dummy surface)\n",
                               r + 1, ij);
  }
  std::cout << "\n  intensity: the ghost's light on the film over the direct image's, from the "
               "traced rays with the coatings' R and T at each ray's angles (mean over the "
               "wavelengths); mm on the film; arrived / launched: rays of the grid that reach "
               "the film on the ghost path / that were launched\n";
}

int runGhosts(const LensArgs& args, const GhostArgs& ga) {
  FocusedLens fl = setUpLens(args);
  const LensSystem& lens = *fl.lens;
  logDiagnostics(fl.allDiagnostics());
  LensPrescription pr_coated = lens.prescription();
  if (!ga.coating.empty()) {
    pr_coated.default_coating = ga.coating;
    pr_coated.default_coating_loc = FileLoc{};  // named on the command line
  }
  const LensCoatings coatings = resolveCoatings(pr_coated);
  const std::vector<double> wl =
      ga.wavelengths.empty() ? visibleBand() : parseWavelengthList(ga.wavelengths, "--wavelengths");
  if (!(ga.focus_tolerance_mm > 0))
    throw Error(fmt::format("--focus-tolerance {} must be > 0 (mm)", ga.focus_tolerance_mm));
  GhostAnalysis g = analyseGhosts(lens, coatings, wl);
  const size_t shown =
      ga.top > 0 ? std::min(g.ghosts.size(), size_t(ga.top)) : g.ghosts.size();
  double total = 0;
  for (const Ghost& h : g.ghosts) total += h.relative_intensity;
  double direct = 0;
  for (double t : g.direct_transmittance) direct += t;
  direct /= double(std::max<size_t>(1, g.direct_transmittance.size()));
  const auto& pr = lens.prescription();
  if (ga.grid < 2 || ga.grid > 2000)
    throw Error(fmt::format("--grid {}: expected 2 to 2000 rays across", ga.grid));
  std::optional<TracedSpots> spots;
  if (ga.angle_deg) spots = traceSpots(lens, coatings, g, *ga.angle_deg, ga.grid);
  if (ga.as_json) {
    json j;
    j["lens"] = pr.path;
    j["wavelengths_nm"] = g.wavelengths_nm;
    j["direct_transmittance"] = g.direct_transmittance;
    j["direct_transmittance_mean"] = direct;
    j["film_z_mm"] = lens.filmZ_mm();
    j["ghost_count"] = g.ghosts.size();
    j["total_relative_intensity"] = total;
    j["focus_tolerance_mm"] = ga.focus_tolerance_mm;
    json arr = json::array();
    for (size_t i = 0; i < shown; ++i) {
      const Ghost& h = g.ghosts[i];
      arr.push_back({{"first_reflection_surface", h.b},
                     {"second_reflection_surface", h.a},
                     {"relative_intensity", h.relative_intensity},
                     {"relative_intensity_per_wavelength", h.relative_intensity_per_wavelength},
                     {"aperture_fraction", h.aperture_fraction},
                     {"focus_z_mm", finiteOr(h.focus_z_mm)},
                     {"defocus_mm", finiteOr(h.defocus_mm)},
                     {"film_diameter_mm", h.film_diameter_mm},
                     {"in_focus", h.film_diameter_mm < ga.focus_tolerance_mm}});
      if (spots && spots->ghosts[i]) {
        json spot = spotJson(*spots->ghosts[i]);
        spot["relative_intensity"] = spots->relative[i];
        spot["relative_intensity_per_wavelength"] = spots->relative_per_wavelength[i];
        arr.back()["spot"] = spot;
      } else if (spots) {
        arr.back()["spot"] = nullptr;
      }
    }
    if (spots) {
      j["angle_deg"] = *ga.angle_deg;
      j["grid"] = ga.grid;
      j["direct_spot"] = spotJson(spots->direct);
      // The ghosts ranked by their traced intensity at the angle (the same count as "ghosts").
      json ranking = json::array();
      for (size_t r = 0; r < shown; ++r) {
        const size_t i = spots->order[r];
        ranking.push_back({{"rank", r + 1},
                           {"first_reflection_surface", g.ghosts[i].b},
                           {"second_reflection_surface", g.ghosts[i].a},
                           {"relative_intensity", spots->relative[i]}});
      }
      j["angle_ranking"] = ranking;
    }
    j["ghosts"] = arr;
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << fmt::format(
      "{}: {} two-reflection ghosts of an axial point at infinity ({} wavelength{} {:.0f}..{:.0f} "
      "nm; direct transmittance {:.4f}; all ghosts together {:.3e} of the direct image)\n",
      pr.name, g.ghosts.size(), wl.size(), wl.size() == 1 ? "" : "s,", wl.front(), wl.back(),
      direct, total);
  std::cout << fmt::format("\n  {:>4} {:>7} {:>12} {:>9} {:>12} {:>11} {:>11}  {}\n", "rank",
                           "I,J", "intensity", "aperture", "focus z", "defocus", "film diam",
                           "focus");
  for (size_t i = 0; i < shown; ++i) {
    const Ghost& h = g.ghosts[i];
    std::cout << fmt::format("  {:>4} {:>7} {:>12.4e} {:>9.4f} {:>12} {:>11} {:>11.4f}  {}\n",
                             i + 1, fmt::format("{},{}", h.b, h.a), h.relative_intensity,
                             h.aperture_fraction, fmtInf(h.focus_z_mm, "{:.4f}"),
                             fmtInf(h.defocus_mm, "{:.4f}"), h.film_diameter_mm,
                             h.film_diameter_mm < ga.focus_tolerance_mm ? "in focus" : "");
  }
  std::cout << "\n  I,J: reflected first at surface I (toward the scene), then at J; intensity: "
               "ghost energy / direct image energy; aperture: fraction of the entrance beam the "
               "clear apertures pass on the ghost path; focus z, defocus (focus - film) and film "
               "diameter in mm (paraxial)\n";
  if (spots) printSpots(g, shown, *spots, *ga.angle_deg, ga.grid);
  return 0;
}

}  // namespace

std::vector<double> parseWavelengthList(const std::string& text, const char* option) {
  std::vector<double> wl;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t end = text.find(',', pos);
    if (end == std::string::npos) end = text.size();
    const std::string item = text.substr(pos, end - pos);
    double v = 0;
    try {
      size_t used = 0;
      v = std::stod(item, &used);
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw Error(
          fmt::format("{}: '{}' is not a number (expected nm, comma-separated)", option, item));
    }
    checkWavelength(v, option);
    wl.push_back(v);
    pos = end + 1;
  }
  return wl;
}

json coatingsJson(const LensSystem& lens) {
  LensCoatings c;
  try {
    c = resolveCoatings(lens.prescription());
  } catch (const Error& e) {
    return json{{"error", e.what()}};
  }
  json j;
  j["surfaces"] = c.label;
  json t = json::object();
  for (double l : kReportWavelengths) t[fmt::format("{:.0f}", l)] = axialTransmittance(lens, c, l);
  j["axial_transmittance"] = t;
  j["axial_transmittance_400_700"] = meanTransmittance(lens, c);
  return j;
}

void printCoatings(const LensSystem& lens) {
  LensCoatings c;
  try {
    c = resolveCoatings(lens.prescription());
  } catch (const Error& e) {
    std::cout << fmt::format("  {:<26}not available: {}\n", "coatings", e.what());
    return;
  }
  std::string list;
  for (size_t k = 0; k < c.label.size(); ++k)
    list += fmt::format("{}{} {}", k ? ", " : "", k, c.label[k]);
  std::cout << fmt::format("  {:<26}{}\n", "coatings", list);
  std::string t;
  for (double l : kReportWavelengths)
    t += fmt::format("{:.4f} at {:.0f} nm, ", axialTransmittance(lens, c, l), l);
  std::cout << fmt::format("  {:<26}{}mean {:.4f} over 400..700 nm (reflection losses, axial)\n",
                           "transmittance", t, meanTransmittance(lens, c));
  // The indices of a glass valid over part of 400..700 nm only are its formula's beyond that.
  std::string beyond;
  for (const Glass& g : lens.glasses())
    if (g.dispersive() && (!g.inRange(400) || !g.inRange(700)) &&
        beyond.find(g.describe() + " ") == std::string::npos)
      beyond += fmt::format("{}{} ({:g}-{:g} nm)", beyond.empty() ? "" : ", ", g.describe(),
                            g.minWavelength_nm(), g.maxWavelength_nm());
  if (!beyond.empty())
    std::cout << fmt::format("  {:<26}the formulas of {} are used beyond their valid ranges\n",
                             "", beyond);
}

std::pair<int, int> parseGhostPair(const std::string& ghost) {
  // I,J: two non-negative integers.
  const size_t comma = ghost.find(',');
  int ij[2] = {0, 0};
  bool parsed = comma != std::string::npos;
  for (int k = 0; parsed && k < 2; ++k) {
    const std::string item = k == 0 ? ghost.substr(0, comma) : ghost.substr(comma + 1);
    parsed = !item.empty() && item.size() < 6 &&
             item.find_first_not_of("0123456789") == std::string::npos;
    if (parsed) ij[k] = std::stoi(item);
  }
  if (!parsed)
    throw Error(
        fmt::format("ghost {}: expected I,J (two surface indices, as `lens ghosts` "
                    "lists them)",
                    ghost));
  return {ij[0], ij[1]};
}

int runGhostDraw(const LensArgs& args, const std::string& ghost, int rays,
                 const std::string& output) {
  const auto [first, second] = parseGhostPair(ghost);
  const int ij[2] = {first, second};
  if (rays < 1 || rays > 1000) throw Error(fmt::format("--rays {}: expected 1 to 1000", rays));
  FocusedLens fl = setUpLens(args);
  logDiagnostics(fl.allDiagnostics());
  const LensSystem& lens = *fl.lens;
  DiagramOptions opts;
  opts.rays = rays;
  opts.film_diagonal_mm = args.film_diagonal_mm;
  opts.fields = {0.0};
  LensDiagram d = buildLensDiagram(fl, opts);
  setGhostBundle(d, fl, ij[0], ij[1], rays);  // refuses a bad pair, naming it
  // The paraxial ghost focus and intensity, as `lens ghosts` reports them (when the coatings
  // resolve; the drawing does not need them).
  try {
    const std::vector<double> band = visibleBand();
    const GhostAnalysis g = analyseGhosts(lens, resolveCoatings(lens.prescription()), band);
    for (const Ghost& h : g.ghosts)
      if (h.b == ij[0] && h.a == ij[1])
        d.annotations.push_back(fmt::format(
            "paraxial focus z {} mm (film at {:.3f} mm), film diameter {:.3f} mm, relative "
            "intensity {:.3e}",
            fmtInf(h.focus_z_mm, "{:.3f}"), lens.filmZ_mm(), h.film_diameter_mm,
            h.relative_intensity));
  } catch (const Error& e) {
    logWarning(fmt::format("ghost intensity not annotated: {}", e.what()));
  }
  writeFileAtomically(output, lensDiagramSheet({d}, false, 1));
  logInfo(fmt::format("wrote {} (ghost {},{}, {} rays)", output, ij[0], ij[1], rays));
  return 0;
}

int runGhostPlot(const LensArgs& args, const std::string& output, bool as_json,
                 std::optional<double> angle_deg) {
  FocusedLens fl = setUpLens(args);
  logDiagnostics(fl.allDiagnostics());
  const LensSystem& lens = *fl.lens;
  const std::vector<double> band = visibleBand();
  const LensCoatings coatings = resolveCoatings(lens.prescription());
  const GhostAnalysis g = analyseGhosts(lens, coatings, band);
  // The ghosts to plot, brightest first: (first surface, second surface, intensity), axial
  // (paraxial) or traced at the angle.
  struct Bar {
    int b = 0, a = 0;
    double intensity = 0;
  };
  std::vector<Bar> ranked;
  if (angle_deg) {
    const TracedSpots t = traceSpots(lens, coatings, g, *angle_deg, 64);
    for (size_t i : t.order) ranked.push_back({g.ghosts[i].b, g.ghosts[i].a, t.relative[i]});
  } else {
    for (const Ghost& h : g.ghosts) ranked.push_back({h.b, h.a, h.relative_intensity});
  }
  constexpr size_t kShown = 20;  // the brightest; the rest are orders of magnitude fainter
  // Linear bars in units of the brightest ghost's decade, with room above them for the notes.
  const double brightest = ranked.empty() ? 0.0 : ranked.front().intensity;
  if (!(brightest > 0))
    throw Error(fmt::format("{}: no ghost reaches the film (no two surfaces reflect)",
                            lens.prescription().path));
  const int decade = int(std::floor(std::log10(brightest)));
  const double unit = std::pow(10.0, decade);
  plot::Chart chart;
  chart.title = fmt::format("Ghost intensities — {}", lens.prescription().name);
  chart.x_label = "rank (brightest first)";
  chart.y_label = fmt::format("ghost / direct image energy (x 1e{})", decade);
  plot::Series bars;
  bars.style = plot::Style::Bars;
  bars.name = angle_deg ? fmt::format("{} deg off axis, traced, 400-700 nm", *angle_deg)
                        : std::string("axial, 400-700 nm");
  json ranks = json::array();
  double total = 0;
  for (const Bar& h : ranked) total += h.intensity;
  std::string top;
  for (const Bar& h : ranked) {
    if (bars.points.size() == kShown || !(h.intensity > 0)) break;
    const double rank = double(bars.points.size() + 1);
    bars.points.push_back({rank, h.intensity / unit});
    ranks.push_back({{"rank", rank},
                     {"first_reflection_surface", h.b},
                     {"second_reflection_surface", h.a},
                     {"relative_intensity", h.intensity}});
    if (bars.points.size() <= 6)
      top += fmt::format("{}{}: {},{}", top.empty() ? "" : "  ", bars.points.size(), h.b, h.a);
  }
  chart.y_range = std::pair{0.0, 1.3 * brightest / unit};
  chart.x_range = std::pair{0.3, double(bars.points.size()) + 0.7};
  chart.notes.push_back(
      fmt::format("all {} ghosts together {:.3e} of the direct image", g.ghosts.size(), total));
  chart.notes.push_back("I,J of the brightest: " + top);
  chart.series.push_back(std::move(bars));
  svg::Document doc(720, 440);
  doc.rect(0, 0, 720, 440, {{"fill", "#ffffff"}});
  chart.render(doc, 0, 0, 720, 440);
  writeFileAtomically(output, doc.str());
  if (as_json) {
    json j{{"kind", "ghosts"},
           {"lens", lens.prescription().path},
           {"total_relative_intensity", total},
           {"bars", ranks}};
    if (angle_deg) j["angle_deg"] = *angle_deg;
    std::cout << j.dump(2) << "\n";
  }
  logInfo(fmt::format("wrote {}", output));
  return 0;
}

void registerLensGhostsCommand(CLI::App& lens, Action& action) {
  auto* cmd = lens.add_subcommand(
      "ghosts", "Two-reflection ghosts of an axial point at infinity: intensity, focus, size");
  auto args = std::make_shared<LensArgs>();
  auto ga = std::make_shared<GhostArgs>();
  addLensOptions(cmd, *args);
  cmd->add_option("--wavelengths", ga->wavelengths,
                  "Wavelengths (nm, comma-separated) the intensities are averaged over; default "
                  "400..700 in 10 nm steps");
  cmd->add_option("--top", ga->top, "Show the N brightest ghosts only")->check(CLI::Range(1, 100000));
  cmd->add_option("--focus-tolerance", ga->focus_tolerance_mm,
                  "A ghost is in focus when its film diameter is below this (mm; default 0.05)");
  cmd->add_option("--coating", ga->coating,
                  "Lens-wide coating of the air-glass surfaces that name none (uncoated, single, "
                  "multi, or a name of the lens's coating file), instead of the file's");
  cmd->add_option("--angle", ga->angle_deg,
                  "Light angle off axis (deg, x-z plane): also trace each shown ghost's film "
                  "spot (centroid, size) with real rays");
  cmd->add_option("--grid", ga->grid,
                  "Rays across the entrance pupil for --angle's traced spots (default 64)");
  cmd->add_flag("--json", ga->as_json, "Print one JSON object");
  cmd->callback([&action, args, ga] {
    action = [args, ga] { return runGhosts(*args, *ga); };
  });
}

}  // namespace lensim::cmd
