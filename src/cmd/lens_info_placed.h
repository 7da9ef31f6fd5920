// `lens info` of a non-coaxial lens (tilted or decentred surfaces): the real rays its geometry
// allows, and the first-order data it does not, refused with the reason.
#pragma once

#include <optional>

#include "lens_options.h"
#include "lensim/optics/prescription.h"

namespace lensim::cmd {

/// `lens info` for a prescription with noncoaxial_loc set: every surface's place, and per field
/// (--field; default on axis) the real chief ray, four marginal rays and the spot at the image
/// surface. Exit status 0.
int runInfoNonCoaxial(const LensArgs& args, const optics::LensPrescription& p, bool as_json);

/// runInfoNonCoaxial's exit status when args.lens_path is a non-coaxial lens (refusing --tilt and
/// --shift, `tilt_or_shift`); nullopt for a coaxial one (refusing --field).
std::optional<int> runInfoIfNonCoaxial(const LensArgs& args, bool tilt_or_shift, bool as_json);

}  // namespace lensim::cmd
