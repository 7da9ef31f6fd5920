// `lensim lens plot ghosts --image` (issue 31): the film image of a distant point light, the
// direct image and every two-reflection ghost, from the rays `lens ghosts --angle` traces.
//
// Each path (the lens itself, then each ghost pair) is traced with traceSpot's grid
// (forEachPathRay); every ray that reaches the film plane carries its coatings' R and T product
// per wavelength, and is splatted bilinearly (a tent over the four nearest pixel centres, which
// keeps the energy and the centroid of the rays exactly) onto a raster covering the film.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "flare_report.h"
#include "lens_options.h"
#include "lensim/io/image.h"
#include "lensim/optics/coating/ghost_trace.h"
#include "lensim/optics/coating/ghosts.h"
#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

using json = nlohmann::json;
using namespace lensim::optics;

namespace {

/// BT.709 luminance of linear sRGB.
double luminance(const double* rgb) {
  return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

/// Linear sRGB (BT.709 primaries) of a ray's spectrum sampled at the wavelengths: CIE 1931 XYZ
/// as the sum of weight x colour matching function, then the renderer's XYZ -> linear sRGB
/// matrix, divided channel by channel by the same of a weight of 1 at every wavelength, so an
/// equal-energy white light that loses nothing is (1, 1, 1).
class RayColour {
 public:
  explicit RayColour(const std::vector<double>& wl) {
    for (double l : wl) cmf_.push_back(render::cieXyzBar(l));
    std::vector<double> ones(wl.size(), 1.0);
    const Vec3 w = raw(ones);
    for (int c = 0; c < 3; ++c) {
      if (!(std::abs(w[c]) > 1e-9))
        throw Error(fmt::format(
            "--wavelengths: an equal-energy light at these wavelengths has no {} (choose "
            "wavelengths within 380..780 nm)",
            "RGB"[c]));
      white_[c] = w[c];
    }
  }
  void operator()(std::span<const double> f, double* rgb) const {
    const Vec3 v = raw(f);
    for (int c = 0; c < 3; ++c) rgb[c] = v[c] / white_[c];
  }

 private:
  Vec3 raw(std::span<const double> f) const {
    Vec3 xyz{0, 0, 0};
    for (size_t i = 0; i < f.size(); ++i) xyz = xyz + cmf_[i] * f[i];
    return render::RGBColorSpace::sRGB().toRgb(xyz);
  }
  std::vector<Vec3> cmf_;
  double white_[3] = {1, 1, 1};
};

/// A film-sized RGB raster accumulated in double: pixel (i, j) covers film x from
/// -width/2 + i px to + px, and film y from height/2 - j px down (rows top to bottom, y up).
struct Raster {
  int w = 0, h = 0;
  double px_mm = 0, width_mm = 0, height_mm = 0;
  std::vector<double> rgb;  // w * h * 3
  /// Adds `value` (RGB) at film point (x, y) with bilinear weights on the pixel centres; returns
  /// the fraction of it that landed on the raster.
  double splat(double x, double y, const double* value) {
    const double u = (x + 0.5 * width_mm) / px_mm - 0.5, v = (0.5 * height_mm - y) / px_mm - 0.5;
    if (!(u > -1 && v > -1 && u < w && v < h)) return 0;
    const int i0 = int(std::floor(u)), j0 = int(std::floor(v));
    const double fu = u - i0, fv = v - j0;
    double landed = 0;
    for (int dj = 0; dj < 2; ++dj)
      for (int di = 0; di < 2; ++di) {
        const int i = i0 + di, j = j0 + dj;
        if (i < 0 || j < 0 || i >= w || j >= h) continue;
        const double k = (di ? fu : 1 - fu) * (dj ? fv : 1 - fv);
        double* p = &rgb[(size_t(j) * size_t(w) + size_t(i)) * 3];
        for (int c = 0; c < 3; ++c) p[c] += k * value[c];
        landed += k;
      }
    return landed;
  }
};

/// One traced path's light: per wavelength, and its luminance total and the part on the raster.
struct PathLight {
  int first = -1, second = -1;
  int rays = 0;
  std::vector<double> energy;  // per wavelength, as tracedPathEnergy sums it
  double luminance = 0, luminance_on_raster = 0;
};

PathLight tracePath(const LensSystem& lens, const LensCoatings& coatings, int first, int second,
                    double angle_rad, int grid, const std::vector<double>& wl,
                    const RayColour& colour, double scale, Raster& raster) {
  PathLight p;
  p.first = first, p.second = second;
  p.energy.assign(wl.size(), 0.0);
  forEachPathRay(lens, coatings, first, second, angle_rad, grid, wl, lens.filmZ_mm(),
                 [&](const PathRay& r) {
                   ++p.rays;
                   for (size_t w = 0; w < wl.size(); ++w) p.energy[w] += r.weight[w];
                   double rgb[3];
                   colour(r.weight, rgb);
                   for (double& c : rgb) c *= scale;
                   const double y = luminance(rgb);
                   p.luminance += y;
                   p.luminance_on_raster += y * raster.splat(r.film_x_mm, r.film_y_mm, rgb);
                 });
  return p;
}

void checkArgs(const GhostImageArgs& ga) {
  if (ga.size < 16 || ga.size > 2048)
    throw Error(fmt::format("--size {}: expected 16 to 2048 pixels across", ga.size));
  if (ga.grid < 2 || ga.grid > 2000)
    throw Error(fmt::format("--grid {}: expected 2 to 2000 rays across", ga.grid));
  if (!(std::abs(ga.angle_deg) < 89))
    throw Error(
        fmt::format("--angle {}: expected a light angle within -89..89 degrees", ga.angle_deg));
  if (!(ga.decades > 0 && ga.decades <= 20))
    throw Error(fmt::format("--decades {}: expected more than 0 and at most 20", ga.decades));
  // imageFormatFromPath refuses an extension lensim does not write.
  const bool exr_out = io::imageFormatFromPath(ga.output) == io::ImageFormat::Exr;
  if (!ga.exr.empty()) {
    if (exr_out)
      throw Error(fmt::format("--exr {}: -o {} is already the unscaled EXR", ga.exr, ga.output));
    if (io::imageFormatFromPath(ga.exr) != io::ImageFormat::Exr)
      throw Error(fmt::format("--exr {}: expected a .exr file", ga.exr));
  }
  for (const std::string& out : {ga.output, ga.exr}) {
    if (out.empty()) continue;
    const std::filesystem::path dir = std::filesystem::absolute(out).parent_path();
    if (!std::filesystem::is_directory(dir))
      throw Error(fmt::format("{}: the directory {} does not exist", out, dir.string()));
  }
}

/// The unscaled layers: R,G,B the sum, direct.* and ghost.* the parts.
io::Image exrImage(const Raster& direct, const Raster& ghost) {
  io::Image img(
      direct.w, direct.h,
      {"R", "G", "B", "direct.R", "direct.G", "direct.B", "ghost.R", "ghost.G", "ghost.B"});
  for (int j = 0; j < direct.h; ++j)
    for (int i = 0; i < direct.w; ++i) {
      const size_t k = (size_t(j) * size_t(direct.w) + size_t(i)) * 3;
      for (int c = 0; c < 3; ++c) {
        img.at(i, j, c) = float(direct.rgb[k + size_t(c)] + ghost.rgb[k + size_t(c)]);
        img.at(i, j, 3 + c) = float(direct.rgb[k + size_t(c)]);
        img.at(i, j, 6 + c) = float(ghost.rgb[k + size_t(c)]);
      }
    }
  img.metadata["lensim:units"] =
      "light per pixel over the direct image's luminance (all its rays, on the film or not)";
  img.metadata["lensim:colour"] =
      "linear sRGB (BT.709) from CIE 1931 XYZ at the traced wavelengths, equal-energy white = 1";
  return img;
}

/// The display image: the sum's luminance mapped logarithmically over `decades` below the
/// brightest pixel to 0..1, the pixel's colour kept (negative channels, out of gamut, as 0).
io::Image toneMapped(const Raster& direct, const Raster& ghost, double decades) {
  const size_t n = size_t(direct.w) * size_t(direct.h);
  std::vector<double> sum(n * 3);
  double y_max = 0;
  for (size_t k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c)
      sum[k * 3 + size_t(c)] =
          std::max(0.0, direct.rgb[k * 3 + size_t(c)] + ghost.rgb[k * 3 + size_t(c)]);
    y_max = std::max(y_max, luminance(&sum[k * 3]));
  }
  io::Image img(direct.w, direct.h, {"R", "G", "B"});
  for (size_t k = 0; k < n; ++k) {
    const double y = luminance(&sum[k * 3]);
    if (!(y > 0) || !(y_max > 0)) continue;
    const double m = std::clamp((std::log10(y / y_max) + decades) / decades, 0.0, 1.0);
    for (int c = 0; c < 3; ++c)
      img.pixels[k * 3 + size_t(c)] = float(std::min(1.0, sum[k * 3 + size_t(c)] * m / y));
  }
  return img;
}

json pathJson(const PathLight& p, const std::vector<double>& direct_energy) {
  json j{{"rays_arrived", p.rays},
         {"luminance", p.luminance},
         {"luminance_on_raster", p.luminance_on_raster}};
  if (p.first >= 0) {
    std::vector<double> rel(p.energy.size(), 0.0);
    double mean = 0;
    for (size_t w = 0; w < rel.size(); ++w) {
      rel[w] = direct_energy[w] > 0 ? p.energy[w] / direct_energy[w] : 0.0;
      mean += rel[w] / double(rel.size());
    }
    j["first_reflection_surface"] = p.first;
    j["second_reflection_surface"] = p.second;
    j["relative_intensity_per_wavelength"] = rel;
    j["relative_intensity"] = mean;
  } else {
    j["energy_per_wavelength"] = p.energy;
  }
  return j;
}

}  // namespace

