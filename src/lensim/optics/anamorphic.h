// First-order data of lenses that are not rotationally symmetric (anamorphic lenses with
// cylindrical, biconic or toroidal surfaces): the x-z and y-z sections are traced paraxially apart.
#pragma once

#include <optional>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"

namespace lensim::optics {

/// True when every surface is rotationally symmetric.
bool isRotationallySymmetric(const LensPrescription& p);

/// The x-z section of a lens as a rotationally symmetric prescription: every surface takes its
/// x-section radius (and conic; a toroid its radius of rotation), so that the usual paraxial
/// code gives the x data.
LensPrescription xSection(const LensPrescription& p);
/// The y-z section likewise: every surface keeps its y-section profile (radius, conic and
/// polynomial; a toroid's y curve) as a rotational surface. Rays in the y-z plane through `p`
/// are the meridional rays of the result (what `lens draw` shows for the y-z section).
LensPrescription ySection(const LensPrescription& p);

/// x and y first-order data of an anamorphic lens; squeeze = EFL_y / EFL_x (> 1: the lens
/// squeezes the image horizontally, as a 2x anamorphic's EFL_x is half its EFL_y).
struct AnamorphicData {
  std::optional<ParaxialData> x;  ///< nullopt when the x section is afocal
  std::optional<ParaxialData> y;  ///< nullopt when the y section is afocal
  double squeeze = 1;             ///< EFL_y / EFL_x (0 when a section is afocal)
};
AnamorphicData anamorphicData(const LensSystem& lens);

}  // namespace lensim::optics
