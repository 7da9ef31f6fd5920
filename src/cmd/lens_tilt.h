// `lens info --tilt X,Y --shift X,Y`: the lens tilted and shifted against the film
// (optics/tilt_shift.h), its hinge line and plane of sharp focus.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "lensim/optics/focus.h"
#include "lensim/optics/tilt_shift.h"

namespace lensim::cmd {

/// Parses --tilt (degrees about the film's x and y axes, each within +-45) and --shift (mm);
/// empty texts are zero. Throws lensim::Error naming the option and the bad value.
optics::TiltShift parseTiltShift(const std::string& tilt, const std::string& shift);

/// The same as `lens info` lines.
void printTiltShift(const optics::FocusedLens& fl, const optics::TiltShift& ts,
                    double film_diagonal_mm);

}  // namespace lensim::cmd
