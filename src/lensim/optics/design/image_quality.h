// Image-quality operands of a design job that need the wavefront: the RMS wavefront error and
// the diffraction MTF at one frequency, per field angle (objects at infinity), computed by the
// workbench's pupil-function code (wavefront.h) on the lens the design variables describe.
#pragma once

#include <vector>

#include "lensim/optics/field_rays.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/prescription.h"

namespace lensim::optics::design {

/// Every clear aperture but the stop's doubled, within the surface's extent (the optimiser's
/// floating apertures).
void floatApertures(LensPrescription& p);

/// The lens the operands are evaluated on: every clear aperture but the stop's doubled (within
/// the surface's extent), the film at the last thickness, focused at infinity.
FocusedLens evaluationLens(LensPrescription p);

/// The beam from infinity at field_deg: the primary wavelength's real chief ray (through the
/// stop centre, apertures ignored) and the paraxial entrance pupil about where it crosses the
/// entrance-pupil plane. Throws lensim::Error when there is no real chief ray.
FieldBundle fieldBundle(const LensSystem& primary, const ParaxialData& pp, double field_deg);

/// RMS wave aberration (waves at lambda_nm) of the beam at field_deg on the film of p, about
/// the best-fitting reference sphere centred on the film: piston and tilt removed, i.e. the
/// reference follows the image point's lateral shift but not a focus shift. Weighted uniformly
/// over the exit pupil in image-space direction cosines (wavefront.h), on a fixed 64-cell grid
/// (W itself is traced per ray, so the grid does not alias it).
double rmsWavefront_waves(const LensPrescription& p, double field_deg, double lambda_nm,
                          double primary_nm);

/// Diffraction MTF of the beam at field_deg at `frequency` cycles/mm, tangential (along the
/// meridional direction, x) or sagittal (y), the modulus of the OTFs of the wavelengths summed
/// with equal weights (one wavelength: monochromatic). The pupil grid is refined from 128 cells
/// (to 512) until W changes by less than a quarter wave between neighbouring cells.
double mtfAt(const LensPrescription& p, double field_deg, const std::vector<double>& lambdas_nm,
             double primary_nm, double frequency, bool sagittal);

}  // namespace lensim::optics::design
