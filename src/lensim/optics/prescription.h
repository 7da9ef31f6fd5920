// Lens prescriptions: the `.dat` tables of pbrt's realistic camera and their variants.
//
// Accepted layouts (all millimetres, one surface per row, front (scene side) to back (film side)):
// - pbrt (the four classic lenses): `radius thickness index aperture`; thickness is the distance
//   to the NEXT surface, the last row's thickness is the lens-to-film distance (0: focus decides).
// - ISET (ISETCam's `data/lens/*.dat`): one line with the focal length (a single number) before
//   the surface rows; the rows are as in the pbrt layout.
// - axpos (older pbrt-v4-scenes tables at 100 mm scale): column 2 is the distance from the
//   PREVIOUS surface, so the first row's value is 0. A file whose first row has thickness 0 (and
//   that has more than one row, the first not being the stop) is read in this layout, with a note.
// Optional columns (any layout): a fifth, the Abbe number V_d of the medium after the surface
// ('-' for none), and a sixth, its catalogue glass name ("N-BK7", "schott:N-BK7"); a row with
// V_d alone is a model glass through (index, V_d); rows without them do not disperse.
// Radius 0 is the aperture stop (a plane disc); index 0 means air; `#` starts a comment;
// spaces or tabs separate columns; CR, LF and CRLF line endings are all accepted.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lensim/optics/surface_shape.h"
#include "lensim/util/error.h"

namespace lensim::optics {

/// The table layout a prescription was read in.
enum class LensFileLayout { Pbrt, Iset, Axpos };

const char* layoutName(LensFileLayout layout);

/// The medium after a surface as the lens file names it. Readers fill what the file says; the
/// glass module resolves it to n(lambda) (catalogue name -> dispersion formula; n_d and V_d ->
/// model glass; neither -> the constant `LensSurface::ior`).
struct GlassSpec {
  std::string name;           ///< catalogue name as written ("N-BK7", "schott:N-BK7"); empty: none
  std::optional<double> n_d;  ///< index at the d line (587.56 nm), when the file gives it
  std::optional<double> v_d;  ///< Abbe number V_d, when the file gives it
  FileLoc loc;                ///< where the glass is named (for errors about it)
  /// Catalogues to search first, in order (a Zemax file's GCAT line); the rest follow.
  std::vector<std::string> catalogs;
  /// A Zemax GLAS line: its n_d and V_d are often placeholders, so a name in no catalogue becomes
  /// the model glass of them only with --model-glass (glass/library.h); elsewhere (lensim JSON,
  /// lentil, .dat) n_d and V_d are the lens's data and make the model glass with a warning.
  bool model_needs_option = false;