int runGhostImage(const LensArgs& args, const GhostImageArgs& ga) {
  checkArgs(ga);
  const std::vector<double> wl = ga.wavelengths.empty()
                                     ? std::vector<double>{450, 550, 650}
                                     : parseWavelengthList(ga.wavelengths, "--wavelengths");
  const RayColour colour(wl);
  std::optional<std::pair<int, int>> only;
  if (!ga.ghost.empty()) only = parseGhostPair(ga.ghost);
  FocusedLens fl = setUpLens(args);
  logDiagnostics(fl.allDiagnostics());
  const LensSystem& lens = *fl.lens;
  LensPrescription pr_coated = lens.prescription();
  if (!ga.coating.empty()) {
    pr_coated.default_coating = ga.coating;
    pr_coated.default_coating_loc = FileLoc{};  // named on the command line
  }
  const LensCoatings coatings = resolveCoatings(pr_coated);
  if (only) ghostPathInterfaces(lens, only->first, only->second);  // refuses a bad pair
  const double angle = ga.angle_deg * std::numbers::pi / 180;

  // The film: 3:2 with the given diagonal, square pixels.
  Raster direct;
  direct.w = ga.size;
  direct.h = std::max(1, int(std::lround(ga.size * 2.0 / 3.0)));
  direct.width_mm = args.film_diagonal_mm * 3 / std::sqrt(13.0);
  direct.px_mm = direct.width_mm / direct.w;
  direct.height_mm = direct.px_mm * direct.h;
  direct.rgb.assign(size_t(direct.w) * size_t(direct.h) * 3, 0.0);
  Raster ghost = direct;

  // The direct path first, at unit scale, to find the normalisation (its luminance), then the
  // raster rescaled to it.
  PathLight d = tracePath(lens, coatings, -1, -1, angle, ga.grid, wl, colour, 1.0, direct);
  if (!(d.luminance > 0))
    throw Error(fmt::format("{}: no ray of the direct image reaches the film at {} deg",
                            lens.prescription().path, ga.angle_deg));
  const double scale = 1 / d.luminance;
  for (double& v : direct.rgb) v *= scale;
  d.luminance_on_raster *= scale;
  d.luminance = 1;

  std::vector<PathLight> ghosts;
  const GhostAnalysis g = analyseGhosts(lens, coatings, wl);
  const auto& s = lens.interfaces();
  for (const Ghost& h : g.ghosts) {
    if (only && (h.b != only->first || h.a != only->second)) continue;
    if (s[size_t(h.a)].ior_before == s[size_t(h.a)].ior_after ||
        s[size_t(h.b)].ior_before == s[size_t(h.b)].ior_after)
      continue;  // the stop or a dummy surface: reflects nothing
    ghosts.push_back(tracePath(lens, coatings, h.b, h.a, angle, ga.grid, wl, colour, scale, ghost));
  }

  double total_rel = 0, ghost_y = 0, ghost_y_raster = 0;
  json arr = json::array();
  for (const PathLight& p : ghosts) {
    arr.push_back(pathJson(p, d.energy));
    total_rel += arr.back()["relative_intensity"].get<double>();
    ghost_y += p.luminance;
    ghost_y_raster += p.luminance_on_raster;
  }

  const bool exr_out = io::imageFormatFromPath(ga.output) == io::ImageFormat::Exr;
  if (exr_out) {
    io::writeImage(ga.output, exrImage(direct, ghost));
  } else {
    if (!ga.exr.empty()) io::writeImage(ga.exr, exrImage(direct, ghost));
    io::writeImage(ga.output, toneMapped(direct, ghost, ga.decades));
  }
  if (ga.as_json) {
    json j{{"kind", "ghost-image"},
           {"lens", lens.prescription().path},
           {"angle_deg", ga.angle_deg},
           {"grid", ga.grid},
           {"wavelengths_nm", wl},
           {"size_px", {direct.w, direct.h}},
           {"film_mm", {direct.width_mm, direct.height_mm}},
           {"pixel_mm", direct.px_mm},
           {"film_z_mm", lens.filmZ_mm()},
           {"direct", pathJson(d, d.energy)},
           {"ghosts", arr},
           {"total_relative_intensity", total_rel},
           {"ghost_luminance", ghost_y},
           {"ghost_luminance_on_raster", ghost_y_raster}};
    std::cout << j.dump(2) << "\n";
  }
  logInfo(fmt::format(
      "wrote {}{} ({} ghost{}; ghosts {:.3e} of the direct image's luminance, {:.3e} on the film)",
      ga.output, ga.exr.empty() ? "" : " and " + ga.exr, ghosts.size(),
      ghosts.size() == 1 ? "" : "s", ghost_y, ghost_y_raster));
  return 0;
}

}  // namespace lensim::cmd
