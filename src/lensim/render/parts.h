// Distributed renders: splitting a render into tiles and sample slices, the parts' files (EXR
// with the exact film sums and metadata that identify the render), merging them exactly, and
// render checkpoints (a part with the finished tiles so far). See docs/cluster.md.
//
// A part file is an EXR whose data window is the part's pixels inside the full image (display
// window). Channels R, G, B hold the part's own image (viewable); UINT channels sum.R.0..3,
// sum.G.*, sum.B.*, sum.W.* hold the exact 128-bit fixed-point sums of render::PixelSum
// (little-endian 32-bit words). A lens-flare render's parts also hold its ghost layer: float
// channels ghost.R, ghost.G, ghost.B (viewable) and UINT ghost.sum.R.0..3, ghost.sum.G.*,
// ghost.sum.B.* (render::GhostSum, over the pixel's sum.W). String attributes:
//   lensim:part          "1"
//   lensim:scene         the scene file as given; lensim:scene_hash its identity (below)
//   lensim:seed, lensim:spp_total, lensim:spp_range "A:B", lensim:tile "I/N"
//   lensim:resolution "W H", lensim:pixelbounds "x0 x1 y0 y1" (of the whole render)
//   lensim:lens          the lens file and a hash of its contents ("none" without one)
//   lensim:version       the lensim version
//   lensim:checkpoint_tiles  (checkpoints) one character per renderer tile, '1' when finished
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "lensim/io/image.h"
#include "lensim/render/film/film.h"
#include "lensim/render/renderer.h"

namespace lensim::scene {
struct Scene;
}

namespace lensim::render {

/// How `count` tiles cut `bounds`: nx columns by ny rows (nx * ny == count), the factorisation
/// whose tiles are closest to square.
std::pair<int, int> tileGrid(const PixelBounds& bounds, int count);

/// Tile `index` (0-based, row by row) of `count` tiles of `bounds` (tileGrid; column edges at
/// x0 + floor(k * width / nx), rows likewise). Throws lensim::Error for an index out of range or
/// more tiles than pixels in a direction.
PixelBounds tileBounds(const PixelBounds& bounds, int index, int count);

/// "I/N" (0 <= I < N). Throws lensim::Error naming the text otherwise.
std::pair<int, int> parseTile(const std::string& text);
/// "A:B" (0 <= A < B). Throws lensim::Error naming the text otherwise.
std::pair<int, int> parseSppRange(const std::string& text);
/// "60s", "500ms", "5m", "1h" or a number of seconds. Throws lensim::Error otherwise.
double parseDuration(const std::string& text);

/// 64-bit FNV-1a of bytes, as 16 hex digits.
std::string hashHex(const std::string& bytes);

/// The identity of a render, as the part metadata (lensim:scene_hash, lensim:seed, ...).
/// The scene hash covers the text of every scene file read (the top-level file and its
/// includes), the lens file, and the settings that change pixels but are not recorded apart
/// (film distance, pbrt-v2 quirks). `version` is the lensim version.
std::map<std::string, std::string> renderIdentity(const scene::Scene& scene,
                                                  const RenderOptions& options,
                                                  const RenderPlan& plan,
                                                  const std::string& version);

/// A part in memory.
struct Part {
  std::string path;                             ///< where it was read from (for messages)
  std::map<std::string, std::string> metadata;  ///< identity, spp range, tile, ...
  int x_res = 0, y_res = 0;                     ///< the full image
  PixelBounds bounds;                           ///< the pixels it holds
  std::vector<PixelSum> sums;                   ///< bounds-sized, row by row
  std::vector<GhostSum> ghost_sums;  ///< lens flare: the ghost layer's, as sums (else empty)
  std::vector<uint8_t> tile_done;               ///< checkpoints: the renderer's finished tiles
};

/// The EXR contents of a part (see the top of this file).
void writePart(const std::string& path, const Part& part);
/// Reads a part; throws lensim::Error naming the file if it is not one.
Part readPart(const std::string& path);

/// The image of exact sums (R, G, B as the renderer's film gives them), bounds-sized; with
/// `ghost_sums` (lens flare) also its ghost layer, channels Film::ghostChannels().
io::Image sumsImage(const PixelBounds& bounds, const std::vector<PixelSum>& sums,
                    const std::vector<GhostSum>& ghost_sums = {});

/// The parts' sum over the whole render. Every part must come from the same render (scene
/// hash, seed, samples per pixel, resolution, pixel bounds, lens, version), be complete and all
/// hold a ghost layer or none;
/// together they must cover every pixel of the render's pixel bounds with every sample index
/// in [0, spp) exactly once. Throws lensim::Error with a message naming the parts otherwise.
/// The result's metadata is the render's identity; its spp range is the whole range.
/// With `allow_partial_samples` (progressive sample splitting), the parts may hold fewer than
/// all samples as long as every pixel has the same contiguous range of them (the result is a
/// part of that range, which can be merged with the other slices later).
Part mergeParts(const std::vector<Part>& parts, bool allow_partial_samples = false);

}  // namespace lensim::render
