// A raw mosaic of a CFA tile that dcraw and LibRaw cannot hold (Quad Bayer, Kodak's 4x4 RGBW, ...)
// remosaiced to a Bayer RGGB mosaic, as phone cameras with such sensors do for their DNGs
// (docs/sensor.md, "Colour filter arrays").
#pragma once

#include <cstdint>
#include <vector>

#include "lensim/scene/sensor_config.h"

namespace lensim::render {

/// The Bayer filter (0 red, 1 green, 2 blue) over pixel (x, y) of the full image: RGGB from its
/// top-left pixel.
inline int bayerChannel(int x, int y) { return (y & 1) ? ((x & 1) ? 2 : 1) : ((x & 1) ? 1 : 0); }

/// The w x h window at (x0, y0) of the full image of raw values `dn` (row-major, taken under
/// `cfa`) remosaiced to RGGB: a pixel whose filter is its Bayer filter keeps its value; another
/// gets the tent-weighted mean (cfa_interpolate.h) of the Bayer filter's colour over that colour's
/// pixels about it, above `black`, rounded and clamped to [0, white]. W pixels give no colour.
std::vector<uint16_t> remosaicToBayer(const std::vector<uint16_t>& dn, int w, int h,
                                      const scene::CfaPattern& cfa, int x0, int y0, int black,
                                      int white);

}  // namespace lensim::render
