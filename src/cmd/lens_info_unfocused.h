// `lens info` of a lens that was read but cannot be set up, and the surface and element tables
// every `lens info` prints.
#pragma once

#include "lens_options.h"
#include "lensim/optics/lens_system.h"
#include "lensim/util/error.h"

namespace lensim::cmd {

/// The surface and element tables of `lens info`, and the shapes of the non-spherical surfaces.
void printSurfaceTables(const optics::LensSystem& lens);

/// `lens info` for a lens that was read but cannot be set up (afocal, no real ray gets through,
/// a film that would sit inside the lens): the reason as a warning and the data that exist;
/// exit status 0.
int runInfoUnfocused(const LensArgs& args, bool as_json, const Error& why);

}  // namespace lensim::cmd