  bool empty() const { return name.empty() && !v_d; }
};

/// One refracting surface (or the stop), as written in the file. Lengths in millimetres.
/// The outline of a surface's clear aperture. Circle: the semi-aperture (and the obscuration
/// radius); Rectangle (Zemax `SQAP`): |x| <= half_x, |y| <= half_y; Ellipse (Zemax `ELAP`):
/// (x / half_x)^2 + (y / half_y)^2 <= 1; both centred on the axis.
enum class ApertureShape { Circle, Rectangle, Ellipse };

/// Whether the point (x, y) of a surface lies inside a Rectangle or Ellipse aperture (true for
/// Circle: the semi-aperture test is the caller's).
template <typename T>
inline bool insideApertureShape(ApertureShape shape, T half_x, T half_y, T x, T y) {
  if (shape == ApertureShape::Rectangle) return std::abs(x) <= half_x && std::abs(y) <= half_y;
  if (shape == ApertureShape::Ellipse) {
    const T u = x / half_x, v = y / half_y;
    return u * u + v * v <= T(1);
  }
  return true;
}

/// A surface's place in space in a non-coaxial lens (tilted or decentred surfaces): the columns
/// of `rotation` are its local x, y, z axes and `origin_mm` its vertex, both in the frame of the
/// front surface (mm; z its axis, the light arriving from -z).
struct SurfaceFrame {
  std::array<std::array<double, 3>, 3> rotation{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  std::array<double, 3> origin_mm{};
};

/// A diffraction grating ruled on a surface (Zemax `TYPE DGRATING`, the OpticStudio "Diffraction
/// Grating" surface): its lines are the traces on the surface of equally spaced planes parallel
/// to the surface's local x-z plane, `lines_per_um` of them per micrometre along local y
/// (whatever the lens units), and the ray leaves in diffraction order `order`. At a hit point
/// with unit normal N the tangential part of n s gains order * lambda_um * lines_per_um times
/// (y - (y . N) N), local y projected into the tangent plane (optics/grating.h).
struct SurfaceGrating {
  double lines_per_um = 0;
  int order = 0;
  FileLoc loc;  ///< the TYPE line
};

struct LensSurface {
  double radius_mm = 0;     ///< signed radius of curvature; > 0: centre toward the film
  double thickness_mm = 0;  ///< axial distance to the next surface (last row: to the film)
  double ior = 1;           ///< index of refraction of the medium after the surface (0 -> 1)
  double aperture_diameter_mm = 0;  ///< clear aperture diameter
  GlassSpec glass;                  ///< the glass after the surface, when the file names one
  FileLoc loc;                      ///< where the row is in the file
  /// Conic, aspheric or cylindrical shape beyond the base sphere (Zemax, JSON readers); the
  /// default is the sphere of radius_mm.
  SurfaceShape shape;
  /// Readers that mark the aperture stop explicitly (Zemax STOP, JSON) set this, so that a plane
  /// surface need not be the stop; unset (.dat): the radius-0 row is the stop.
  std::optional<bool> stop_flag;
  /// A mirror (Zemax `GLAS MIRROR`, JSON `"mirror": true`): the surface reflects, and the ray
  /// travels back along the axis. The medium after it is the one before (ior and glass repeat
  /// it), and the thickness after it is negative after an odd number of mirrors (Zemax's sign
  /// convention: thicknesses are signed z distances).
  bool mirror = false;
  /// Central obscuration: rays meeting the surface closer than this to the axis are blocked (a
  /// catadioptric lens's secondary mirror or the hole in its primary; Zemax `OBSC 0 r`, the
  /// inner radius of `CLAP rmin r`). 0: none.
  double obscuration_radius_mm = 0;
  /// A rectangular or elliptical aperture (Zemax SQAP, ELAP) with these half-widths; the
  /// semi-aperture is then the radius of the circle around it.
  ApertureShape aperture_shape = ApertureShape::Circle;
  double aperture_half_x_mm = 0, aperture_half_y_mm = 0;
  /// The centre of the aperture and of the obscuration in the surface's own x, y (Zemax OBDC,
  /// an off-axis mirror's clear aperture): the tests are made at (x - dx, y - dy). Non-zero only
  /// on a lens placed in space (`frame` set): the coaxial tracers refuse it.
  std::array<double, 2> aperture_decentre_mm{};
  /// The coating on this surface as the file names it (JSON "coating", Zemax COAT); empty: the
  /// lens-wide default on an air-glass surface, none on a cemented one (coating/lens_coatings.h).
  std::string coating;
  FileLoc coating_loc;
  /// Its place in space when the lens is not coaxial (LensPrescription::noncoaxial_loc); unset
  /// otherwise (the vertex on the axis, thickness_mm after the previous one).
  std::optional<SurfaceFrame> frame;
  /// A grating on this surface; a lens with one is not rotationally symmetric and is traced by
  /// the non-coaxial tracer only (LensPrescription::noncoaxial_loc is set).
  std::optional<SurfaceGrating> grating;

