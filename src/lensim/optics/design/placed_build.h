// Decentred and tilted builds of a design job's lens. A coaxial prescription is placed in space
// (every row's frame on the axis: PlacedLens coordinates, the front vertex at the origin, z the
// axis), rows are moved rigidly, and the lens is evaluated by the non-coaxial tracer
// (optics/placed_lens.h) with the beam spotQuadratic uses for coaxial lenses, so that an
// unmoved placed lens gives the coaxial numbers.
#pragma once

#include "lensim/optics/design/design_job.h"
#include "lensim/util/vec.h"

namespace lensim::optics::design {

/// `p` with every row's frame on the axis (vertex at the summed thicknesses, unturned), the
/// image frame at the film (the last thickness), and noncoaxial_loc set to `loc`. A lens that
/// already has frames is returned unchanged.
LensPrescription placeOnAxis(LensPrescription p, const FileLoc& loc);

/// Moves rows first..last of a placed lens rigidly about the current vertex P of row `first`:
/// X -> P + (dx, dy, 0) + Rx(tilt_x) Ry(tilt_y) (X - P), the frames' axes turned alike. This is
/// what a Zemax coordinate break with order 0 at that vertex does (decentre, then tilt about x,
/// then about the new y; degrees, right-handed as the .zmx reader reads them).
void moveRows(LensPrescription& p, int first, int last, double dx_mm, double dy_mm,
              double tilt_x_deg, double tilt_y_deg);

/// A thickness change of row `row` of a placed lens: the later rows and the image surface move
/// by delta_mm along row `row`'s axis (and its thickness changes).
void changeThickness(LensPrescription& p, int row, double delta_mm);

/// Moves the image surface of a placed lens by dz_mm along its own axis (the film distance, the
/// last thickness, changes with it).
void shiftImage(LensPrescription& p, double dz_mm);

/// The beam spotQuadratic traces (the paraxial entrance pupil of the lens's coaxial twin, its
/// rows with their thicknesses and no frames, about where the primary wavelength's real chief
/// ray, aimed through the stop centre, crosses the pupil plane; hexapolar rings; apertures
/// ignored) traced through the placed lens at lambda_nm: the spot's mean square radius about its
/// centroid as a quadratic in a shift of the image surface along its axis, and where the
/// chief ray meets the image surface (its own frame, mm) with its slopes there.
struct PlacedBeam {
  SpotQuadratic spot;
  Vec2 chief{}, chief_slope{};
};
PlacedBeam placedBeam(const LensPrescription& p, double field_deg, double lambda_nm,
                      double primary_nm, int rings);

}  // namespace lensim::optics::design
