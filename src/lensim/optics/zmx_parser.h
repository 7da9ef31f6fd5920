// The Zemax `.zmx` reader's parser (zmx.cpp: the file's lines and the prescription built from
// them; zmx_data.cpp: multi-configuration data, toroids, coordinate breaks). Private to those
// files; readers use parseZmx (lens_formats.h).
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lensim/optics/glass.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"

namespace lensim::optics::zmx_detail {

using Tok = LineField;

// A frame in lens units scaled to millimetres.
inline SurfaceFrame scaledFrame(SurfaceFrame f, double unit_mm) {
  for (double& c : f.origin_mm) c *= unit_mm;
  return f;
}

struct ZSurface {
  int number = 0;
  FileLoc loc;  // the SURF line
  std::string type = "STANDARD";
  FileLoc type_loc;
  double curv = 0;
  std::optional<double> disz;  // nullopt: INFINITY
  FileLoc disz_loc;
  bool has_disz = false;
  std::optional<double> diam;
  FileLoc diam_loc;
  bool stop = false;
  double conic = 0;
  std::map<int, double> parm;
  std::map<int, FileLoc> parm_loc;  // the value's place on each PARM line
  std::optional<FileLoc> xdat_loc;  // the first non-zero XDAT (extra data) value
  std::string glass;
  std::optional<double> n_d, v_d;
  FileLoc glass_loc;
  std::optional<double> clap_max;  // CLAP's maximum radius, or the circle around SQAP/ELAP's
  ApertureShape aperture_shape = ApertureShape::Circle;  // SQAP: Rectangle, ELAP: Ellipse
  double half_x = 0, half_y = 0;                          // their half-widths
  FileLoc aperture_loc;                                   // the SQAP/ELAP/CLAP line
  double inner_radius = 0;  // central obscuration (OBSC 0 r, or CLAP's minimum radius)
  FileLoc inner_loc;
  double obdc_x = 0, obdc_y = 0;  // OBDC: the aperture's (and obscuration's) decentre
  FileLoc obdc_loc;               // its first non-zero value
  // SCBD (the surface's own decentre and tilt before it) with non-zero values: decentre x, y,
  // tilt about x, y, z, and their places; read as a coordinate break before the image surface.
  std::optional<std::array<double, 5>> scbd;
  std::array<FileLoc, 5> scbd_loc;
  FileLoc scbd_line;
  bool mirror = false;
  std::string coating;  // COAT name
  FileLoc coating_loc;
  std::optional<SurfaceFrame> frame;  // a non-coaxial lens's placement (lens units)
};

class ZmxParser {
 public:
  ZmxParser(const std::string& path) : path_(path) {}

  LensPrescription parse(std::string_view bytes);

 private:
  double number(const Tok& t, int line, const char* what) const {
    double v = 0;
    const char* first = t.text.data();
    const char* last = first + t.text.size();
    if (first != last && *first == '+') ++first;
    auto [ptr, ec] = std::from_chars(first, last, v);
    if (ec != std::errc() || ptr != last || !std::isfinite(v))
      throw Error(FileLoc{path_, line, t.col},
                  fmt::format("expected a number for the {}, found '{}'", what, t.text));
    return v;
  }
  void need(const std::vector<Tok>& t, size_t n, int line, const char* what) const {
    if (t.size() < n)
      throw Error(FileLoc{path_, line, t.empty() ? 0 : t[0].col},
                  fmt::format("{} needs {} value{}, found {}", t[0].text, n - 1, n > 2 ? "s" : "",
                              t.size() - 1));
    (void)what;
  }

  // The place of PARM i's value, else the surface's TYPE line.
  FileLoc parmLoc(const ZSurface& z, int i) const {
    if (auto it = z.parm_loc.find(i); it != z.parm_loc.end()) return it->second;
    return z.type_loc.valid() ? z.type_loc : z.loc;
  }
  void readToroidal(const ZSurface& z, double unit_mm, SurfaceShape& shape) const;
  SurfaceGrating readGrating(const ZSurface& z) const;
  void resolveCoordinateBreaks(std::vector<ZSurface>& surfs, LensPrescription& p) const;

 public:
  // Multi-configuration data: `MNUM count active`, then one row per operand and configuration,
  // `OPERAND argument configuration value ...` (operand-major; the shape OpticStudio writes,
  // e.g. `THIC 5 2 25.27 0 0 0 1 1 1 0 0 "" 0`; `MOFF` rows are empty operand rows).
  struct McRow {
    std::string op;
    int arg = 0;
    int config = 1;
    std::string value;
    FileLoc loc, value_loc;
  };
  int mcCount() const { return mc_count_.value_or(1); }
  int mcActive() const { return mc_active_; }
  const FileLoc& mcLoc() const { return mc_loc_; }
  /// Parse with configuration `n`'s operand values applied over the surface data.
  void setConfiguration(int n) { apply_config_ = n; }
  const std::vector<McRow>& mcRows() const { return mc_rows_; }
  /// Where configuration `config`'s THIC operand for the surface whose SURF block starts at
  /// `surf_line` is written; the MNUM line when the file has no such operand.
  FileLoc mcThicknessLoc(int surf_line, int config) const;

