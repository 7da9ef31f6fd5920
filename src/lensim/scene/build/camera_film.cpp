// Builder: Camera, Film, Sampler and PixelFilter directives.
#include <cctype>
#include <cmath>

#include "lensim/optics/glass/library.h"
#include "lensim/scene/build/builder_internal.h"

namespace lensim::scene::detail {

namespace {

/// The parameters every camera has: "shutteropen", "shutterclose" (swapped when out of order,
/// which returns true) and the clipping distances "hither", "yon".
bool parseShutterAndClip(ParamSet& ps, Camera& c) {
  c.shutter_open = ps.getFloat({"shutteropen"}, 0);
  c.shutter_close = ps.getFloat({"shutterclose"}, 1);
  c.hither = ps.getFloat({"hither"}, 1e-3);
  c.yon = ps.getFloat({"yon"}, 1e30);
  if (!(c.shutter_close < c.shutter_open)) return false;
  std::swap(c.shutter_open, c.shutter_close);
  return true;
}

/// The parameters of the perspective, orthographic and spherical cameras into c; false for
/// another type.
bool parseCentralCamera(const std::string& type, ParamSet& ps, Camera& c) {
  auto screen = [&]() {
    c.frame_aspect_ratio = ps.findFloat({"frameaspectratio"});
    if (const Param* p = ps.find({"screenwindow"}, {ParamType::Float})) {
      ps.expectCount(*p, 4);
      c.screen_window =
          std::array<double, 4>{p->numbers[0], p->numbers[1], p->numbers[2], p->numbers[3]};
    }
    c.lens_radius = ps.getFloat({"lensradius"}, 0);
    c.focal_distance = ps.getFloat({"focaldistance"}, 1e6);
  };
  if (type == "perspective") {
    c.type = "perspective";
    screen();
    c.fov_deg = ps.getFloat({"fov"}, 90);
    if (auto half = ps.findFloat({"halffov"})) c.fov_deg = 2 * *half;  // pbrt-v1/v2
  } else if (type == "orthographic") {
    c.type = "orthographic";
    screen();
  } else if (type == "spherical") {
    c.type = "spherical";
    ps.find({"screenwindow"}, {ParamType::Float});
    ps.getFloat({"lensradius"}, 0);
    ps.getFloat({"focaldistance"}, 1e6);
    ps.findFloat({"frameaspectratio"});
    c.spherical_mapping = ps.getString({"mapping"}, "equalarea");
    if (c.spherical_mapping != "equirectangular" && c.spherical_mapping != "equalarea")
      throw Error(ps.peek({"mapping"})->loc,
                  fmt::format("spherical camera: unknown mapping \"{}\" (expected "
                              "\"equalarea\" or \"equirectangular\")",
                              c.spherical_mapping));
  } else {
    return false;
  }
  return true;
}

/// "string flareghosts", a diagnostic: only the listed ghost pairs, "I,J;I,J" (docs/flare.md).
void parseFlareGhosts(ParamSet& ps, Realistic& r) {
  if (const Param* fg = ps.find({"flareghosts"}, {ParamType::String})) {
    if (!r.flare) ps.fail(*fg, "applies only with \"bool flare\" true");
    const std::string& text = fg->strings[0];
    size_t pos = 0;
    while (pos <= text.size()) {
      size_t end = text.find(';', pos);
      if (end == std::string::npos) end = text.size();
      const std::string item = text.substr(pos, end - pos);
      const size_t comma = item.find(',');
      bool ok = comma != std::string::npos && comma > 0 && comma + 1 < item.size() &&
                item.size() < 12 &&
                item.find_first_not_of("0123456789,") == std::string::npos &&
                item.find(',', comma + 1) == std::string::npos;
      std::pair<int, int> ij{0, 0};
      if (ok) ij = {std::stoi(item.substr(0, comma)), std::stoi(item.substr(comma + 1))};
      if (!ok)
        ps.fail(*fg, fmt::format("'{}': expected ghost pairs I,J separated by ';' (surface "
                                 "indices as `lens ghosts` lists them)",
                                 item));
      for (const auto& p : r.flare_ghosts)
        if (p == ij) ps.fail(*fg, fmt::format("ghost pair {} is listed twice", item));
      r.flare_ghosts.push_back(ij);
      pos = end + 1;
    }
    r.flare_ghosts_loc = fg->loc;
  }
}

}  // namespace

// ---- camera and options --------------------------------------------------------------------
void Builder::camera(const Directive& d) {
  const std::string& type = d.strings[0];
  if (!scene_.camera.defaulted)
    warn(d.loc, fmt::format("second Camera (the first is at {}); the last one is used",
                            scene_.camera.loc.str()));
  ParamSet ps(d.params, d.loc, fmt::format("Camera \"{}\"", type));
  Camera c;
  c.defaulted = false;
  c.type_as_written = type;
  c.loc = d.loc;
  requireInvertible(d.loc, fmt::format("Camera \"{}\"", type));
  c.camera_from_world = gs_.ctm[0];
  c.camera_from_world_end = gs_.ctm[1];
  c.transform_start_time = scene_.transform_start_time;
  c.transform_end_time = scene_.transform_end_time;
  if (c.camera_from_world_end != c.camera_from_world)
    requireInvertible(d.loc, fmt::format("Camera \"{}\" (its end-time transform)", type), 1);
  named_cs_["camera"] = {inverse(gs_.ctm[0]), inverse(gs_.ctm[1])};
  pending_media_.push_back({-1, "", gs_.outside_medium, gs_.medium_loc});
  if (parseShutterAndClip(ps, c))
    warn(d.loc, "shutterclose is before shutteropen; they are swapped");
  if (type == "realistic") {
    c.type = "realistic";
    if (ps.peek({"specfile"})) {
      c.legacy_realistic = legacyRealistic(d, ps);
    } else {
      Realistic r;
      const Param* lf = ps.find({"lensfile"}, {ParamType::String});
      if (!lf) throw Error(d.loc, "realistic camera: missing \"string lensfile\"");
      r.lens_file_as_written = lf->strings[0];
      // Catalogue names (lentil:KEY, lenses:NAME; see optics/lens_formats.h) are not paths.
      const std::string& lname = lf->strings[0];
      r.lens_file = lname.rfind("lentil:", 0) == 0 || lname.rfind("lenses:", 0) == 0
                        ? lname
                        : resolve(lname, lf->loc, "lens file");
      if (const Param* ad = ps.find({"aperturediameter"}, {ParamType::Float})) {
        ps.expectCount(*ad, 1);
        if (!(ad->numbers[0] > 0) || !std::isfinite(ad->numbers[0]))
          ps.fail(*ad, fmt::format("{} mm: expected a finite aperture diameter > 0 (mm)",
                                   ad->numbers[0]));
        r.aperture_diameter_mm = ad->numbers[0];
      }
      r.focus_given = ps.peek({"focusdistance"}) || ps.peek({"filmdistance"});
      r.focus_distance_m = ps.getFloat({"focusdistance"}, 10.0);
      // pbrt-v3's default is true; pbrt-v4 has no such parameter (always irradiance).
      r.simple_weighting = ps.getBool({"simpleweighting"}, scene_.legacy_syntax);
      r.glass_match = ps.getBool({"glassmatch"}, false);
      r.glass_absorption = ps.getBool({"glassabsorption"}, true);
      if (const Param* cf = ps.find({"configuration"}, {ParamType::Integer})) {
        ps.expectCount(*cf, 1);
        if (!(cf->numbers[0] >= 1)) ps.fail(*cf, "expected a configuration number >= 1");
        r.configuration = static_cast<int>(cf->numbers[0]);
        r.zoom_loc = cf->loc;
      }
      if (const Param* fl = ps.find({"focallength"}, {ParamType::Float})) {
        ps.expectCount(*fl, 1);
        if (r.configuration) ps.fail(*fl, "give configuration or focallength, not both");
        if (!(fl->numbers[0] > 0)) ps.fail(*fl, "expected a focal length > 0 (mm)");
        r.zoom_focal_length_mm = fl->numbers[0];
        r.zoom_loc = fl->loc;
      }

      // "string glasscatalog": catalogue files (.agf, .csv) searched for the lens's glasses
      // before the built-in ones (optics/glass/library.h); errors point at this parameter.
      if (const Param* gc = ps.find({"glasscatalog"}, {ParamType::String}))
        for (const std::string& f : gc->strings)
          optics::addGlassCatalogFile(resolve(f, gc->loc, "glass catalogue"), gc->loc);
      if (const Param* fd = ps.find({"filmdistance"}, {ParamType::Float})) {
        ps.expectCount(*fd, 1);
        if (!(fd->numbers[0] > 0)) ps.fail(*fd, "film distance must be positive (mm)");
        if (ps.peek({"focusdistance"}))
          ps.fail(*fd, "give filmdistance or focusdistance, not both");
        r.film_distance_mm = fd->numbers[0];
      }
      if (const Param* fm = ps.find({"focusmethod"}, {ParamType::String})) {
        if (fm->strings[0] != "thick" && fm->strings[0] != "exact")
          ps.fail(*fm, fmt::format("\"{}\": expected \"thick\" or \"exact\"", fm->strings[0]));
        r.focus_method = fm->strings[0];
      }
      if (const Param* b = ps.find({"blades"}, {ParamType::Integer})) {
        ps.expectCount(*b, 1);
        if (b->numbers[0] != 0 && b->numbers[0] < 3)
          ps.fail(*b, "a polygonal stop needs at least 3 blades (0: round)");
        r.blades = static_cast<int>(b->numbers[0]);
      }
      r.blade_rotation_deg = ps.getFloat({"bladerotation"}, 0);
      if (const Param* ap = ps.find({"aperture"}, {ParamType::String})) {
        const std::string& a = ap->strings[0];
        static const std::set<std::string> builtin = {"gaussian", "square", "pentagon", "star"};
        r.aperture = builtin.count(a) ? a : resolve(a, ap->loc, "aperture image");
      }
      // Tilt and shift (optics/tilt_shift.h): the lens axis meets the film at "lensshift"
      // [x y] (mm, film coordinates) and turns about it by "lenstilt" [about x, about y] (deg).
      if (const Param* sh = ps.find({"lensshift"}, {ParamType::Float})) {
        ps.expectCount(*sh, 2);
        for (double v : sh->numbers)
          if (!(std::abs(v) <= 1000)) ps.fail(*sh, "expected a shift within +-1000 mm");
        r.tilt_shift.shift_mm = {sh->numbers[0], sh->numbers[1]};
        r.tilt_shift_loc = sh->loc;
      }
      if (const Param* tl = ps.find({"lenstilt"}, {ParamType::Float})) {
        ps.expectCount(*tl, 2);
        for (double v : tl->numbers)
          if (!(std::abs(v) < 45)) ps.fail(*tl, "expected tilt angles within +-45 degrees");
        r.tilt_shift.tilt_deg = {tl->numbers[0], tl->numbers[1]};
        r.tilt_shift_loc = tl->loc;
      }
      // Lens flare (issue 31, docs/flare.md "Rendering ghosts"): "bool flare" and the
      // lens-wide coating it renders with, "string flarecoating".
      if (const Param* fp = ps.find({"flare"}, {ParamType::Bool})) {
        ps.expectCount(*fp, 1);
        r.flare = fp->bools[0];
        r.flare_loc = fp->loc;
      }
      if (const Param* fc = ps.find({"flarecoating"}, {ParamType::String})) {
        if (!r.flare) ps.fail(*fc, "applies only with \"bool flare\" true");
        r.flare_coating = fc->strings[0];
        r.flare_coating_loc = fc->loc;
      }
      // As-built lenses (issue 33, docs/design.md "Rendering as-built lenses"): "string
      // tolerances" names a design job, "integer asbuilt" the Monte Carlo build rendered.
      const Param* tj = ps.find({"tolerances"}, {ParamType::String});
      const Param* ab = ps.find({"asbuilt"}, {ParamType::Integer});
      if (ab) {
        ps.expectCount(*ab, 1);
        if (!tj) ps.fail(*ab, "needs \"string tolerances\" naming the design job");
        if (!(ab->numbers[0] >= 0 && ab->numbers[0] <= 1e9))
          ps.fail(*ab, fmt::format("{}: expected a build index >= 0", ab->numbers[0]));
        r.as_built = static_cast<int>(ab->numbers[0]);
      }
      if (tj) {
        if (!ab) ps.fail(*tj, "needs \"integer asbuilt\" (the Monte Carlo build to render)");
        r.tolerance_job = resolve(tj->strings[0], tj->loc, "design job");
        r.tolerance_loc = ab ? ab->loc : tj->loc;
      }
      parseFlareGhosts(ps, r);
      c.realistic = r;
    }
  } else if (!parseCentralCamera(type, ps, c)) {
    ps.markAllUsed();
    warnOnce("camera " + type, d.loc,
             fmt::format("camera \"{}\" is not rendered by lensim; it renders as a perspective "
                         "camera with a 90 degree field of view",
                         type));
  }
  finish(ps);
  scene_.camera = std::move(c);
}

/// The pbrt-v1/v2 realistic camera ("specfile", CS348B): camera-space millimetres.
LegacyRealistic Builder::legacyRealistic(const Directive& d, ParamSet& ps) {
  pbrt_v2_ = true;
  LegacyRealistic r;
  const Param* spec = ps.find({"specfile"}, {ParamType::String});
  r.lens_file_as_written = spec->strings[0];
  r.lens_file = resolve(spec->strings[0], spec->loc, "lens file");
  const Param* fd = ps.find({"filmdistance"}, {ParamType::Float});
  if (!fd) throw Error(d.loc, "realistic camera: missing \"float filmdistance\" (mm)");
  ps.expectCount(*fd, 1);
  r.film_distance_mm = fd->numbers[0];
  const Param* ad = ps.find({"aperture_diameter"}, {ParamType::Float});
  if (!ad) throw Error(d.loc, "realistic camera: missing \"float aperture_diameter\" (mm)");
  ps.expectCount(*ad, 1);
  r.aperture_diameter_mm = ad->numbers[0];
  r.film_diagonal_mm = ps.getFloat({"filmdiag"}, 35);
  if (const Param* af = ps.find({"af_zones"}, {ParamType::String}))
    r.af_zones_file = resolve(af->strings[0], af->loc, "autofocus zone file");
  if (r.film_distance_mm <= 0) ps.fail(*fd, "film distance must be positive (mm)");
  if (r.aperture_diameter_mm <= 0) ps.fail(*ad, "aperture diameter must be positive (mm)");
  return r;
}

// pbrt-v4's "sensor" (src/pbrt/film.cpp, PixelSensor::Create): "cie1931" or one of pbrt-v4's
// named cameras (whose measured curves lensim bundles); any other name is an error there
// ("unknown sensor type") and here.
void Builder::checkSensor(ParamSet& ps, const Film& f) {
  const Param* p = ps.find({"sensor"}, {ParamType::String});
  if (!p || sensorSupport(f.sensor) == SensorSupport::Applied) return;
  std::string list;
  for (const std::string& n : bundledSensorNames()) list += (list.empty() ? "" : ", ") + n;
  throw Error(p->loc,
              fmt::format("\"sensor\": unknown sensor \"{}\"; expected one of {}", f.sensor, list));
}

// pbrt-v4's SpectralFilm::Create (src/pbrt/film.cpp): "nbuckets" (16), "lambdamin" and
// "lambdamax" (360 and 830 nm, pbrt-v4's Lambda_min/Lambda_max, outside which it refuses to
// render), an EXR file only.
void Builder::spectralFilm(ParamSet& ps, Film& f) {
  f.type = "spectral";
  const Param* nb = ps.find({"nbuckets"}, {ParamType::Integer});
  f.spectral_buckets = ps.getInt({"nbuckets"}, 16);
  if (f.spectral_buckets < 1 || f.spectral_buckets > 4096)
    throw Error(nb ? nb->loc : f.loc,
                fmt::format("\"nbuckets\": {} buckets; expected 1 to 4096", f.spectral_buckets));
  const Param* lo = ps.find({"lambdamin"}, {ParamType::Float});
  const Param* hi = ps.find({"lambdamax"}, {ParamType::Float});
  f.lambda_min_nm = ps.getFloat({"lambdamin"}, 360);
  f.lambda_max_nm = ps.getFloat({"lambdamax"}, 830);
  if (f.lambda_min_nm < 360 || f.lambda_max_nm > 830 || !(f.lambda_min_nm < f.lambda_max_nm))
    throw Error(lo   ? lo->loc
                : hi ? hi->loc
                     : f.loc,
                fmt::format("\"lambdamin\"/\"lambdamax\": [{}, {}] nm; expected an interval "
                            "within [360, 830] nm (the wavelengths lensim and pbrt-v4 render)",
                            f.lambda_min_nm, f.lambda_max_nm));
}

// Film "raw" (issue 34, docs/sensor.md): the camera sensor's parameters, each with its unit.
void Builder::rawFilm(ParamSet& ps, Film& f) {
  f.type = "raw";
  SensorConfig& s = f.raw_sensor;
  const std::string qe = ps.getString({"qe"}, s.qe);
  // A QE file is resolved like the scene's other files; a bundled camera name is kept.
  s.qe = qe.find('/') != std::string::npos || qe.find('.') != std::string::npos
             ? resolve(qe, ps.peek({"qe"})->loc, "QE file")
             : qe;
  // "cfa": a pattern's text, or its rows as a string array (["RG" "GB"]).
  FileLoc cfa_loc = f.loc;
  if (const Param* p = ps.find({"cfa"}, {ParamType::String})) {
    cfa_loc = p->loc;
    s.cfa.clear();
    for (const std::string& row : p->strings) s.cfa += (s.cfa.empty() ? "" : "/") + row;
  }
  const CfaPattern cfa = parseCfa(s.cfa, cfa_loc);
  std::string out = ps.getString({"filename"}, f.filename);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  // "dngcfa": the DNG's mosaic, the CFA's own or remosaiced to Bayer RGGB.
  FileLoc dng_cfa_loc = f.loc;
  if (const Param* p = ps.find({"dngcfa"}, {ParamType::String})) {
    dng_cfa_loc = p->loc;
    s.dng_cfa = p->strings[0];
    if (s.dng_cfa != "native" && s.dng_cfa != "bayer")
      throw Error(p->loc, fmt::format("\"dngcfa\": \"{}\"; expected \"native\" (the CFA's own "
                                      "mosaic) or \"bayer\" (remosaiced to RGGB)",
                                      s.dng_cfa));
  }
  if (out.size() >= 4 && out.compare(out.size() - 4, 4, ".dng") == 0)
    checkDngCfa(cfa, cfa_loc, s.dng_cfa);
  s.peak_qe = ps.getFloat({"peakqe"}, s.peak_qe);
  s.ircut_nm = ps.getFloat({"ircut"}, s.ircut_nm);
  s.ircut_width_nm = ps.getFloat({"ircutwidth"}, s.ircut_width_nm);
  s.pixel_pitch_um = ps.getFloat({"pixelpitch"}, 0);
  s.fill_factor = ps.getFloat({"fillfactor"}, s.fill_factor);
  s.base_iso = ps.getFloat({"baseiso"}, s.base_iso);
  s.temperature_c = ps.getFloat({"temperature"}, s.temperature_c);
  s.dark_current_e_s = ps.getFloat({"darkcurrent"}, s.dark_current_e_s);
  s.dark_ref_c = ps.getFloat({"darkreftemperature"}, s.dark_ref_c);
  s.dark_doubling_c = ps.getFloat({"darkdoubling"}, s.dark_doubling_c);
  s.read_noise_e = ps.getFloat({"readnoise"}, s.read_noise_e);
  s.dsnu_e = ps.getFloat({"dsnu"}, s.dsnu_e);
  s.prnu = ps.getFloat({"prnu"}, s.prnu);
  s.full_well_e = ps.getFloat({"fullwell"}, s.full_well_e);
  s.conversion_gain_e_dn = ps.getFloat({"conversiongain"}, s.conversion_gain_e_dn);
  s.adc_bits = ps.getInt({"adcbits"}, s.adc_bits);
  s.black_level_dn = ps.getInt({"blacklevel"}, s.black_level_dn);
  s.pattern_seed = uint64_t(uint32_t(ps.getInt({"patternseed"}, int(s.pattern_seed))));
  f.raw_noise_seed = ps.getInt({"noiseseed"}, 0);
  s.noise = ps.getBool({"noise"}, true);
  f.raw_nits = ps.getFloat({"nits"}, 1);
  f.raw_fnumber = ps.getFloat({"fnumber"}, 0);
  if (!(f.raw_nits > 0 && f.raw_nits < 1e30))
    throw Error(ps.peek({"nits"})->loc,
                fmt::format("\"nits\": {} is out of range; expected a positive luminance "
                            "(cd/m^2) of unit scene radiance",
                            f.raw_nits));
  if (!(f.raw_fnumber >= 0 && f.raw_fnumber <= 1000))
    throw Error(ps.peek({"fnumber"})->loc,
                fmt::format("\"fnumber\": {} is out of range; expected (0, 1000]", f.raw_fnumber));
}

void Builder::film(const Directive& d) {
  const std::string& type = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("Film \"{}\"", type));
  Film& f = scene_.film;
  f.defaulted = false;
  f.type_as_written = type;
  f.loc = d.loc;
  f.type = "rgb";
  if (type == "spectral") {
    spectralFilm(ps, f);
  } else if (type == "raw") {
    rawFilm(ps, f);
  } else if (type == "gbuffer") {
    // pbrt-v4's GBufferFilm::Create (src/pbrt/film.cpp): "coordinatesystem" "camera" (default)
    // or "world"; EXR output only (checked where the output is known).
    f.type = "gbuffer";
    f.gbuffer_coordinates = ps.getString({"coordinatesystem"}, "camera");
    if (f.gbuffer_coordinates != "camera" && f.gbuffer_coordinates != "world")
      throw Error(ps.peek({"coordinatesystem"})->loc,
                  fmt::format("\"coordinatesystem\": unknown coordinate system \"{}\" for the "
                              "gbuffer film; expected \"camera\" or \"world\"",
                              f.gbuffer_coordinates));
  } else if (type != "rgb" && type != "image")
    warnOnce(
        "film " + type, d.loc,
        fmt::format("film \"{}\" is not rendered by lensim; it renders as an \"rgb\" film", type));
  f.x_resolution = ps.getInt({"xresolution"}, f.x_resolution);
  f.y_resolution = ps.getInt({"yresolution"}, f.y_resolution);
  if (f.x_resolution <= 0 || f.y_resolution <= 0)
    throw Error(d.loc, fmt::format("film resolution {}x{} must be positive", f.x_resolution,
                                   f.y_resolution));
  // The film's buffers (accumulated XYZ and weights, then the RGB image): about 64 bytes a pixel.
  checkMemory(64.0 * f.x_resolution * f.y_resolution, d.loc,
              fmt::format("a {}x{} film", f.x_resolution, f.y_resolution));
  f.filename = ps.getString({"filename"}, f.filename);
  if (const Param* p = ps.find({"cropwindow"}, {ParamType::Float})) {
    ps.expectCount(*p, 4);
    f.crop_window = {p->numbers[0], p->numbers[1], p->numbers[2], p->numbers[3]};
  }
  if (const Param* p = ps.find({"pixelbounds"}, {ParamType::Integer})) {
    ps.expectCount(*p, 4);
    f.pixel_bounds = std::array<int, 4>{int(p->numbers[0]), int(p->numbers[1]), int(p->numbers[2]),
                                        int(p->numbers[3])};
  }
  f.scale = ps.getFloat({"scale"}, 1);  // pbrt-v3 image film
  f.diagonal_mm = ps.getFloat({"diagonal"}, 35);
  f.iso = ps.getFloat({"iso"}, 100);
  f.white_balance_k = ps.getFloat({"whitebalance"}, 0);
  // Ranges that keep the film's arithmetic finite (a NaN or 1e-300 here made every pixel NaN).
  if (!(f.iso > 0 && f.iso <= 1e7))
    throw Error(d.loc, fmt::format("film \"iso\" {} is out of range; expected (0, 1e7]", f.iso));
  if (f.white_balance_k != 0 && !(f.white_balance_k >= 1000 && f.white_balance_k <= 100000))
    throw Error(d.loc, fmt::format("film \"whitebalance\" {} K is out of range; expected 0 (none) "
                                   "or a colour temperature in [1000, 100000] K",
                                   f.white_balance_k));
  if (!(f.diagonal_mm > 0))
    throw Error(d.loc, fmt::format("film \"diagonal\" {} mm must be > 0", f.diagonal_mm));
  f.sensor = ps.getString({"sensor"}, "cie1931");
  checkSensor(ps, f);
  f.max_component_value = ps.getFloat({"maxcomponentvalue", "maxsampleluminance"}, 1e300);
  if (f.type == "raw") {
    // The pixel pitch from the film's diagonal and resolution unless given.
    if (f.raw_sensor.pixel_pitch_um == 0)
      f.raw_sensor.pixel_pitch_um =
          f.diagonal_mm * 1000 / std::hypot(double(f.x_resolution), double(f.y_resolution));
    f.raw_sensor.iso = f.iso;
    f.raw_sensor.validate(d.loc);
  }
  // pbrt-v4 (src/pbrt/film.cpp, RGBFilm::Create) defaults "savefp16" to true; lensim's
  // default is 32-bit float (docs/scene-support.md): only an explicit true writes half.
  f.save_fp16 = ps.getBool({"savefp16"}, false);
  ps.getBool({"display"}, false);  // pbrt-v2 image film: open a window
  if (f.x_resolution <= 0 || f.y_resolution <= 0)
    throw Error(d.loc, "film resolution must be positive");
  finish(ps);
}

