// Tolerancing: how a design degrades when built. Each tolerance (radius, thickness, index, Abbe
// number of one surface or medium; decentre and tilt of an element or a surface) is applied
// alone at its +- limits (the sensitivity table), then all at once, drawn from their
// distributions, for N Monte Carlo builds.
//
// The criterion is the RMS spot radius over the job's fields and wavelengths (the root of the
// mean of the squared RMS radii), the boresight (the on-axis image point's shift on the film)
// or a first-order quantity (efl, bfl, ...). The back-focus
// compensator moves the film to the plane that minimises the RMS-spot criterion: the squared
// spot radius is a quadratic in the film shift (rays are straight behind the lens), so the
// optimum is exact, not searched.
//
// Distributions over [-delta, delta]: uniform; normal with sigma = delta / 2, truncated at
// +-delta; end_point: -delta or +delta with equal chance. Builds draw from a 64-bit Mersenne
// Twister seeded by (seed, build index) through splitmix64, with the conversions written here
// (not the standard library's distributions, whose output is implementation-defined), so a seed
// gives the same builds on every platform and thread count.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lensim/optics/design/design_job.h"
#include "lensim/util/vec.h"

namespace lensim::optics::design {

/// Whether the job's lenses are evaluated by the non-coaxial tracer (a decentre or tilt
/// tolerance, or the boresight criterion): the nominal lens too, so that every change is
/// measured by one method.
bool placedTolerancing(const DesignJob& job);

/// The job's lens as toleranced (placed on its axis when placedTolerancing): media with index or Abbe tolerances become the model glasses
/// through their (n_d, V_d), so that a zero offset changes nothing.
LensPrescription toleranceNominal(const DesignJob& job);

/// Surface irregularity of `fringes` fringes (signed) at the test wavelength, as OpticStudio's
/// TIRR counts them (a double-pass test: a fringe is half a wavelength of sag) and splits them:
/// half spherical, half astigmatic, each A = fringes * lambda_t / 4 of sag at the rim, where h is
/// the surface's clear semi-aperture. The spherical half adds A (r/h)^4 to the sag exactly (the
/// r^4 polynomial term). The astigmatic half makes the surface a biconic whose y section's vertex
/// curvature is larger by 2A/h^2, its x section unchanged: its sag departs from the nominal by
/// A (y/h)^2 along y to lowest order (OpticStudio's form), plus (3/4)(c h)^2 A (y/h)^4 and higher
/// terms from the base curvature c; it is the surface with two principal curvatures that
/// astigmatic polishing errors are, expressible in every lens format lensim writes. The surface
/// must be rotationally symmetric.
void applyIrregularity(LensSurface& s, double fringes, double test_wavelength_nm);

/// A prescription with the tolerance applied at offset `value` (radius mm, thickness mm, index,
/// Abbe number, irregularity fringes, decentre mm, tilt degrees). Index and Abbe tolerances make the medium a model
/// glass through the perturbed (n_d, V_d). A decentre or tilt places the lens on its axis first
/// (placeOnAxis) and moves its rows about the first row's vertex (moveRows); a thickness change
/// of a placed lens moves the rows behind it along the row's axis.
LensPrescription applyTolerance(LensPrescription p, const Tolerance& t, double value);

/// The criterion of a lens (see above), with the film moved by the compensator when enabled;
/// `film_shift_mm` receives that shift (0 without compensator). A placed lens (or the boresight
/// criterion) is traced by the non-coaxial tracer (placed_build.h), the film shifted along the
/// image surface's axis. `field_rms_mm` receives the RMS spot radius of each field (over the
/// wavelengths) on that film (rms_spot and boresight criteria; empty otherwise).
double toleranceCriterion(const DesignJob& job, const LensPrescription& p,
                          double* film_shift_mm = nullptr,
                          std::vector<double>* field_rms_mm = nullptr);

/// What the criterion measures every lens of a run against, from the nominal lens: for the
/// boresight criterion the nominal on-axis image point on its compensated film (nothing for
/// the others). runTolerancing computes it once, before its parallel loops, and every
/// evaluation reads it; it is immutable, so sharing it between threads is safe.
struct CriterionReference {
  bool has_boresight = false;
  Vec2 boresight;  ///< mm, on the nominal lens's (placed) image surface
};
CriterionReference criterionReference(const DesignJob& job);

/// toleranceCriterion against a reference computed once (criterionReference(job)): the same
/// value, without tracing the nominal lens again for each evaluation.
double toleranceCriterion(const DesignJob& job, const LensPrescription& p,
                          const CriterionReference& ref, double* film_shift_mm = nullptr,
                          std::vector<double>* field_rms_mm = nullptr);

/// The draw of one tolerance for build `build` (reproducible, see above): an offset in
/// [-delta, delta].
double drawTolerance(const Tolerance& t, std::uint64_t seed, int build, int index);

struct SensitivityRow {
  std::string label;
  double plus = 0, minus = 0;  ///< criterion change at +delta and -delta
  /// RMS spot radius (mm) of each job field at +delta and -delta (see toleranceCriterion)
  std::vector<double> fields_plus, fields_minus;
};

struct ToleranceResult {
  double nominal = 0;
  std::vector<double> nominal_fields;  ///< RMS spot radius (mm) of each job field, nominal lens
  std::vector<SensitivityRow> sensitivity;
  /// Root-sum-square of the larger change of each row: the linear estimate of the worst case
  /// spread.
  double rss_change = 0;
  std::vector<double> builds;  ///< the criterion of every Monte Carlo build, in build order
  double mean = 0, stddev = 0, p10 = 0, p50 = 0, p90 = 0, worst = 0;
};

/// Runs the sensitivity table and the Monte Carlo builds (in parallel).
ToleranceResult runTolerancing(const DesignJob& job);

/// As-built lens number `build` (0-based) of the Monte Carlo run, compensator applied (a
/// placed lens when the job decentres or tilts).
LensPrescription asBuiltLens(const DesignJob& job, int build);

}  // namespace lensim::optics::design