  bool isStop() const { return stop_flag ? *stop_flag : radius_mm == 0; }
  double semiAperture_mm() const { return aperture_diameter_mm / 2; }
  bool apertureDecentred() const {
    return aperture_decentre_mm[0] != 0 || aperture_decentre_mm[1] != 0;
  }
  /// The farthest any point of the clear aperture lies from the surface's axis (mm): the
  /// semi-aperture, moved out by the decentre (the rectangle's farthest corner exactly; an
  /// ellipse's bound |decentre| + its larger half-width).
  double apertureReach_mm() const;
};

/// The fields a lens file lists for its design (Zemax FTYP with XFLN/YFLN; per configuration
/// the XFIE/YFIE operands). Reported as the file gives them (lens info); lensim's own field of
/// view comes from the film, not from these.
struct FileFields {
  enum class Kind { Angle, ObjectHeight, ParaxialImageHeight, RealImageHeight };
  Kind kind = Kind::Angle;
  /// (x, y) per field: degrees for angles, mm for heights.
  std::vector<std::pair<double, double>> xy;
  FileLoc loc;  ///< the FTYP (or first XFLN/YFLN) line
};

/// A point of `s`'s clear aperture (its own x, y, mm) where the sag is not defined (beyond the
/// surface's extent), or nullopt when the sag is defined over the whole aperture. Rotationally
/// symmetric shapes: the disc of sagDomainRadius against apertureReach_mm. Toroids and
/// biconics, defined out to a different distance in each direction (a cylinder: any x): the
/// sag is tested along the aperture's outline (every region where it is undefined reaches out
/// to infinity, so it would cross the outline), at 4096 points and the outline's extremes.
std::optional<std::array<double, 2>> apertureOutsideSag(const LensSurface& s);

/// One configuration of a multi-configuration lens (a zoom position, a focus position): the
/// whole surface table as it is in that configuration (rows match LensPrescription::surfaces one
/// to one), with the configuration's system data.
struct LensConfiguration {
  std::vector<LensSurface> surfaces;
  std::string aperture_spec;  ///< the system aperture in this configuration, when stated
  std::optional<double> object_distance_mm;  ///< unset: infinity or not given
  std::vector<double> wavelengths_nm;        ///< empty: the prescription's
  std::optional<FileFields> fields;          ///< unset: the file lists none
  FileLoc loc;  ///< where the configuration (or its first operand) is written
};

/// A lens prescription read from a file: surfaces front to back and what was noticed about them.
struct LensPrescription {
  std::string path;  ///< the file it came from
  std::string name;  ///< first comment line, or the file name without extension
  LensFileLayout layout = LensFileLayout::Pbrt;
  std::optional<double> nominal_focal_length_mm;  ///< ISET files state it
  /// Wavelengths the file lists (Zemax WAVL) and its primary one (PWAV), in nanometres; empty and
  /// unset when the file gives none (the workbench then uses the d line, 587.56 nm).
  std::vector<double> wavelengths_nm;
  std::optional<double> primary_wavelength_nm;
  std::vector<LensSurface> surfaces;
  /// The file format it was read from: "dat", "zmx", "lentil", "iset-json" or "lensim-json".
  std::string format = "dat";
  /// Object distance from the front vertex the file gives (Zemax object thickness); unset:
  /// infinity or not given.
  std::optional<double> object_distance_mm;
  /// The file's system aperture, when it states one (Zemax ENPD / FNUM): the stop diameter has
  /// already been set from it; kept for reports.
  std::string aperture_spec;
  /// The design fields the file lists (Zemax FTYP, XFLN/YFLN); unset: none.
  std::optional<FileFields> fields;
  /// The coating of the air-glass surfaces that name none (JSON top-level "coating":
  /// "uncoated", "single", "multi" or a coating file's name); empty: uncoated.
  std::string default_coating;
  FileLoc default_coating_loc;
  /// A Zemax coating file (COATING.DAT syntax) defining further coating names, resolved against
  /// the lens file's folder (JSON "coating_file", Zemax COFN); empty: none.
  std::string coating_file;
  FileLoc coating_file_loc;

