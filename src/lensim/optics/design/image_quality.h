// Image-quality operands of a design job that need the wavefront: the RMS wavefront error and
// the diffraction MTF at one frequency, per field angle (objects at infinity), computed by the
// workbench's pupil-function code (wavefront.h) on the lens the design variables describe.
#pragma once

#include <functional>
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

/// The part of the beam's paraxial entrance pupil (a disc of `radius_mm` about the chief ray)
/// whose rays reach the film, star-shaped about the chief ray. When the rim passes along every
/// one of `directions` equally spaced azimuths, the disc itself (four equal radii: the plain
/// circle's quadrature, so operands are unchanged where nothing is lost). Otherwise, along each
/// azimuth, the distance to the first lost of 16 points out to the rim, bisected to 1e-12 of the
/// radius (the rim where none is lost): the region shrinks continuously as rays start to be
/// lost, so merit functions stay continuous. Rays are lost where they miss a surface's sphere or
/// are totally reflected: with floating apertures the beam of a wide field can be larger than
/// the lens passes (OpticStudio stops with "ray missed surface" there and wants vignetting
/// factors; this finds the passing beam instead). Throws lensim::Error when the chief ray itself
/// is lost.
FieldBundle::PupilRegion passingPupil(double radius_mm, const std::function<bool(Vec2)>& passes,
                                      double field_deg, int directions = 32);

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
