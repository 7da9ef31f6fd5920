// Lens design jobs: a starting lens, variables with bounds, and a merit function of weighted
// operands, as a JSON file (docs/design-job.schema.json, docs/design.md), optimised by damped
// least squares (levenberg_marquardt.h).
//
// Every operand is computed by the workbench's own code on the lens the variables describe:
// paraxial data (paraxial.h), real chief rays (chief_ray.h) and exact traces of hexapolar pupil
// samples (field_rays.h) for RMS spots. Objects are at infinity; fields are angles (degrees).
// During optimisation the clear apertures of every surface but the stop float (they are doubled,
// within the surface's extent) and spot rays are not clipped: the paraxial entrance pupil, aimed at
// the real chief ray, defines each beam, so the merit is smooth in the variables.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"
#include "lensim/util/vec.h"

namespace lensim::optics::design {

/// One optimisation variable: a number of the prescription, with bounds.
struct Variable {
  /// StopPosition: the stop row's distance behind the row before it, the gap between those
  /// two rows' neighbours kept (the stop slides between them; `surface` is the stop row).
  enum class Kind { Curvature, Thickness, Conic, Asphere, GlassIndex, GlassAbbe, StopPosition };
  Kind kind = Kind::Curvature;
  int surface = 0;  ///< 0-based row of the prescription
  int power = 0;    ///< Asphere: the power p of r^p
  double gap_mm = 0;  ///< StopPosition: the thicknesses before and after the stop, summed
  double lower = -1e300, upper = 1e300;
  FileLoc loc;
};
/// "curvature", "thickness", "conic", "asphere", "glass_nd", "glass_vd", "stop_position".
const char* variableKindName(Variable::Kind k);

/// One operand of the merit function: residual weight (value - target), or for limits the
/// weighted amount by which the value leaves [min, max].
struct Operand {
  enum class Kind {
    Efl,                ///< paraxial effective focal length (mm)
    FNumber,            ///< paraxial f-number at infinity
    Bfl,                ///< paraxial back focal length (mm)
    TotalTrack,         ///< front vertex to film (mm)
    RmsSpot,            ///< RMS spot radius (mm) at a field and wavelength on the film
    Distortion,         ///< 100 (h - f tan theta) / (f tan theta), %, at a field
    LateralColor,       ///< chief-ray image height at F minus at C (mm), at a field
    LongitudinalColor,  ///< paraxial back focus at F minus at C (mm)
    Thickness,          ///< centre thickness after a surface (mm), a limit
    ImageHeight,        ///< real chief-ray image height (mm) at a field
    RmsWavefront,       ///< RMS wave aberration (waves), tilt removed, at a field and wavelength
    Mtf,  ///< diffraction MTF at a frequency, field and azimuth (wavelength, or all polychromatic)
    /// Thickness after a surface at the edge (mm), a limit: at the larger of its and the next
    /// row's semi-apertures, along y, the thickness plus the next row's sag minus its own.
    EdgeThickness,
    /// The largest real ray height (mm) at a surface over the rims of the job's field beams
    /// (primary wavelength, the beams' passing pupils), a limit (default max: the surface's
    /// semi-aperture as written).
    ClearAperture,
  };
  Kind kind = Kind::Efl;
  double target = 0;
  double weight = 1;
  std::optional<double> min, max;  ///< limits instead of a target
  double field_deg = 0;
  double wavelength_nm = 0;  ///< RmsSpot, RmsWavefront, Mtf (0: Mtf over every wavelength)
  int surface = 0;           ///< Thickness, EdgeThickness, ClearAperture
  double frequency = 0;      ///< Mtf, cycles/mm
  bool sagittal = false;     ///< Mtf: sagittal (else tangential)
  FileLoc loc;
  /// "efl", "rms_spot(field 14 deg, 486.1 nm)", ...
  std::string label() const;
};
const char* operandKindName(Operand::Kind k);

/// A tolerance of the tolerancing section.
struct Tolerance {
  enum class Kind { Radius, Thickness, Index, Abbe, Irregularity, DecentreX, DecentreY, TiltX, TiltY };
  enum class Distribution { Uniform, Normal, EndPoint };
  Kind kind = Kind::Radius;
  int surface = 0;
  /// Decentre and tilt: the last row moved with `surface` (the element's last surface for an
  /// element tolerance, `surface` itself for a surface tolerance).
  int last_surface = 0;
  /// +- range: radius, thickness and decentre in mm, tilt in degrees, index and Abbe number
  /// absolute, irregularity in fringes at test_wavelength_nm
  double delta = 0;
  /// Irregularity: the test wavelength of the fringes (OpticStudio's TWAV; 632.8 nm default).
  double test_wavelength_nm = 632.8;
  Distribution distribution = Distribution::Uniform;
  FileLoc loc;
  /// Decentre or tilt: the build is no longer coaxial (optics/placed_lens.h traces it).
  bool moves() const { return kind >= Kind::DecentreX; }
  std::string label() const;
};

/// The tolerancing section of a job.
struct ToleranceSpec {
  std::vector<Tolerance> tolerances;
  /// The criterion: RMS spot radius (mm) averaged (RMS) over the job's fields and wavelengths,
  /// "boresight" (how far the image of the on-axis object point, where the primary wavelength's
  /// real chief ray meets the film, lies from the nominal lens's, mm) or a single operand kind's
  /// value ("efl", "bfl", ...).
  std::string criterion = "rms_spot";
  /// Criterion "mtf": the diffraction MTF at `mtf_frequency` cycles/mm (the wavelengths' OTFs
  /// summed, as the mtf operand), averaged over the job's fields and, unless one is named, over
  /// the tangential and sagittal azimuths ("both", "tangential", "sagittal").
  double mtf_frequency = 0;
  std::string mtf_azimuth = "both";
  bool back_focus_compensator = true;
  int monte_carlo = 100;
  std::uint64_t seed = 1;
};

struct DesignJob {
  std::string path;
  std::string lens_path;  ///< the starting lens: its file (resolved) or catalogue name
  LensPrescription start;
  std::vector<double> wavelengths_nm;  ///< the first is the primary
  std::vector<double> fields_deg;
  int rings = 6;  ///< hexapolar rings per RMS spot
  std::vector<Variable> variables;
  std::vector<Operand> operands;
  bool snap_glass = true;
  int max_iterations = 50;
  /// Global search ("global": {"starts", "seed"}): multi-start damped least squares
  /// (multiStartLevenbergMarquardt); starts 1 is the plain local run.
  int global_starts = 1;
  std::uint64_t global_seed = 1;
  ToleranceSpec tolerance;
};

/// Parses a design job; the lens is a path relative to the job's folder or a catalogue name.
/// Throws lensim::Error at `path:line:col` for anything malformed or out of range.
DesignJob parseDesignJob(std::string_view text, const std::string& path);
DesignJob readDesignJob(const std::string& path);

/// The variables' current values in a prescription.
std::vector<double> variableValues(const std::vector<Variable>& vars, const LensPrescription& p);
/// Writes the values into a copy of the prescription (a glass variable makes the medium a
/// model glass from its n_d and V_d).
LensPrescription applyVariables(const std::vector<Variable>& vars, LensPrescription p,
                                const std::vector<double>& x);

/// The operands' values for a prescription. Throws lensim::Error when the lens cannot be
/// evaluated (afocal, a chief ray that does not exist, ...).
std::vector<double> operandValues(const DesignJob& job, const LensPrescription& p);
/// weight (value - target), or weight times the excess over a limit.
double operandResidual(const Operand& o, double value);

/// RMS spot radius (mm) of the beam at field_deg and lambda_nm on the film of p (objects at
/// infinity; paraxial entrance pupil aimed at the primary wavelength's real chief ray; rays not
/// clipped by apertures), the hexapolar quadrature of `rings` rings.
double rmsSpot_mm(const LensPrescription& p, double field_deg, double lambda_nm,
                  double primary_nm, int rings);
/// The same beam's spot as a function of a shift dz (mm, +z) of the film: the mean square radius
/// about the centroid is a + 2 b dz + c dz^2 (rays are straight lines behind the lens).
struct SpotQuadratic {
  double a = 0, b = 0, c = 0;
};
SpotQuadratic spotQuadratic(const LensPrescription& p, double field_deg, double lambda_nm,
                            double primary_nm, int rings);
/// The spot quadratic of a beam traced by `land`: the ray through the pupil-plane point at
/// `offset` from the chief ray's, its hit on the film and its slopes d(x, y)/dz there; false
/// when it does not reach the film. The beam is the part of the paraxial entrance pupil
/// (`pupil_radius_mm`) whose rays land (passingPupil, image_quality.h), sampled by `rings`
/// hexapolar rings; the coaxial and the placed evaluations trace it their own way.
using LandFn = std::function<bool(Vec2 offset, Vec2& hit, Vec2& slope)>;
SpotQuadratic beamSpot(double pupil_radius_mm, double field_deg, int rings, const LandFn& land);

struct DesignResult {
  LensPrescription lens;
  double initial_merit = 0, merit = 0;
  int iterations = 0, evaluations = 0;
  std::string stop_reason;
  std::vector<double> values;      ///< operands at the end
  std::vector<std::string> snapped;  ///< "surface 1: model 1.62/58 -> schott:N-SK16"
};

/// Optimises the job's lens; `log` receives a line per iteration (merit, the three largest
/// operand contributions) and a line per glass snapped. With glass variables and snap_glass,
/// the model glasses are replaced by the nearest catalogue glasses and the rest re-optimised.
DesignResult optimiseDesign(const DesignJob& job,
                            const std::function<void(const std::string&)>& log = {});

}  // namespace lensim::optics::design