  /// Multi-configuration data (Zemax MNUM and its operands, lensim JSON "configurations"):
  /// every configuration's surfaces; empty for a lens with one configuration.
  /// `surfaces` holds the active one (`active_configuration`, 1-based) as the file stores it.
  std::vector<LensConfiguration> configurations;
  int active_configuration = 1;
  /// Group focusing (lensim JSON "focus_group"): surface row -> rate; moving the group by x mm
  /// changes that row's thickness by rate * x (an inner group: +1 on the gap before it, -1 on
  /// the gap after). Empty: the whole lens moves to focus (unit focusing). focusLens solves x.
  std::vector<std::pair<int, double>> focus_group;
  /// Floating focus (Zemax focus positions whose gaps move at different rates): the moved rows'
  /// thicknesses at each of the file's focus positions, by the position's object vergence
  /// (1000 / d dioptres, d the file's object distance from the front vertex; 0: infinity), in
  /// increasing vergence. Between positions every thickness is piecewise linear in the
  /// vergence; focusLens solves the vergence parameter within the file's range. `surfaces`
  /// holds the infinity position.
  struct FloatingFocus {
    std::vector<int> rows;
    std::vector<double> vergence_dpt;
    std::vector<std::vector<double>> thickness_mm;  ///< [position][k]: rows[k]'s thickness
    FileLoc loc;                                    ///< the MNUM line
  };
  std::optional<FloatingFocus> floating_focus;
  /// Set when the file folds its axis with coordinate breaks and plane mirrors (Zemax
  /// COORDBRK, optics/coordinate_break.h): the first break. `surfaces` then holds the coaxial
  /// twin, whose first-order data and aberrations are the fold's; the image in space is the
  /// twin's turned and mirrored, which the renderer does not model (it refuses such a lens).
  std::optional<FileLoc> fold_loc;
  /// Set when surfaces are tilted or decentred so that no single axis holds them (Zemax
  /// COORDBRK): where that starts. Every surface then has its `frame`, and `image_frame` is the
  /// image surface's; thicknesses are the file's and do not place anything. Only the
  /// non-coaxial tracer (optics/placed_lens.h) models such a lens: LensSystem refuses it.
  std::optional<FileLoc> noncoaxial_loc;
  std::string noncoaxial_reason;  ///< why (for messages)
  SurfaceFrame image_frame;
  /// Warnings and notes (crossing surfaces, layout guesses); errors are thrown instead.
  std::vector<Diagnostic> diagnostics;

  /// Index of the radius-0 row, if the file has one.
  std::optional<int> stopIndex() const;
  /// The last row's thickness: the lens-to-film distance the file gives (0 when it gives none).
  double fileFilmDistance_mm() const { return surfaces.empty() ? 0 : surfaces.back().thickness_mm; }
};

/// The first surface with a diffraction grating, or nullptr.
inline const LensSurface* firstGrating(const LensPrescription& p) {
  for (const LensSurface& s : p.surfaces)
    if (s.grating) return &s;
  return nullptr;
}

/// Parses prescription text; `path` is used for messages. Throws lensim::Error
/// (`path:line:col: error: ...`) for malformed input.
LensPrescription parseLensPrescription(std::string_view text, const std::string& path);

/// Reads and parses a lens file in any format lensim reads, chosen by extension (.zmx Zemax,
/// .json lensim/ISET3d/lentil, else the .dat table), or a catalogue name (`lentil:0003`,
/// `lenses:NAME`; see lens_formats.h). Throws lensim::Error when it cannot be read or is
/// malformed.
LensPrescription readLensFile(const std::string& path);

/// The largest lens file read (a real prescription has at most a few hundred rows).
inline constexpr uint64_t kMaxLensFileBytes = uint64_t{16} << 20;
/// The most surfaces a prescription may have.
inline constexpr size_t kMaxLensSurfaces = 10000;

/// Sag of a spherical surface at height h: axial distance from the vertex plane (mm), signed
/// toward +z. Zero for a plane (radius 0). Requires |h| <= |radius|.
double sphericalSag(double radius_mm, double h_mm);

}  // namespace lensim::optics
