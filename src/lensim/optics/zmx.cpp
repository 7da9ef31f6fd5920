// Zemax `.zmx` reader (sequential mode).
//
// A .zmx file is a list of keyword lines: system data first (UNIT, ENPD, WAVM, ...), then one
// block per surface starting with `SURF n` (0 = object, last = image). Written from the file
// format as Zemax writes it (see the samples in ../shared/lenses/zmx and their sources); no
// library reads it, so this is hand-written.
#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>

#include "lensim/optics/auto_semi_diameter.h"
#include "lensim/optics/coating/lens_coatings.h"
#include "lensim/optics/coordinate_break.h"
#include "lensim/optics/glass.h"
#include "lensim/optics/glass/library.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/zmx_parser.h"

namespace lensim::optics {

namespace zmx_detail {

LensPrescription ZmxParser::parse(std::string_view bytes) {
  const std::string text = decodeTextFile(bytes, path_);
  LensPrescription p;
  p.path = path_;
  p.format = "zmx";
  p.name = std::filesystem::path(path_).stem().string();

  int line_no = 0;
  size_t pos = 0;
  int last_line = 1;
  while (pos <= text.size()) {
    size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string::npos) end = text.size();
    std::string_view line(text.data() + pos, end - pos);
    ++line_no;
    pos = (end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n') ? end + 2 : end + 1;
    if (end == text.size() && line.empty()) break;
    last_line = line_no;
    const std::vector<Tok> t = splitFields(line);
    if (t.empty()) continue;
    const std::string_view key = t[0].text;
    const FileLoc loc{path_, line_no, t[0].col};
    if ((key == "MNUM" || mc_count_) && readMultiConfig(t, line_no)) continue;
    const Line l{t, line, line_no, loc};
    if (key == "SURF") {
      const int n = lineInt(l, 1, "surface number");
      if (n != int(surfs.size()))
        throw Error(loc, fmt::format("surfaces out of order: SURF {} where SURF {} was expected", n,
                                     surfs.size()));
      surfs.push_back({});
      cur = &surfs.back();
      cur->number = n;
      cur->loc = loc;
      continue;
    }
    if (!cur)
      systemLine(p, l);
    else
      surfaceLine(l);
  }
  finishSystemData(p, last_line);
  buildSurfaces(p);
  sizeStop(p);
  computeMissingSemiDiameters(p);
  readCoatingFile(p);
  return p;
}

// A line of system data (before the first SURF).
void ZmxParser::systemLine(LensPrescription& p, const Line& l) {
  const std::vector<Tok>& t = l.t;
  const std::string_view line = l.text, key = t[0].text;
  const int line_no = l.line_no;
  const FileLoc& loc = l.loc;
  auto num = [&](size_t i, const char* what) { return lineNumber(l, i, what); };
  auto inum = [&](size_t i, const char* what) { return lineInt(l, i, what); };
  // System data.
  if (key == "MODE") {
    need(t, 2, line_no, "mode");
    if (t[1].text != "SEQ")
      throw Error(FileLoc{path_, line_no, t[1].col},
                  fmt::format("MODE {} is not supported: lensim reads sequential (MODE SEQ) "
                              "files only",
                              t[1].text));
    sequential_seen = true;
  } else if (key == "UNIT") {
    need(t, 2, line_no, "unit");
    const std::string_view u = t[1].text;
    if (u == "MM")
      unit_mm = 1;
    else if (u == "CM")
      unit_mm = 10;
    else if (u == "IN")
      unit_mm = 25.4;
    else if (u == "M" || u == "METER" || u == "METERS")
      unit_mm = 1000;
    else
      throw Error(FileLoc{path_, line_no, t[1].col},
                  fmt::format("unknown lens unit '{}'; expected MM, CM, IN or M", u));
  } else if (key == "COFN") {
    // The coating file: the first name ending in .DAT ("COFN [QF] "COATING.DAT" ...").
    for (size_t i = 1; i < t.size(); ++i) {
      std::string_view f = t[i].text;
      if (f.size() >= 2 && f.front() == '"' && f.back() == '"') f = f.substr(1, f.size() - 2);
      if (f.size() > 4 && (f.substr(f.size() - 4) == ".DAT" || f.substr(f.size() - 4) == ".dat")) {
        cofn = std::string(f);
        cofn_loc = FileLoc{path_, line_no, t[i].col};
        break;
      }
    }
  } else if (key == "GCAT") {
    // The glass catalogues the GLAS names come from, in the order they are searched.
    for (size_t i = 1; i < t.size(); ++i) {
      std::string c(t[i].text);
      for (char& ch : c) ch = char(std::tolower(static_cast<unsigned char>(ch)));
      if (!glassLibrary().hasCatalog(c))
        p.diagnostics.push_back(
            {Severity::Warning, FileLoc{path_, line_no, t[i].col},
             fmt::format("GCAT: lensim has no glass catalogue '{}' (--glass-catalog FILE "
                         "adds one); its glasses are looked up in the others",
                         t[i].text)});
      gcat.push_back(std::move(c));
    }
  } else if (key == "NAME") {
    const size_t s = line.find("NAME") + 4;
    std::string name(line.substr(std::min(s, line.size())));
    while (!name.empty() && (name.front() == ' ' || name.front() == '\t')) name.erase(0, 1);
    while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.pop_back();
    if (!name.empty()) p.name = name;
  } else if (key == "ENPD") {
    enpd = num(1, "entrance pupil diameter");
    aperture_loc = loc;
    if (!(*enpd > 0))
      throw Error(FileLoc{path_, line_no, t[1].col},
                  fmt::format("entrance pupil diameter {} must be > 0", *enpd));
  } else if (key == "FNUM") {
    fnum = num(1, "f-number");
    aperture_loc = loc;
    if (!(*fnum > 0))
      throw Error(FileLoc{path_, line_no, t[1].col},
                  fmt::format("f-number {} must be > 0", *fnum));
  } else if (key == "FLOA") {
    floa = true;
    aperture_loc = loc;
  } else if (key == "OBNA") {
    // Object-space numerical aperture (object space is air): sin of the axial marginal ray's
    // angle; the value is the first number.
    obna = num(1, "object-space numerical aperture");
    aperture_loc = FileLoc{path_, line_no, t[1].col};
    if (!(*obna > 0 && *obna < 1))
      throw Error(aperture_loc, fmt::format("object-space numerical aperture {} must be > 0 "
                                            "and < 1 (the object is in air)",
                                            *obna));
  } else if (key == "OBSC" || key == "NUMA") {
    throw Error(loc, fmt::format("system aperture {} (object-space numerical aperture or "
                                 "cone angle) is not supported; use ENPD, FNUM or FLOA",
                                 key));
  } else if (key == "WAVM") {
    const int i = inum(1, "wavelength number");
    wavm[i] = num(2, "wavelength (micrometres)");
    if (!(wavm[i] > 0))
      throw Error(FileLoc{path_, line_no, t[2].col},
                  fmt::format("wavelength {} micrometres must be > 0", wavm[i]));
  } else if (key == "WAVL") {
    for (size_t i = 1; i < t.size(); ++i) {
      wavl.push_back(number(t[i], line_no, "wavelength"));
      if (!(wavl.back() > 0))
        throw Error(FileLoc{path_, line_no, t[i].col},
                    fmt::format("wavelength {} micrometres must be > 0", wavl.back()));
    }
  } else if (key == "PWAV") {
    pwav = inum(1, "primary wavelength number");
  } else if (key == "FTYP") {
    // FTYP type telecentric fields wavelengths ...
    if (t.size() >= 2) field_type = inum(1, "field type");
    if (t.size() >= 4) n_fields = inum(3, "number of fields");
    if (t.size() >= 5) n_waves = int(number(t[4], line_no, "number of wavelengths"));
    field_loc = loc;
  } else if (key == "XFLN" || key == "YFLN") {
    auto& v = key == "XFLN" ? xfln : yfln;
    v.clear();
    for (size_t i = 1; i < t.size(); ++i) v.push_back(number(t[i], line_no, "field value"));
    if (!field_loc.valid()) field_loc = loc;
  } else if (key == "VDXN" || key == "VDYN" || key == "VCXN" || key == "VCYN") {
    // Vignetting factors: they shrink the pupil OpticStudio's automatic apertures use.
    for (size_t i = 1; i < t.size(); ++i)
      if (number(t[i], line_no, "vignetting factor") != 0 && !vignetting_loc)
        vignetting_loc = FileLoc{path_, line_no, t[i].col};
  } else if (key == "RAIM") {
    // Ray aiming: the second value is its mode (0 off). Inferred from the optiland sample
    // circular_aperture_example_*.zmx (`RAIM 0 1 ...`), whose automatic semi-diameters
    // OpticStudio computed with rays aimed at the real stop (reproduced to 1e-6 that way).
    if (t.size() >= 3 && number(t[2], line_no, "ray aiming") != 0)
      ray_aiming_loc = FileLoc{path_, line_no, t[2].col};
  }
}

// A line of the current surface's data.
void ZmxParser::surfaceLine(const Line& l) {
  const std::vector<Tok>& t = l.t;
  const std::string_view key = t[0].text;
  const int line_no = l.line_no;
  const FileLoc& loc = l.loc;
  auto num = [&](size_t i, const char* what) { return lineNumber(l, i, what); };
  auto inum = [&](size_t i, const char* what) { return lineInt(l, i, what); };
  auto surfErr = [&](const std::string& msg) { return surfaceError(l, msg); };
  if (key == "TYPE") {
    need(t, 2, line_no, "type");
    cur->type = std::string(t[1].text);
    cur->type_loc = loc;
    if (cur->type != "STANDARD" && cur->type != "EVENASPH" && cur->type != "ODDASPH" &&
        cur->type != "TOROIDAL" && cur->type != "COORDBRK" && cur->type != "DGRATING")
      throw surfErr(
          fmt::format("TYPE {} is not supported (lensim models STANDARD, EVENASPH, "
                      "ODDASPH, TOROIDAL and DGRATING surfaces, and COORDBRK folds)",
                      cur->type));
  } else if (key == "CURV") {
    cur->curv = num(1, "curvature");
  } else if (key == "DISZ") {
    need(t, 2, line_no, "thickness");
    cur->has_disz = true;
    cur->disz_loc = FileLoc{path_, line_no, t[1].col};
    if (t[1].text == "INFINITY")
      cur->disz.reset();
    else
      cur->disz = number(t[1], line_no, "thickness");
  } else if (key == "DIAM") {
    cur->diam = num(1, "semi-diameter");
    cur->diam_loc = FileLoc{path_, line_no, t[1].col};
  } else if (key == "STOP") {
    cur->stop = true;
  } else if (key == "CONI") {
    cur->conic = num(1, "conic constant");
  } else if (key == "PARM") {
    const int i = inum(1, "parameter number");
    cur->parm[i] = num(2, "parameter value");
    cur->parm_loc[i] = FileLoc{path_, line_no, t[2].col};
  } else if (key == "XDAT" && cur->type == "TOROIDAL") {
    // Extra data (`XDAT n value ...`): a toroid's Zernike sag terms (1: the number of terms,
    // 2: their normalisation radius, 3 on: the coefficients); kept to refuse them. The
    // radius alone changes nothing.
    const int n = inum(1, "extra data number");
    const double v = num(2, "extra data value");
    if (v != 0 && n != 2 && !cur->xdat_loc) cur->xdat_loc = FileLoc{path_, line_no, t[2].col};
  } else if (key == "COAT") {
    // A Zemax coating name (defined in the COFN coating file); "COAT" alone: none.
    if (t.size() >= 2) {
      cur->coating = std::string(t[1].text);
      cur->coating_loc = FileLoc{path_, line_no, t[1].col};
    }
  } else if (key == "GLAS") {
    need(t, 2, line_no, "glass");
    cur->glass = std::string(t[1].text);
    cur->glass_loc = FileLoc{path_, line_no, t[1].col};
    if (cur->glass == "MIRROR") {
      // A reflecting surface; the medium after it is the one before it.
      cur->mirror = true;
      cur->glass.clear();
    } else if (t.size() >= 6) {
      cur->n_d = number(t[4], line_no, "glass index n_d");
      cur->v_d = number(t[5], line_no, "glass Abbe number V_d");
    }
  } else {
    // CLAP, OBSC, OBDC, SQAP, ELAP and the surface's own decentres and tilts; other keys are
    // not read.
    (void)apertureLine(l);
  }
}

// Multi-configuration values, the checks on the whole file, coordinate breaks, wavelengths and
// the object distance.
void ZmxParser::finishSystemData(LensPrescription& p, int last_line) {
  applyMultiConfig(surfs, enpd, fnum, floa, wavm, xfln, yfln);

  if (!sequential_seen && surfs.empty())
    throw Error(FileLoc{path_, last_line, 0},
                "not a Zemax lens file: no MODE SEQ line and no SURF blocks");
  if (surfs.size() < 3)
    throw Error(FileLoc{path_, last_line, 0},
                fmt::format("truncated or empty lens: {} SURF block{} (object, at least one lens "
                            "surface and the image are needed)",
                            surfs.size(), surfs.size() == 1 ? "" : "s"));

  readSurfaceTilt();
  resolveCoordinateBreaks(surfs, p);

  // Wavelengths (micrometres in the file).
  {
    std::vector<double> um;
    if (!wavm.empty()) {
      const int count = n_waves ? *n_waves : int(wavm.size());
      for (int i = 1; i <= count; ++i)
        if (auto it = wavm.find(i); it != wavm.end()) um.push_back(it->second);
    } else {
      um = wavl;
    }
    for (double w : um) p.wavelengths_nm.push_back(w * 1000);
    if (pwav && *pwav >= 1 && *pwav <= int(p.wavelengths_nm.size()))
      p.primary_wavelength_nm = p.wavelengths_nm[size_t(*pwav - 1)];
  }

  // Object surface.
  const ZSurface& obj = surfs.front();
  if (obj.disz) p.object_distance_mm = *obj.disz * unit_mm;
  setFields(p);
}

// The design fields (FTYP type 0: angles, 1: object heights, 2: paraxial image heights, 3: real
// image heights; heights in lens units). Other field types are not kept.
void ZmxParser::setFields(LensPrescription& p) const {
  const int count = fieldCount();
  if (count == 0 || field_type < 0 || field_type > 3) return;
  FileFields f;
  f.kind = FileFields::Kind(field_type);
  f.loc = field_loc;
  const double scale = field_type == 0 ? 1.0 : unit_mm;
  for (size_t i = 0; i < size_t(count); ++i)
    f.xy.push_back({(i < xfln.size() ? xfln[i] : 0.0) * scale,
                    (i < yfln.size() ? yfln[i] : 0.0) * scale});
  p.fields = std::move(f);
}

// The lens surfaces (1 .. N-2; the last is the image) as prescription rows.
void ZmxParser::buildSurfaces(LensPrescription& p) {
  // Lens surfaces: 1 .. N-2; the last is the image.
  stop_surface = -1;
  for (size_t k = 1; k + 1 < surfs.size(); ++k)
    if (surfs[k].stop) stop_surface = int(k);
  if (stop_surface < 0) {
    stop_surface = 1;  // Zemax's default: the first surface
    p.diagnostics.push_back({Severity::Note, surfs[1].loc,
                             "no STOP line: surface 1 is the aperture stop (Zemax's default)"});
  }
  // Surfaces without a semi-diameter (no DIAM, DIAM 0) get one from real rays below; until then
  // a placeholder larger than any ray height (bounded by the surface's extent).
  double placeholder_mm = enpd ? *enpd * unit_mm : 0.0;
  for (size_t k = 1; k + 1 < surfs.size(); ++k) {
    if (surfs[k].disz) placeholder_mm += std::abs(*surfs[k].disz) * unit_mm;
    if (surfs[k].diam) placeholder_mm = std::max(placeholder_mm, 4 * *surfs[k].diam * unit_mm);
  }
  placeholder_mm = std::max(4 * placeholder_mm, 1.0);
  double ior_before = 1;
  GlassSpec glass_before;
  int mirrors = 0;
  for (size_t k = 1; k + 1 < surfs.size(); ++k) {
    const ZSurface& z = surfs[k];
    if (!z.has_disz)
      throw Error(z.loc, fmt::format("surface {}: no DISZ (thickness) line", z.number));
    if (!z.disz)
      throw Error(
          z.disz_loc,
          fmt::format("surface {}: thickness INFINITY is allowed for the object only", z.number));
    // Thicknesses are signed (Zemax): negative after an odd number of mirrors, where the light
    // travels toward -z; any other sign would need a ray to go backward.
    mirrors += z.mirror ? 1 : 0;
    if (!p.noncoaxial_loc && *z.disz * (mirrors % 2 ? -1 : 1) < 0)
      throw Error(z.disz_loc,
                  fmt::format("surface {}: thickness {} is {} after {} mirror{}; lensim models "
                              "lenses whose surfaces follow in the direction the light travels "
                              "(+z, and -z after an odd number of mirrors)",
                              z.number, *z.disz, *z.disz < 0 ? "negative" : "positive", mirrors,
                              mirrors == 1 ? "" : "s"));
    const bool auto_semi = !z.clap_max && (!z.diam || *z.diam == 0);
    if (auto_semi && int(k) == stop_surface && floa)
      throw Error(z.diam_loc.valid() ? z.diam_loc : z.loc,
                  fmt::format("surface {} is the stop and has no semi-diameter (no DIAM or DIAM "
                              "0), and the system aperture is FLOA (the stop's size): nothing "
                              "sets the aperture; give the stop a DIAM or the file an ENPD or "
                              "FNUM",
                              z.number));
    double semi = auto_semi ? std::min(placeholder_mm,
                                       0.999 * sagDomainRadius(z.curv != 0 ? unit_mm / z.curv : 0.0,
                                                               SurfaceShape{}))
                            : (z.clap_max ? *z.clap_max : *z.diam) * unit_mm;
    if (!(semi > 0) && auto_semi)
      throw Error(z.loc, fmt::format("surface {}: no semi-diameter in the file, and its curvature "
                                     "{} leaves no extent to compute one on",
                                     z.number, z.curv));
    if (!(semi > 0))
      throw Error(z.diam_loc, fmt::format("surface {}: semi-diameter {} must be > 0", z.number,
                                          semi / unit_mm));

    LensSurface s = makeSurface(z, semi, ior_before, glass_before);
    checkExtent(z, s, semi, auto_semi);
    if (int(k) == stop_surface) {
      const bool plane = s.radius_mm == 0 && s.shape.isSpherical();
      // A mirror is its own stop: a plane at its vertex could not be reached in sequence on
      // either side of a concave mirror (the light turns back before it).
      if (plane || s.mirror) {
        s.stop_flag = true;
      } else {
        // Stop on a curved surface: a plane stop at its vertex, on the side the surface does not
        // reach within its aperture (paraxially the same stop).
        LensSurface st;
        st.loc = z.loc;
        st.frame = s.frame;  // a plane at the same vertex
        st.stop_flag = true;
        st.aperture_diameter_mm = 2 * semi;
        auto sg = surfaceSag(s.radius_mm, s.shape, 0.0, semi * (1 - 1e-9));
        const bool before = !sg || sg->z >= 0;
        p.diagnostics.push_back(
            {Severity::Note, z.loc,
             fmt::format("surface {} is the stop and curved: lensim puts a plane stop at its "
                         "vertex, {} it",
                         z.number, before ? "just before" : "just after")});
        if (before) {
          // The plane sits in the medium before the surface: its glass too, or a stop inside
          // glass would lose the glass's dispersion (and the .zmx writer could not state it).
          st.ior = ior_before;
          st.glass = glass_before;
          st.thickness_mm = 0;
          p.surfaces.push_back(st);
          p.surfaces.push_back(s);
        } else {
          st.ior = s.ior;
          st.glass = s.glass;
          st.thickness_mm = s.thickness_mm;
          s.thickness_mm = 0;
          p.surfaces.push_back(s);
          p.surfaces.push_back(st);
        }
        ior_before = s.ior;
        glass_before = s.glass;
        continue;
      }
    }
    ior_before = s.ior;
    glass_before = s.glass;
    p.surfaces.push_back(s);
  }

  for (size_t r = 0; r < p.surfaces.size(); ++r)
    for (size_t k = 1; k + 1 < surfs.size(); ++k) {
      const ZSurface& z = surfs[k];
      if (z.loc.line == p.surfaces[r].loc.line && !z.clap_max && (!z.diam || *z.diam == 0) &&
          !p.surfaces[r].stop_flag.value_or(false))
        auto_rows.push_back({int(r), &z});
    }

  // An unknown glass falls back on its GLAS line's n_d and V_d (resolveGlass warns). Some files
  // carry placeholders there instead (US05331467-1.zmx: 1.5 and 40 on every line): say so when
  // most of the catalogue glasses of the same file disagree with the catalogue.
  if (!glas_fallbacks.empty() && glas_disagree > 0 && 2 * glas_disagree >= glas_checked)
    for (const auto& [name, gloc] : glas_fallbacks)
      p.diagnostics.push_back(
          {Severity::Warning, gloc,
           fmt::format("glass '{}': the n_d/V_d on this file's GLAS lines look like placeholders, "
                       "not glass data ({} of {} catalogue glasses here disagree with the "
                       "catalogue, e.g. {}); the model glass made from them is probably wrong",
                       name, glas_disagree, glas_checked, glas_example)});
}

// One surface's row: shape, apertures and the medium after it (semi: its semi-diameter, mm;
// the medium before it: ior_before, glass_before).
LensSurface ZmxParser::makeSurface(const ZSurface& z, double semi, double ior_before,
                                   const GlassSpec& glass_before) {
  LensSurface s;
  s.loc = z.loc;
  if (z.frame) s.frame = scaledFrame(*z.frame, unit_mm);
  s.radius_mm = z.curv != 0 ? unit_mm / z.curv : 0.0;
  s.thickness_mm = *z.disz * unit_mm;
  s.aperture_diameter_mm = 2 * semi;
  s.stop_flag = false;
  s.shape.conic = z.conic;
  if (z.type == "EVENASPH" || z.type == "ODDASPH") {
    for (const auto& [i, v] : z.parm) {
      if (i < 1 || i > 8 || v == 0) continue;
      const size_t power = z.type == "EVENASPH" ? size_t(2 * i) : size_t(i);
      if (s.shape.poly.size() <= power) s.shape.poly.resize(power + 1, 0.0);
      s.shape.poly[power] = v;
    }
    s.shape.scaleLengths(unit_mm);
  } else if (z.type == "TOROIDAL") {
    readToroidal(z, unit_mm, s.shape);
  } else if (z.type == "DGRATING") {
    s.grating = readGrating(z);
  }
  s.mirror = z.mirror;
  s.coating = z.coating;
  s.coating_loc = z.coating_loc;
  s.aperture_shape = z.aperture_shape;
  s.aperture_half_x_mm = z.half_x * unit_mm;
  s.aperture_half_y_mm = z.half_y * unit_mm;
  s.aperture_decentre_mm = {z.obdc_x * unit_mm, z.obdc_y * unit_mm};
  if (z.inner_radius > 0) {
    s.obscuration_radius_mm = z.inner_radius * unit_mm;
    if (!(s.obscuration_radius_mm < semi))
      throw Error(z.inner_loc, fmt::format("surface {}: obscuration radius {} is not inside the "
                                           "semi-diameter {}",
                                           z.number, z.inner_radius, semi / unit_mm));
  }
  // The medium after the surface.
  if (z.mirror) {
    s.ior = ior_before;  // a mirror: the light goes back through the medium it came from
    s.glass = glass_before;
  } else if (z.glass.empty()) {
    s.ior = 1;
  } else {
    s.glass.name = z.glass == "___BLANK" ? std::string() : z.glass;
    s.glass.loc = z.glass_loc;
    s.glass.n_d = z.n_d;
    s.glass.v_d = z.v_d;
    s.glass.catalogs = gcat;
    s.glass.model_needs_option = true;
    // The constant index (used where dispersion is not) is the catalogue's n_d for a
    // catalogue glass, else the n_d written on the GLAS line; resolveGlass (glass.h) gives the
    // lens system the glass's n(lambda) and warns about a name it does not know.
    const CatalogGlass* known = z.glass == "___BLANK" ? nullptr : findGlassOrSuccessor(z.glass, nullptr, gcat);
    if (known) {
      s.ior = known->listed_n_d;
      if (z.n_d && z.glass != "___BLANK") {
        ++glas_checked;
        if (std::abs(*z.n_d - known->listed_n_d) > 1e-3) {
          if (glas_disagree++ == 0)
            glas_example = fmt::format("{} n_d {} on its line, {} in the catalogue", z.glass,
                                       *z.n_d, known->listed_n_d);
        }
      }
    } else if (z.n_d && *z.n_d >= 1 && (z.glass == "___BLANK" || modelGlassAllowed())) {
      s.ior = *z.n_d;
      if (z.glass != "___BLANK") glas_fallbacks.push_back({z.glass, z.glass_loc});
    } else {
      resolveGlass(s.glass, 1.0, nullptr);  // throws: unknown glass, with did-you-mean hints
    }
  }
  return s;
}

// The semi-diameter against the surface's extent (an automatic one is clipped to it).
void ZmxParser::checkExtent(const ZSurface& z, LensSurface& s, double& semi,
                            bool auto_semi) const {
  const double domain = sagDomainRadius(s.radius_mm, s.shape);
  if (auto_semi && semi >= 0.999 * domain) {
    semi = 0.999 * domain;
    s.aperture_diameter_mm = 2 * semi;
  }
  const auto outside = apertureOutsideSag(s);
  if (!outside) {
    // A toroid or an asphere-topped biconic is traced within the disc of its domain radius
    // only (ShapeIntersector's bound); a quadric (a cylinder) everywhere.
    const double reach = s.apertureReach_mm();
    if (reach >= domain && !ShapeIntersector(s.radius_mm, s.shape, reach).quadric())
      throw Error(s.apertureDecentred()     ? z.obdc_loc
                  : z.aperture_loc.valid() ? z.aperture_loc
                                           : z.diam_loc,
                  fmt::format("surface {}: its aperture reaches {:.6g} mm from the axis; lensim "
                              "traces this toroidal or biconic shape within {:.6g} mm of the "
                              "axis only (in every direction)",
                              z.number, reach / unit_mm, domain / unit_mm));
    return;
  }
  const bool shaped = z.aperture_shape != ApertureShape::Circle || s.apertureDecentred();
  if (s.shape.isToroidal() && !shaped) {
    // Within the y curve's own extent, the radius of rotation is what is too small.
    SurfaceShape y_curve = s.shape;
    y_curve.rotation_radius_mm = 0.0;
    if (semi < sagDomainRadius(s.radius_mm, y_curve))
      throw Error(parmLoc(z, 1), fmt::format("surface {}: radius of rotation {}: the toroid "
                                             "closes on its axis of rotation {:.6g} mm from "
                                             "the vertex, inside the semi-diameter {}",
                                             z.number, z.parm.count(1) ? z.parm.at(1) : 0.0,
                                             domain / unit_mm, semi / unit_mm));
  }
  if (shaped) {
    const char* what = z.aperture_shape == ApertureShape::Rectangle ? "SQAP"
                       : z.aperture_shape == ApertureShape::Ellipse ? "ELAP"
                                                                    : "CLAP";
    throw Error(s.apertureDecentred() ? z.obdc_loc : z.aperture_loc,
                fmt::format("surface {}: its {} aperture{} reaches the point x {:.6g}, y "
                            "{:.6g} mm, where the surface is not defined (its sag's square root "
                            "fails: beyond its extent)",
                            z.number, what, s.apertureDecentred() ? ", decentred by OBDC," : "",
                            (*outside)[0] / unit_mm, (*outside)[1] / unit_mm));
  }
  throw Error(z.diam_loc, fmt::format("surface {}: semi-diameter {} mm exceeds the surface's "
                                      "extent ({} mm)",
                                      z.number, semi, domain));
}

namespace {

// Whether rows 0 .. last of a non-coaxial lens sit on the object axis, unturned, with no grating
// before row `last` (the stop's own grating does not change its paraxial image).
bool coaxialUpTo(const LensPrescription& p, int last) {
  for (int i = 0; i <= last; ++i) {
    if (i < last && p.surfaces[size_t(i)].grating) return false;
    const SurfaceFrame& f = *p.surfaces[size_t(i)].frame;
    if (!(std::abs(f.origin_mm[0]) <= 1e-12 && std::abs(f.origin_mm[1]) <= 1e-12)) return false;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        if (!(std::abs(f.rotation[size_t(r)][size_t(c)] - (r == c ? 1.0 : 0.0)) <= 1e-12))
          return false;
  }
  return true;
}

// Rows 0 .. last of a non-coaxial lens (coaxialUpTo) as a coaxial prescription.
LensPrescription coaxialFront(const LensPrescription& p, int last) {
  LensPrescription q = p;
  q.surfaces.resize(size_t(last) + 1);
  for (LensSurface& s : q.surfaces) s.frame.reset(), s.grating.reset();
  q.noncoaxial_loc.reset();
  q.configurations.clear();
  return q;
}

}  // namespace

// The system aperture sets the stop's size.
void ZmxParser::sizeStop(LensPrescription& p) {
  // The system aperture sets the stop's size (paraxially: the entrance pupil is the image of the
  // stop, so its diameter scales with the stop's).
  const auto stop_index = p.stopIndex();
  const ZSurface& stop_z = surfs[size_t(stop_surface)];
  const bool stop_auto = !stop_z.clap_max && (!stop_z.diam || *stop_z.diam == 0);
  // A non-coaxial lens whose surfaces up to the stop sit on the object axis: its entrance pupil
  // is the paraxial image of the stop through them, as for any lens.
  const bool front_coaxial = p.noncoaxial_loc && stop_index && (enpd || obna) && !floa &&
                             coaxialUpTo(p, *stop_index);
  if (p.noncoaxial_loc) p.image_frame = scaledFrame(*surfs.back().frame, unit_mm);
  if (p.noncoaxial_loc && !front_coaxial) {
    if (stop_auto)
      throw Error(stop_z.diam_loc.valid() ? stop_z.diam_loc : stop_z.loc,
                  fmt::format("surface {} (the stop) has no semi-diameter (no DIAM or DIAM 0): "
                              "in a tilted or decentred lens lensim does not size the stop from "
                              "the system aperture; give the stop a DIAM",
                              stop_z.number));
    if (floa) {
      p.aperture_spec = "FLOA (stop semi-diameter from DIAM)";
    } else if (enpd || fnum || obna) {
      p.aperture_spec = "the stop's DIAM";
      p.diagnostics.push_back(
          {Severity::Note, aperture_loc,
           fmt::format("a tilted or decentred lens: the stop keeps the semi-diameter DIAM gives "
                       "({:.6g} mm); the system aperture on this line (which needs the paraxial "
                       "image of the stop through a coaxial system) is not applied",
                       p.surfaces[size_t(*stop_index)].semiAperture_mm())});
    }
  } else if (stop_index && (enpd || fnum || obna) && !floa) {
    const LensSystem sys(front_coaxial ? coaxialFront(p, *stop_index) : p);
    const auto& in = sys.interfaces();
    const int st = *stop_index;
    // (y, n u) at the stop per unit height (y_stop) and per unit angle (w_stop) of a ray at the
    // front vertex: the entrance pupil lies where y_stop y + w_stop u = 0 for y = -z u.
    double y_stop = 1, w_stop = 0;
    if (st > 0) {
      const RayMatrix m = systemMatrix(sys, 0, st - 1);
      const double reduced =
          (in[size_t(st)].z_mm - in[size_t(st - 1)].z_mm) / in[size_t(st)].nBefore();
      y_stop = m.a + reduced * m.c;
      w_stop = m.b + reduced * m.d;
    }
    const double semi_now = p.surfaces[size_t(st)].semiAperture_mm();
    const double epd_now = 2 * semi_now / std::abs(y_stop);
    double epd_target;
    if (enpd) {
      epd_target = *enpd * unit_mm;
      p.aperture_spec = fmt::format("ENPD {} mm", epd_target);
    } else if (obna) {
      // The axial marginal ray from the object point at angle asin(NA) to the paraxial entrance
      // pupil's edge.
      if (!p.object_distance_mm)
        throw Error(aperture_loc, fmt::format("OBNA {}: an object-space numerical aperture needs "
                                              "a finite object (the object surface's DISZ is "
                                              "INFINITY)",
                                              *obna));
      const double to_pupil = *p.object_distance_mm + w_stop / y_stop;
      if (!(to_pupil > 0))
        throw Error(aperture_loc, fmt::format("OBNA {}: the entrance pupil lies {:.6g} mm in "
                                              "front of the object",
                                              *obna, -to_pupil));
      epd_target = 2 * to_pupil * std::tan(std::asin(*obna));
      p.aperture_spec = fmt::format("OBNA {}", *obna);
    } else {
      const ParaxialData para = computeParaxial(sys);
      epd_target = std::abs(para.effective_focal_length_mm) / *fnum;
      p.aperture_spec = fmt::format("FNUM {}", *fnum);
    }
    const double semi_new = semi_now * epd_target / epd_now;
    epd_mm = epd_target;
    const LensSurface& stop_row = p.surfaces[size_t(st)];
    const double extent = sagDomainRadius(stop_row.radius_mm, stop_row.shape);
    if (semi_new >= extent && stop_auto) {
      throw Error(aperture_loc,
                  fmt::format("{}: the stop (surface {}, no DIAM) would need a semi-diameter of "
                              "{:.6g} mm, beyond its surface's extent ({:.6g} mm)",
                              p.aperture_spec, stop_z.number, semi_new, extent));
    } else if (semi_new >= extent) {
      // A curved stop (a mirror) cannot open beyond its surface: keep DIAM's size.
      p.diagnostics.push_back(
          {Severity::Warning, aperture_loc,
           fmt::format("{}: the stop would need a semi-diameter of {:.6g} mm, beyond its "
                       "surface's extent ({:.6g} mm); it keeps DIAM's {:.6g} mm",
                       p.aperture_spec, semi_new, extent, semi_now)});
    } else {
      p.surfaces[size_t(st)].aperture_diameter_mm = 2 * semi_new;
    }
    if (stop_auto)
      p.diagnostics.push_back(
          {Severity::Note, stop_z.loc,
           fmt::format("surface {} (the stop) has no semi-diameter in the file: {:.6g} mm from "
                       "{}",
                       stop_z.number, semi_new, p.aperture_spec)});
    else if (semi_new < extent && std::abs(semi_new / semi_now - 1) > 1e-6)
      p.diagnostics.push_back(
          {Severity::Note, aperture_loc,
           fmt::format("{}: the stop's semi-diameter is {:.6g} mm (DIAM gives {:.6g} mm)",
                       p.aperture_spec, semi_new, semi_now)});
  } else if (floa) {
    p.aperture_spec = "FLOA (stop semi-diameter from DIAM)";
  }
}

// Semi-diameters the file leaves to OpticStudio, from real rays.
void ZmxParser::computeMissingSemiDiameters(LensPrescription& p) {
  if (!auto_rows.empty() && p.noncoaxial_loc) {
    const ZSurface& z = *auto_rows.front().second;
    throw Error(z.diam_loc.valid() ? z.diam_loc : z.loc,
                fmt::format("surface {}: no semi-diameter (no DIAM or DIAM 0): lensim computes "
                            "semi-diameters for coaxial lenses only, and this one is not "
                            "coaxial ({})",
                            z.number, p.noncoaxial_reason));
  }
  if (!auto_rows.empty()) {
    if (vignetting_loc)
      throw Error(*vignetting_loc,
                  "vignetting factors with surfaces whose semi-diameters OpticStudio computes (no "
                  "DIAM or DIAM 0) are not supported");
    AutoSemiDiameterSpec spec;
    spec.fields_loc = field_loc.valid() ? field_loc : auto_rows.front().second->loc;
    // Paraxial image heights (type 2) of an object at infinity are the angles atan(h / EFL);
    // real image heights (type 3) the angles whose real chief rays land at h.
    const bool image_heights = field_type == 2 && !p.object_distance_mm;
    const bool real_heights = field_type == 3 && !p.object_distance_mm;
    if (field_type != 0 && field_type != 1 && !image_heights && !real_heights)
      throw Error(spec.fields_loc,
                  fmt::format("field type {} (FTYP): automatic semi-diameters need field angles "
                              "(0), object heights (1) or, for an object at infinity, paraxial "
                              "(2) or real (3) image heights",
                              field_type));
    spec.object_heights = field_type == 1;
    double efl = 0;
    if (image_heights) {
      efl = computeParaxial(LensSystem(p)).effective_focal_length_mm;
      if (!std::isfinite(efl) || efl == 0)
        throw Error(spec.fields_loc, "paraxial image-height fields (FTYP 2) of an afocal lens");
    }
    spec.aim_at_stop = ray_aiming_loc.has_value();
    // FTYP's count of the XFLN/YFLN values (a count beyond them adds no field).
    const size_t count = size_t(fieldCount());
    for (size_t i = 0; i < count; ++i) {
      const double fx = i < xfln.size() ? xfln[i] : 0.0, fy = i < yfln.size() ? yfln[i] : 0.0;
      if (image_heights) {
        spec.fields.push_back({std::atan(fx * unit_mm / efl) * 180 / std::numbers::pi,
                               std::atan(fy * unit_mm / efl) * 180 / std::numbers::pi});
        continue;
      }
      if (real_heights) {
        // The chief ray of the radial height, split along the field's azimuth by the tangents
        // (the bundle's direction (tan x, tan y, 1)).
        const double h = std::hypot(fx, fy) * unit_mm;
        const std::optional<double> deg = realImageHeightFieldAngle(p, h, spec.aim_at_stop);
        if (!deg)
          throw Error(spec.fields_loc,
                      fmt::format("field {}: no real chief ray reaches the image height {:.6g} mm "
                                  "(FTYP 3, real image heights)",
                                  i + 1, h));
        const double t = h > 0 ? std::tan(*deg * std::numbers::pi / 180) / h : 0.0;
        spec.fields.push_back({std::atan(t * fx * unit_mm) * 180 / std::numbers::pi,
                               std::atan(t * fy * unit_mm) * 180 / std::numbers::pi});
        continue;
      }
      spec.fields.push_back(spec.object_heights ? std::pair{fx * unit_mm, fy * unit_mm}
                                                : std::pair{fx, fy});
    }
    spec.entrance_pupil_diameter_mm = epd_mm.value_or(0.0);
    std::vector<int> rows;
    for (const auto& [row, z] : auto_rows) rows.push_back(row);
    const std::vector<double> semi = computeAutoSemiDiameters(p, rows, spec);
    for (size_t i = 0; i < rows.size(); ++i) {
      LensSurface& s = p.surfaces[size_t(rows[i])];
      const ZSurface& z = *auto_rows[i].second;
      if (s.obscuration_radius_mm >= semi[i])
        throw Error(z.inner_loc, fmt::format("surface {}: obscuration radius {} is not inside the "
                                             "computed semi-diameter {:.6g}",
                                             z.number, z.inner_radius, semi[i] / unit_mm));
      s.aperture_diameter_mm = 2 * semi[i];
      p.diagnostics.push_back(
          {Severity::Note, z.diam_loc.valid() ? z.diam_loc : z.loc,
           fmt::format("surface {}: {}: semi-diameter {:.6g} mm computed from real rays (the "
                       "largest ray height of {} field{} at the pupil's edge, {})",
                       z.number, z.diam ? "DIAM 0" : "no DIAM", semi[i], spec.fields.size(),
                       spec.fields.size() == 1 ? "" : "s",
                       spec.aim_at_stop ? "rays aimed at the real stop (RAIM)"
                                        : "rays through the paraxial entrance pupil")});
    }
  }
}

void ZmxParser::readCoatingFile(LensPrescription& p) {
  // Coatings: with the coating file beside the lens file, unknown COAT names are refused at
  // their line; without it they are kept and refused where coatings are used (flare analyses),
  // so that the lens still loads for everything else.
  if (!cofn.empty()) {
    const std::filesystem::path f = std::filesystem::path(path_).parent_path() / cofn;
    std::error_code ec;
    if (std::filesystem::is_regular_file(f, ec)) {
      p.coating_file = f.lexically_normal().string();
      p.coating_file_loc = cofn_loc;
      resolveCoatings(p);
    } else {
      for (const LensSurface& s : p.surfaces)
        if (!s.coating.empty()) {
          p.diagnostics.push_back(
              {Severity::Note, s.coating_loc,
               fmt::format("coating '{}' is defined in {}, which is not beside the lens file: "
                           "the lens's coatings are unknown (flare analyses refuse it)",
                           s.coating, cofn)});
          break;
        }
    }
  }
}

}  // namespace zmx_detail

namespace {

using zmx_detail::ZmxParser;

// Every configuration of a multi-configuration file: the file parsed again with that
// configuration's operands applied (so that ENPD/FNUM, curved stops and glasses are treated as in
// any file).
void readZmxConfigurations(const ZmxParser& base, std::string_view bytes, const std::string& path,
                           LensPrescription& p) {
  p.active_configuration = base.mcActive();
  if (base.mcCount() < 2) return;
  for (int n = 1; n <= base.mcCount(); ++n) {
    ZmxParser c(path);
    c.setConfiguration(n);
    LensPrescription q = c.parse(bytes);
    if (q.surfaces.size() != p.surfaces.size())
      throw Error(base.mcLoc(), fmt::format("configuration {} has {} surfaces and the file's data "
                                            "{}: a stop moved (STPS) to or from a curved surface "
                                            "is not supported",
                                            n, q.surfaces.size(), p.surfaces.size()));
    LensConfiguration cfg;
    cfg.surfaces = std::move(q.surfaces);
    cfg.aperture_spec = q.aperture_spec;
    cfg.object_distance_mm = q.object_distance_mm;
    cfg.wavelengths_nm = q.wavelengths_nm;
    cfg.fields = q.fields;
    cfg.loc = base.mcLoc();
    p.configurations.push_back(std::move(cfg));
  }
}

}  // namespace

LensPrescription parseZmx(std::string_view bytes, const std::string& path) {
  zmx_detail::ZmxParser base(path);
  LensPrescription p = base.parse(bytes);
  readZmxConfigurations(base, bytes, path, p);
  zmx_detail::readFocusPositions(base, p);
  return p;
}

}  // namespace lensim::optics
