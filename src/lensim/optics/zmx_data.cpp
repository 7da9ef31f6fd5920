// The Zemax reader's multi-configuration data, toroidal surfaces and coordinate breaks
// (zmx_parser.h).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "lensim/optics/coordinate_break.h"
#include "lensim/optics/zmx_parser.h"

namespace lensim::optics::zmx_detail {

// One line of multi-configuration data; returns false when the line is not one (it is then read
// as usual). Operands lensim does not model are refused at their line.
bool ZmxParser::readMultiConfig(const std::vector<Tok>& t, int line_no) {
  const std::string_view key = t[0].text;
  const FileLoc loc{path_, line_no, t[0].col};
  auto integer = [&](size_t i, const char* what) {
    const double v = number(t[i], line_no, what);
    if (v != std::floor(v) || std::abs(v) > 1e6)
      throw Error(FileLoc{path_, line_no, t[i].col},
                  fmt::format("expected an integer for the {}, found '{}'", what, t[i].text));
    return int(v);
  };
  if (key == "MNUM") {
    need(t, 2, line_no, "configuration count");
    const int n = integer(1, "number of configurations");
    if (n < 1 || n > 1000)
      throw Error(FileLoc{path_, line_no, t[1].col},
                  fmt::format("MNUM {}: expected 1 to 1000 configurations", n));
    mc_count_ = n;
    mc_loc_ = loc;
    if (t.size() >= 3) {
      mc_active_ = integer(2, "active configuration");
      if (mc_active_ < 1 || mc_active_ > n)
        throw Error(FileLoc{path_, line_no, t[2].col},
                    fmt::format("MNUM {} {}: the active configuration must be 1 to {}", n,
                                mc_active_, n));
    }
    return true;
  }
  if (!mc_count_ || key.size() != 4 || t.size() < 3) return false;
  for (char c : key)
    if (!(c >= 'A' && c <= 'Z') && !(c >= '0' && c <= '9')) return false;
  if (key == "MOFF") return true;  // an empty operand row
  static constexpr std::string_view kModelled[] = {"THIC", "CURV", "CONI", "GLSS", "APER",
                                                   "SDIA", "STPS", "WAVE", "XFIE", "YFIE"};
  if (std::find(std::begin(kModelled), std::end(kModelled), key) == std::end(kModelled))
    throw Error(loc, fmt::format("multi-configuration operand {} is not supported; lensim models "
                                 "THIC, CURV, CONI, GLSS, APER, SDIA, STPS, WAVE, XFIE and YFIE",
                                 key));
  need(t, 4, line_no, "operand");
  McRow r;
  r.op = std::string(key);
  r.arg = integer(1, "operand's surface or number");
  r.config = integer(2, "configuration number");
  if (r.config < 1 || r.config > *mc_count_)
    throw Error(FileLoc{path_, line_no, t[2].col},
                fmt::format("{}: configuration {} is not one of the {} configurations MNUM "
                            "declares",
                            key, r.config, *mc_count_));
  r.value = std::string(t[3].text);
  if (r.value.size() >= 2 && r.value.front() == '"' && r.value.back() == '"')
    r.value = r.value.substr(1, r.value.size() - 2);
  r.loc = loc;
  r.value_loc = FileLoc{path_, line_no, t[3].col};
  if (r.op != "GLSS") number(t[3], line_no, "operand value");  // checked now, used later
  mc_rows_.push_back(std::move(r));
  return true;
}

// Puts configuration apply_config_'s operand values over the surface and system data.
void ZmxParser::applyMultiConfig(std::vector<ZSurface>& surfs, std::optional<double>& enpd,
                                 std::optional<double>& fnum, bool floa,
                                 std::map<int, double>& wavm, std::vector<double>& xf,
                                 std::vector<double>& yf) const {
  if (!apply_config_) return;
  const int last_lens = int(surfs.size()) - 2;
  for (const McRow& r : mc_rows_) {
    if (r.config != *apply_config_) continue;
    const double v = r.op == "GLSS" ? 0.0 : std::strtod(r.value.c_str(), nullptr);
    auto surface = [&](int lo, int hi) -> ZSurface& {
      if (r.arg < lo || r.arg > hi)
        throw Error(r.loc, fmt::format("{} {}: expected a surface {} to {}", r.op, r.arg, lo, hi));
      return surfs[size_t(r.arg)];
    };
    if (r.op == "THIC") {
      ZSurface& z = surface(0, last_lens);
      z.has_disz = true;
      if (r.arg == 0 && std::abs(v) >= 1e10)
        z.disz.reset();  // OpticStudio writes 1e10 for an object at infinity
      else
        z.disz = v;
      z.disz_loc = r.value_loc;
    } else if (r.op == "CURV") {
      surface(1, last_lens).curv = v;
    } else if (r.op == "CONI") {
      surface(1, last_lens).conic = v;
    } else if (r.op == "SDIA") {
      ZSurface& z = surface(1, last_lens);
      z.diam = v, z.clap_max.reset();
      z.diam_loc = r.value_loc;
    } else if (r.op == "GLSS") {
      ZSurface& z = surface(1, last_lens);
      if (r.value == "MIRROR")
        throw Error(r.value_loc, "GLSS MIRROR: a configuration cannot turn a surface into a mirror");
      z.glass = r.value;
      z.glass_loc = r.value_loc;
      z.n_d.reset(), z.v_d.reset();
    } else if (r.op == "STPS") {
      const int n = int(v);
      if (double(n) != v || n < 1 || n > last_lens)
        throw Error(r.value_loc, fmt::format("STPS {}: expected a surface 1 to {}", r.value,
                                             last_lens));
      for (ZSurface& z : surfs) z.stop = false;
      surfs[size_t(n)].stop = true;
    } else if (r.op == "APER") {
      if (floa || (!enpd && !fnum))
        throw Error(r.loc, "APER: the file's system aperture is not ENPD or FNUM; lensim changes "
                           "those two per configuration");
      if (!(v > 0))
        throw Error(r.value_loc, fmt::format("APER {}: expected a value > 0", r.value));
      (enpd ? enpd : fnum) = v;
    } else if (r.op == "WAVE") {
      if (wavm.find(r.arg) == wavm.end())
        throw Error(r.loc, fmt::format("WAVE {}: the file has no wavelength {} (WAVM)", r.arg,
                                       r.arg));
      if (!(v > 0))
        throw Error(r.value_loc, fmt::format("WAVE {}: expected a wavelength > 0 um", r.value));
      wavm[r.arg] = v;
    } else if (r.op == "XFIE" || r.op == "YFIE") {
      // A field's x or y value (field number 1 .. FTYP's count), in the file's field type.
      const int count = fieldCount();
      if (r.arg < 1 || r.arg > count)
        throw Error(r.loc, count == 0 ? fmt::format("{} {}: the file lists no fields (FTYP with "
                                                    "XFLN/YFLN)",
                                                    r.op, r.arg)
                                      : fmt::format("{} {}: expected a field 1 to {} (FTYP)",
                                                    r.op, r.arg, count));
      std::vector<double>& f = r.op == "XFIE" ? xf : yf;
      if (f.size() < size_t(count)) f.resize(size_t(count), 0.0);
      f[size_t(r.arg - 1)] = v;
    }
  }
}

// TYPE TOROIDAL, as OpticStudio defines it (OpticStudio User Guide, "Toroidal"; see
// surface_shape.h): PARM 0 extrapolate (ignored: lensim continues every surface flat beyond its
// aperture), PARM 1 the radius of rotation R in lens units (0: infinite, a cylinder), PARM 2..8
// the y-curve terms alpha_1..alpha_7 on y^2, y^4, ..., y^14; PARM 13 the number of Zernike
// sag terms (PARM 14 their normalisation radius), whose coefficients are extra data (XDAT): not
// modelled, refused when present.
void ZmxParser::readToroidal(const ZSurface& z, double unit_mm, SurfaceShape& shape) const {
  shape.rotation_radius_mm = 0.0;
  for (const auto& [i, v] : z.parm) {
    if (i == 0 || i == 14) continue;  // extrapolate; the Zernike normalisation radius
    if (i == 1) {
      shape.rotation_radius_mm = v;
    } else if (i >= 2 && i <= 8) {
      if (v == 0) continue;
      const size_t power = size_t(2 * (i - 1));
      if (shape.poly.size() <= power) shape.poly.resize(power + 1, 0.0);
      shape.poly[power] = v;
    } else if (v != 0) {
      throw Error(parmLoc(z, i),
                  i == 13 ? fmt::format("surface {}: TOROIDAL PARM {} = {}: Zernike sag terms on a "
                                        "toroidal surface are not supported",
                                        z.number, i, v)
                          : fmt::format("surface {}: TOROIDAL PARM {} = {}: a toroidal surface has "
                                        "parameters 1 (radius of rotation) and 2-8 (y^2 .. y^14 "
                                        "terms) only",
                                        z.number, i, v));
    }
  }
  if (z.xdat_loc)
    throw Error(*z.xdat_loc, fmt::format("surface {}: TOROIDAL extra data (XDAT, Zernike sag "
                                         "terms) is not supported",
                                         z.number));
  shape.scaleLengths(unit_mm);
}

// A diffraction grating (OpticStudio's "Diffraction Grating" surface, a standard sphere or conic
// ruled with lines parallel to its local x axis): PARM 1 the line density in lines per
// micrometre (whatever the lens units), PARM 2 the diffraction order.
SurfaceGrating ZmxParser::readGrating(const ZSurface& z) const {
  SurfaceGrating g;
  g.loc = z.type_loc.valid() ? z.type_loc : z.loc;
  for (const auto& [i, v] : z.parm) {
    if (i == 1) {
      g.lines_per_um = v;
    } else if (i == 2) {
      if (v != std::floor(v) || std::abs(v) > 1e6)
        throw Error(parmLoc(z, i), fmt::format("surface {}: DGRATING PARM 2 = {}: the "
                                               "diffraction order must be an integer",
                                               z.number, v));
      g.order = int(v);
    } else if (v != 0) {
      throw Error(parmLoc(z, i), fmt::format("surface {}: DGRATING PARM {} = {}: a diffraction "
                                             "grating has parameters 1 (lines per micrometre) "
                                             "and 2 (diffraction order) only",
                                             z.number, i, v));
    }
  }
  return g;
}

// Coordinate breaks (optics/coordinate_break.h): a fold by plane mirrors becomes its coaxial twin
// (the breaks dropped, thicknesses along the unfolded axis, a tilted mirror's circular aperture
// its projection, an ellipse); anything else is refused at its break.
void ZmxParser::resolveCoordinateBreaks(std::vector<ZSurface>& surfs, LensPrescription& p) const {
  std::vector<FoldSurface> fold(surfs.size());
  for (size_t k = 0; k < surfs.size(); ++k) {
    const ZSurface& z = surfs[k];
    FoldSurface& f = fold[k];
    f.number = z.number, f.loc = z.loc, f.coordbrk = z.type == "COORDBRK", f.mirror = z.mirror;
    f.thickness = z.disz ? *z.disz : std::numeric_limits<double>::infinity();
    bool parms_zero = true;
    for (const auto& [i, v] : z.parm) parms_zero = parms_zero && v == 0;
    f.plane = z.curv == 0 && parms_zero && !z.xdat_loc && z.type != "TOROIDAL";
    f.symmetric = z.type != "TOROIDAL" && z.type != "DGRATING" &&
                  z.aperture_shape == ApertureShape::Circle;
    if (z.obdc_loc.valid() && k > 0 && k + 1 < surfs.size()) {
      if (!z.clap_max)
        throw Error(z.obdc_loc, fmt::format("surface {}: OBDC decentres the surface's aperture "
                                            "(CLAP, SQAP or ELAP), and it has none; a decentred "
                                            "DIAM or obscuration alone is not modelled",
                                            z.number));
      f.decentred_aperture_loc = z.obdc_loc;
      f.symmetric = false;
    }
    if (!f.coordbrk) continue;
    if (!z.has_disz)
      throw Error(z.loc, fmt::format("surface {}: no DISZ (thickness) line", z.number));
    if (!z.disz)
      throw Error(z.disz_loc, fmt::format("surface {}: a coordinate break's thickness must be "
                                          "finite",
                                          z.number));
    for (const auto& [i, v] : z.parm) {
      if (i >= 1 && i <= 6) {
        f.parm[size_t(i - 1)] = v;
        f.parm_loc[size_t(i - 1)] = parmLoc(z, i);
      } else if (v != 0) {
        throw Error(parmLoc(z, i), fmt::format("surface {}: COORDBRK PARM {} = {}: a coordinate "
                                               "break has parameters 1 to 6",
                                               z.number, i, v));
      }
    }
    if (z.stop)
      throw Error(z.type_loc, fmt::format("surface {}: TYPE COORDBRK on the stop: a coordinate "
                                          "break cannot be the stop; put STOP on a real surface",
                                          z.number));
    if (z.mirror || !z.glass.empty())
      throw Error(z.glass_loc, fmt::format("surface {}: a coordinate break has no glass (GLAS "
                                           "{})",
                                           z.number, z.mirror ? "MIRROR" : z.glass));
  }
  for (const ZSurface* z : {&surfs.front(), &surfs.back()})
    if (z->type == "DGRATING")
      throw Error(z->type_loc, fmt::format("surface {}: a diffraction grating as the {} surface "
                                           "is not supported",
                                           z->number, z == &surfs.front() ? "object" : "image"));
  PlacedSystem placed = placeCoordinateBreaks(fold);
  // A grating breaks rotational symmetry: the lens is placed in space like a tilted one (its
  // surfaces on their axis, folds by mirrors kept as they are in space).
  const auto grating = std::find_if(surfs.begin(), surfs.end(),
                                    [](const ZSurface& z) { return z.type == "DGRATING"; });
  if (grating != surfs.end() && placed.coaxial) {
    placed.coaxial = false;
    placed.frames = placeSurfaces(fold);
    placed.refusal = Error(grating->type_loc.valid() ? grating->type_loc : grating->loc,
                           fmt::format("surface {} is a diffraction grating (TYPE DGRATING), "
                                       "which is not rotationally symmetric",
                                       grating->number));
  }
  if (!placed.coaxial) {
    // No single axis holds the surfaces: each keeps its frame in space (the breaks dropped).
    p.noncoaxial_loc = placed.refusal->loc();
    p.noncoaxial_reason = placed.refusal->message();
    std::vector<ZSurface> kept;
    for (size_t k = 0; k < surfs.size(); ++k) {
      if (fold[k].coordbrk) continue;
      kept.push_back(surfs[k]);
      kept.back().frame = placed.frames[k];
    }
    p.diagnostics.push_back(
        {Severity::Note, *p.noncoaxial_loc,
         grating != surfs.end()
             ? fmt::format("{}: each surface is placed in space; `lens info` traces real rays "
                           "through it, the coaxial analyses and the cameras refuse the lens",
                           p.noncoaxial_reason)
             : fmt::format("tilted or decentred surfaces ({}): each surface is placed in space; "
                           "`lens info` and the realistic camera trace real rays through them, "
                           "the coaxial analyses refuse the lens",
                           p.noncoaxial_reason)});
    surfs = std::move(kept);
    return;
  }
  const UnfoldedSystem& u = placed.unfolded;
  if (!u.any_break) return;
  p.fold_loc = fold[size_t(std::find_if(fold.begin(), fold.end(),
                                        [](const FoldSurface& f) { return f.coordbrk; }) -
                          fold.begin())]
                   .loc;
  std::vector<ZSurface> twin;
  for (size_t k = 0; k < u.kept.size(); ++k) {
    ZSurface z = surfs[u.kept[k]];
    if (k > 0 && k + 1 < u.kept.size()) z.disz = u.thickness[k];
    twin.push_back(std::move(z));
  }
  for (const FoldMirrorAperture& m : u.tilted_mirrors) {
    ZSurface& z = twin[m.index];
    const double r = z.clap_max ? *z.clap_max : z.diam.value_or(0);
    if (!(r > 0)) continue;  // automatic semi-diameter: computed on the twin
    z.aperture_shape = ApertureShape::Ellipse;
    z.half_x = r * m.scale_x, z.half_y = r * m.scale_y;
    z.clap_max = r;
    p.diagnostics.push_back(
        {Severity::Note, z.loc,
         fmt::format("surface {}: a tilted fold mirror; its semi-diameter {} is clipped as its "
                     "projection along the axis, an ellipse {} x {} (exact for rays parallel to "
                     "the axis)",
                     z.number, r, z.half_x, z.half_y)});
  }
  p.diagnostics.push_back(
      {Severity::Note, *p.fold_loc,
       fmt::format("coordinate breaks fold the axis with plane mirrors: traced as the coaxial "
                   "twin ({} surfaces, breaks removed)",
                   twin.size())});
  surfs = std::move(twin);
}

// A line of the current surface's aperture, obscuration or own decentre/tilt data; false when
// the line is none of these.
bool ZmxParser::apertureLine(const Line& l) {
  const std::vector<Tok>& t = l.t;
  const std::string_view key = t[0].text;
  const int line_no = l.line_no;
  const FileLoc& loc = l.loc;
  auto num = [&](size_t i, const char* what) { return lineNumber(l, i, what); };
  auto surfErr = [&](const std::string& msg) { return surfaceError(l, msg); };
  if (key == "CLAP" || key == "OBSC") {
    // Circular aperture `CLAP rmin rmax` (clear between the radii) and circular obscuration
    // `OBSC rmin rmax` (blocked between them), as Zemax writes them (the samples: `CLAP 0
    // 25.4 0`, `OBSC 0 25 0`). An annular clear aperture and a central obscuration (rmin 0)
    // both block the centre; an obscuring ring (OBSC rmin > 0) is not modelled.
    const double rmin = num(1, "aperture minimum radius");
    const double rmax = num(2, "aperture maximum radius");
    const FileLoc vloc{path_, line_no, t[1].col};
    if (!(rmin >= 0) || !(rmax > rmin))
      throw Error(vloc, fmt::format("surface {}: {} radii {} .. {}: expected 0 <= minimum < "
                                    "maximum",
                                    cur->number, key, rmin, rmax));
    if (key == "CLAP") {
      if (cur->aperture_shape != ApertureShape::Circle)
        throw surfErr("CLAP: the surface already has an aperture (one per surface)");
      cur->clap_max = rmax;
      if (rmin > 0) cur->inner_radius = rmin, cur->inner_loc = vloc;
    } else {
      if (rmin != 0)
        throw Error(vloc, fmt::format("surface {}: OBSC {} {}: an obscuring ring (minimum "
                                      "radius > 0) is not supported; a central obscuration "
                                      "(OBSC 0 r) is",
                                      cur->number, rmin, rmax));
      cur->inner_radius = rmax, cur->inner_loc = FileLoc{path_, line_no, t[2].col};
    }
  } else if (key == "OBDC") {
    // Aperture / obscuration decentre `OBDC x y` (lens units, in the surface's own x and y): the
    // surface's aperture and obscuration are centred at (x, y), as on an off-axis parabolic
    // mirror (zmax_37992.zmx: CLAP 25.4 decentred 190.6 mm in y). Such a surface is not
    // rotationally symmetric about the axis: the lens is placed in space (non-coaxial).
    need(t, 3, line_no, "aperture decentre");
    const double x = num(1, "aperture x decentre"), y = num(2, "aperture y decentre");
    for (size_t i = 3; i < t.size(); ++i)
      if (number(t[i], line_no, "aperture decentre") != 0)
        throw Error(FileLoc{path_, line_no, t[i].col},
                    fmt::format("surface {}: OBDC: value {} is {}; only the decentres x and y "
                                "are read",
                                cur->number, i, t[i].text));
    cur->obdc_x = x, cur->obdc_y = y;
    if (x != 0 || y != 0) cur->obdc_loc = FileLoc{path_, line_no, t[x != 0 ? 1 : 2].col};
  } else if (key == "SQAP" || key == "ELAP") {
    // Rectangular `SQAP hx hy` and elliptical `ELAP hx hy` apertures, centred (their decentre
    // is the OBDC line): the half-widths in x and y, as OpticStudio writes them (Thorlabs'
    // 4 mm x 6 mm cylindrical lens LJ1598L1: `SQAP 3.0 2 0`). Further values are refused
    // unless 0.
    const double hx = num(1, "aperture x half-width");
    const double hy = num(2, "aperture y half-width");
    if (!(hx > 0) || !(hy > 0) || !std::isfinite(hx) || !std::isfinite(hy))
      throw Error(FileLoc{path_, line_no, t[!(hx > 0) || !std::isfinite(hx) ? 1 : 2].col},
                  fmt::format("surface {}: {} half-widths {} {}: expected two finite values "
                              "> 0",
                              cur->number, key, hx, hy));
    for (size_t i = 3; i < t.size(); ++i)
      if (number(t[i], line_no, "aperture data") != 0)
        throw Error(FileLoc{path_, line_no, t[i].col},
                    fmt::format("surface {}: {}: value {} is {}; only centred apertures "
                                "(hx hy 0) are supported",
                                cur->number, key, i, t[i].text));
    if (cur->clap_max)
      throw surfErr(fmt::format("{}: the surface already has an aperture (one per surface)",
                                key));
    cur->aperture_shape = key == "SQAP" ? ApertureShape::Rectangle : ApertureShape::Ellipse;
    cur->half_x = hx, cur->half_y = hy;
    cur->clap_max = key == "SQAP" ? std::hypot(hx, hy) : std::max(hx, hy);
    cur->aperture_loc = FileLoc{path_, line_no, t[0].col};
  } else if (key == "SQOB" || key == "ELOB" || key == "UDAP" || key == "UDOB") {
    throw surfErr(
        fmt::format("{} (a surface aperture or obscuration other than circular) is "
                    "not supported",
                    key));
  } else if (key == "SCBD") {
    // The surface's own decentre and tilt before it, as OpticStudio writes it
    // (zmax_37992.zmx's image surface: `SCBD 1 0 0 0 0 90 0 0`): three flags, then decentre x,
    // y and tilt about x, y, z, the five values of a coordinate break (PARM 1 .. 5). The flags'
    // meaning (among them the order of decentres and tilts) is not documented where it could be
    // checked, so only lines on which the order cannot matter are read: flags 2 and 3 zero and
    // at most one motion (a decentre, or a tilt about one axis).
    if (t.size() < 9) {
      for (size_t i = 2; i < t.size(); ++i)
        if (number(t[i], line_no, "decentre/tilt") != 0)
          throw Error(FileLoc{path_, line_no, t[i].col},
                      fmt::format("surface {}: SCBD with {} values: expected 8 (three flags, "
                                  "decentre x, y, tilt x, y, z)",
                                  cur->number, t.size() - 1));
      return true;
    }
    std::array<double, 5> v{};
    bool any = false;
    for (size_t i = 2; i < t.size(); ++i) {
      const double x = number(t[i], line_no, "decentre/tilt");
      if (i <= 3 && x != 0)
        throw Error(FileLoc{path_, line_no, t[i].col},
                    fmt::format("surface {}: SCBD flag {} is {}; only 0 is read (its meaning "
                                "is not documented where it could be checked)",
                                cur->number, i, t[i].text));
      if (i >= 9 && x != 0)
        throw Error(FileLoc{path_, line_no, t[i].col},
                    fmt::format("surface {}: SCBD value {} is {}; expected 8 values", cur->number,
                                i, t[i].text));
      if (i >= 4 && i <= 8) {
        v[i - 4] = x;
        cur->scbd_loc[i - 4] = FileLoc{path_, line_no, t[i].col};
        any = any || x != 0;
      }
    }
    if (!any) return true;
    const int motions = (v[0] != 0 || v[1] != 0) + (v[2] != 0) + (v[3] != 0) + (v[4] != 0);
    if (motions > 1)
      throw surfErr("SCBD: a decentre and tilts, or tilts about more than one axis, on one "
                    "line; their order is a flag whose place on the line is not documented "
                    "where it could be checked (a TYPE COORDBRK surface before it is read)");
    cur->scbd = v;
    cur->scbd_line = loc;
  } else if (key == "SCAD" || key == "DECX" || key == "DECY" || key == "TILT") {
    // A surface's own decentres and tilts after it, and the older forms: refused unless all
    // zero; their field layout is not documented where it could be checked (COORDBRK surfaces
    // are read).
    for (size_t i = 2; i < t.size(); ++i)
      if (number(t[i], line_no, "decentre/tilt") != 0)
        throw surfErr(fmt::format("{}: a surface's own decentre or tilt is not supported (a "
                                  "TYPE COORDBRK surface before it is)",
                                  key));
  } else {
    return false;
  }
  return true;
}

// A surface's own decentre or tilt (SCBD) is read on the image surface, where nothing follows
// it (whether the frame is restored after the surface does not matter there): a coordinate
// break just before it.
void ZmxParser::readSurfaceTilt() {
  for (size_t k = 0; k < surfs.size(); ++k) {
    if (!surfs[k].scbd) continue;
    if (k + 1 != surfs.size())
      throw Error(surfs[k].scbd_line,
                  fmt::format("surface {}: SCBD (the surface's own decentre or tilt) is read on "
                              "the image surface only; put a TYPE COORDBRK surface before this "
                              "one",
                              surfs[k].number));
    ZSurface cb;
    cb.number = surfs[k].number;
    cb.loc = cb.type_loc = surfs[k].scbd_line;
    cb.type = "COORDBRK";
    cb.has_disz = true;
    cb.disz = 0.0;
    for (int i = 0; i < 5; ++i) {
      cb.parm[i + 1] = (*surfs[k].scbd)[size_t(i)];
      cb.parm_loc[i + 1] = surfs[k].scbd_loc[size_t(i)];
    }
    surfs.insert(surfs.begin() + std::ptrdiff_t(k), std::move(cb));
    break;
  }
}

}  // namespace lensim::optics::zmx_detail