 private:
  bool readMultiConfig(const std::vector<Tok>& t, int line_no);
  void applyMultiConfig(std::vector<ZSurface>& surfs, std::optional<double>& enpd,
                        std::optional<double>& fnum, bool floa, std::map<int, double>& wavm,
                        std::vector<double>& xf, std::vector<double>& yf) const;
  // The number of fields: FTYP's count, else as many as XFLN/YFLN list.
  int fieldCount() const {
    const int listed = int(std::max(xfln.size(), yfln.size()));
    return n_fields > 0 ? std::min(n_fields, listed) : listed;
  }
  void setFields(LensPrescription& p) const;

  std::optional<int> mc_count_;
  int mc_active_ = 1;
  FileLoc mc_loc_;
  std::vector<McRow> mc_rows_;
  std::optional<int> apply_config_;

  std::string path_;

  // One line's fields, its number and its first field's place.
  struct Line {
    const std::vector<Tok>& t;
    std::string_view text;
    int line_no;
    FileLoc loc;
  };
  double lineNumber(const Line& l, size_t i, const char* what) const {
    need(l.t, i + 1, l.line_no, what);
    return number(l.t[i], l.line_no, what);
  }
  // A count or index (surface, wavelength, parameter number): an integer in [-1e6, 1e6], so
  // that converting it to int is defined.
  int lineInt(const Line& l, size_t i, const char* what) const {
    const double v = lineNumber(l, i, what);
    if (v != std::floor(v) || std::abs(v) > 1e6)
      throw Error(FileLoc{path_, l.line_no, l.t[i].col},
                  fmt::format("expected an integer between -1000000 and 1000000 for the {}, "
                              "found '{}'",
                              what, l.t[i].text));
    return int(v);
  }
  Error surfaceError(const Line& l, const std::string& msg) const {
    return Error(l.loc, fmt::format("surface {}: {}", cur ? cur->number : -1, msg));
  }
  void systemLine(LensPrescription& p, const Line& l);
  void surfaceLine(const Line& l);
  bool apertureLine(const Line& l);
  void readSurfaceTilt();
  void finishSystemData(LensPrescription& p, int last_line);
  void buildSurfaces(LensPrescription& p);
  LensSurface makeSurface(const ZSurface& z, double semi, double ior_before,
                          const GlassSpec& glass_before);
  void checkExtent(const ZSurface& z, LensSurface& s, double& semi, bool auto_semi) const;
  void sizeStop(LensPrescription& p);
  void computeMissingSemiDiameters(LensPrescription& p);
  void readCoatingFile(LensPrescription& p);

  // The file as read so far: system data and surfaces.
  double unit_mm = 1;
  std::optional<double> enpd, fnum, obna;
  bool floa = false;
  FileLoc aperture_loc;
  std::map<int, double> wavm;  // index -> micrometres
  std::vector<double> wavl;
  std::vector<std::string> gcat;  // GCAT: glass catalogues, lower case, in search order
  std::optional<int> pwav;
  std::optional<int> n_waves;
  // Fields (FTYP type and count, XFLN/YFLN values) and ray aiming, for automatic semi-diameters.
  int field_type = 0, n_fields = 0;
  FileLoc field_loc;
  std::vector<double> xfln, yfln;
  std::optional<FileLoc> vignetting_loc, ray_aiming_loc;
  std::vector<ZSurface> surfs;
  ZSurface* cur = nullptr;
  bool sequential_seen = false;
  std::string cofn;
  FileLoc cofn_loc;
  // What building the surface rows leaves for the steps after it.
  int stop_surface = -1;
  std::vector<std::pair<int, const ZSurface*>> auto_rows;  // row in p.surfaces, its surface
  // Whether the n_d on the file's GLAS lines are the glasses' data: catalogue glasses checked,
  // those whose n_d disagrees with the catalogue, and the unknown names that fall back on them.
  int glas_checked = 0, glas_disagree = 0;
  std::string glas_example;
  std::vector<std::pair<std::string, FileLoc>> glas_fallbacks;
  std::optional<double> epd_mm;
};

/// Zemax focus positions (zmx_focus.cpp): when the configurations read into `p` differ in the
/// object distance (THIC 0) and move lens gaps without changing the lens's length, they become
/// `p.focus_group` (gaps in fixed ratios) or `p.floating_focus` (at different rates) over the
/// infinity configuration; ambiguous files are refused at the operand's line. Other
/// multi-configuration files are left as they are.
void readFocusPositions(const ZmxParser& base, LensPrescription& p);

}  // namespace lensim::optics::zmx_detail