void Builder::sampler(const Directive& d) {
  const std::string& type = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("Sampler \"{}\"", type));
  Sampler& s = scene_.sampler;
  s.defaulted = false;
  s.type_as_written = type;
  s.loc = d.loc;
  static const std::set<std::string> v4 = {"independent", "stratified", "halton", "sobol",
                                           "paddedsobol", "zsobol",     "pmj02bn"};
  s.seed = ps.getInt({"seed"}, 0);
  s.randomization = ps.getString({"randomization"}, "");
  if (!s.randomization.empty() && s.randomization != "none" && s.randomization != "permutedigits" &&
      s.randomization != "fastowen" && s.randomization != "owen")
    throw Error(ps.peek({"randomization"})->loc,
                fmt::format("sampler randomization \"{}\": expected \"none\", "
                            "\"permutedigits\", \"fastowen\" or \"owen\"",
                            s.randomization));
  ps.getBool({"samplepixelcenter"}, false);  // pbrt-v3 halton
  if (type == "stratified") {
    int x = ps.getInt({"xsamples"}, 4), y = ps.getInt({"ysamples"}, 4);
    s.jitter = ps.getBool({"jitter"}, true);
    // The product in 64 bits: 65536 x 65536 must not wrap around.
    const int64_t xy = int64_t{x} * int64_t{y};
    if (x <= 0 || y <= 0 || xy > kMaxSamplesPerPixel)
      throw Error(d.loc, fmt::format("stratified sampler: {} x {} samples per pixel; expected "
                                     "positive counts with a product of at most {}",
                                     x, y, kMaxSamplesPerPixel));
    s.pixel_samples = static_cast<int>(xy);
    s.type = type;
  } else if (v4.count(type)) {
    s.type = type;
    s.pixel_samples = ps.getInt({"pixelsamples"}, 16);
  } else if (type == "lowdiscrepancy" || type == "02sequence" || type == "bestcandidate" ||
             type == "maxmindist" || type == "random" || type == "adaptive") {
    // The pbrt-v4 equivalents its --upgrade uses.
    s.type = type == "random"                                  ? "independent"
             : type == "maxmindist" || type == "bestcandidate" ? "pmj02bn"
                                                               : "paddedsobol";
    s.pixel_samples = ps.getInt({"pixelsamples"}, 4);
    if (type == "adaptive") {
      s.pixel_samples = ps.getInt({"maxsamples"}, 32);
      ps.markAllUsed();
    }
    ps.getInt({"dimensions"}, 4);
    warnOnce("sampler " + type, d.loc,
             fmt::format("sampler \"{}\" (pbrt-v1–v3) renders as \"{}\" with {} samples per "
                         "pixel",
                         type, s.type, s.pixel_samples));
  } else {
    ps.markAllUsed();
    s.type = "zsobol";
    warnOnce(
        "sampler " + type, d.loc,
        fmt::format("sampler \"{}\" is not rendered by lensim; it renders as \"zsobol\"", type));
  }
  if (s.pixel_samples <= 0) throw Error(d.loc, "pixelsamples must be positive");
  if (s.pixel_samples > kMaxSamplesPerPixel)
    throw Error(d.loc, fmt::format("pixelsamples {} is too large; at most {} are taken",
                                   s.pixel_samples, kMaxSamplesPerPixel));
  finish(ps);
}

void Builder::filter(const Directive& d) {
  const std::string& type = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("PixelFilter \"{}\"", type));
  Filter& f = scene_.filter;
  f.defaulted = false;
  f.type_as_written = type;
  f.loc = d.loc;
  double def = type == "box"        ? 0.5
               : type == "gaussian" ? 1.5
               : type == "mitchell" ? 2
               : type == "triangle" ? 2
                                    : 4;
  f.type = type == "sinc" ? "lanczos" : type;
  f.x_radius = ps.getFloat({"xradius", "xwidth"}, def);
  f.y_radius = ps.getFloat({"yradius", "ywidth"}, def);
  if (type == "gaussian") {
    f.sigma = ps.getFloat({"sigma"}, 0.5);
    if (auto alpha = ps.findFloat({"alpha"}))  // pbrt-v2: exp(-alpha x^2) = exp(-x^2/(2 sigma^2))
      f.sigma = 1 / std::sqrt(2 * *alpha);
  } else if (type == "mitchell") {
    f.b = ps.getFloat({"B"}, 1.0 / 3);
    f.c = ps.getFloat({"C"}, 1.0 / 3);
  } else if (type == "sinc" || type == "lanczos") {
    f.tau = ps.getFloat({"tau"}, 3);
  } else if (type != "box" && type != "triangle") {
    ps.markAllUsed();
    f.type = "gaussian";
    warnOnce(
        "filter " + type, d.loc,
        fmt::format("filter \"{}\" is not rendered by lensim; it renders as \"gaussian\"", type));
  }
  finish(ps);
}

}  // namespace lensim::scene::detail
