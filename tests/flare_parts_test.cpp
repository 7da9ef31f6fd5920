// Lens flare as parts and checkpoints (issue 31, docs/flare.md "Parts and checkpoints"): a flare
// render's ghost layer is kept in exact sums like its pixels, so sample slices and tiles merge to
// the whole render bit for bit, ghost layer included, and a resumed render equals an
// uninterrupted one. The reference is the whole render itself, rendered separately: a render
// defines its image by its samples, and the parts take the same samples (docs/cluster.md).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/io/exr_window.h"
#include "lensim/io/image.h"
#include "lensim/render/parts.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace fs = std::filesystem;
using namespace lensim;

namespace {

const std::string kSource = LENSIM_SOURCE_DIR;

fs::path tempDir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("lensim_flare_parts_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// The demo world through the uncoated 50 mm double Gauss with flare (48 x 32 pixels: 3 x 2 of
/// the renderer's 16-pixel tiles), a bright small light beside the frame's centre for ghosts.
std::string writeScene(const fs::path& dir) {
  const std::string path = (dir / "flare.pbrt").string();
  std::ofstream f(path);
  f << "LookAt 0 0.9 -3.2   0 0.45 0.4   0 1 0\n"
    << "Camera \"realistic\" \"string lensfile\" \"" << kSource << "/lenses/dgauss.50mm.dat\"\n"
    << "  \"float aperturediameter\" 12.2 \"float focusdistance\" 3.3 \"bool flare\" true\n"
    << "Film \"rgb\" \"integer xresolution\" 48 \"integer yresolution\" 32 "
       "\"float diagonal\" 43.3\n"
    << "  \"float iso\" 1000 \"string filename\" \"flare.exr\"\n"
    << "Sampler \"paddedsobol\" \"integer pixelsamples\" 8\n"
    << "PixelFilter \"gaussian\"\n"
    << "Integrator \"path\" \"integer maxdepth\" 3\n"
    << "WorldBegin\n"
    << "Include \"" << kSource << "/scenes/demo/world.pbrt\"\n"
    << "AttributeBegin\n  Translate 0.3 0.7 0.8\n"
    << "  AreaLightSource \"diffuse\" \"rgb L\" [400 380 350]\n"
    << "  Shape \"sphere\" \"float radius\" 0.03\nAttributeEnd\n";
  return path;
}

bool sameBits(const io::Image& a, const io::Image& b) {
  return a.width == b.width && a.height == b.height && a.channels == b.channels &&
         std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(float)) == 0;
}

/// Sum of channel `c` over the image.
double channelSum(const io::Image& im, int c) {
  double s = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) s += im.at(x, y, c);
  return s;
}

render::RenderOptions options() {
  render::RenderOptions o;
  o.threads = 2;
  o.progress = false;
  return o;
}

/// A part of a render result, as lensim render writes it.
render::Part partOf(const scene::Scene& s, const render::RenderOptions& o,
                    render::RenderResult res) {
  render::Part p;
  p.metadata = render::renderIdentity(s, o, render::planRender(s, o), "test");
  p.x_res = s.film.x_resolution, p.y_res = s.film.y_resolution;
  p.bounds = res.bounds;
  p.sums = std::move(res.sums);
  p.ghost_sums = std::move(res.ghost_sums);
  return p;
}

}  // namespace

// Two sample slices x two tiles, each written to a part file and read back, merge to the whole
// render's sums, ghost sums and image (R, G, B and the ghost layer) bit for bit.
TEST(FlareParts, SampleSlicesAndTilesMergeToTheWholeRenderBitForBit) {
  const fs::path d = tempDir("merge");
  const scene::Scene s = scene::loadScene(writeScene(d));
  render::RenderOptions whole_o = options();
  whole_o.keep_sums = true;
  const render::RenderResult whole = render::render(s, whole_o);
  ASSERT_EQ(whole.image.channelCount(), 6);
  ASSERT_EQ(whole.image.channels[3], "ghost.R");
  ASSERT_EQ(whole.ghost_sums.size(), whole.sums.size());
  // The ghost layer holds light, and less than the sum.
  const double ghost = channelSum(whole.image, 4), sum = channelSum(whole.image, 1);
  std::printf("whole render: G sum %.4g, ghost.G sum %.4g\n", sum, ghost);
  EXPECT_GT(ghost, 0);
  EXPECT_LT(ghost, sum);

  std::vector<render::Part> parts;
  for (const auto& range : {std::pair{0, 3}, std::pair{3, 8}})
    for (int tile = 0; tile < 2; ++tile) {
      render::RenderOptions o = options();
      o.keep_sums = true;
      o.spp_range = range;
      o.tile = std::pair{tile, 2};
      o.threads = 1 + tile;  // the thread count does not matter either
      const std::string file =
          (d / ("part" + std::to_string(range.first) + "_" + std::to_string(tile) + ".exr"))
              .string();
      render::Part p = partOf(s, o, render::render(s, o));
      ASSERT_FALSE(p.ghost_sums.empty());
      render::writePart(file, p);
      parts.push_back(render::readPart(file));
      EXPECT_TRUE(parts.back().ghost_sums == p.ghost_sums) << file;
    }
  const render::Part merged = render::mergeParts(parts);
  EXPECT_TRUE(merged.sums == whole.sums);
  EXPECT_TRUE(merged.ghost_sums == whole.ghost_sums);
  EXPECT_TRUE(
      sameBits(render::sumsImage(merged.bounds, merged.sums, merged.ghost_sums), whole.image));

  // A part file with some but not all of the ghost layer's sum channels is refused, naming it.
  {
    io::ExrWindowFile f = io::readExrWindow((d / "part0_0.exr").string());
    ASSERT_EQ(f.uint_channels.erase("ghost.sum.G.2"), 1u);
    const std::string cut = (d / "cut.exr").string();
    io::writeExrWindow(cut, f);
    try {
      render::readPart(cut);
      ADD_FAILURE() << "read a part with 11 of the 12 ghost-layer channels";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("cut.exr"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("11 of the 12 ghost-layer channels"), std::string::npos)
          << e.what();
    }
  }
  // A part without the ghost layer does not merge with those that have it.
  std::vector<render::Part> mixed = parts;
  mixed[1].ghost_sums.clear();
  try {
    render::mergeParts(mixed);
    ADD_FAILURE() << "merged parts with and without a ghost layer";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ghost layer"), std::string::npos) << e.what();
  }
}

// A render resumed from a checkpoint (written to its file and read back) whose tiles 1, 3 and 4
// of 6 are unfinished equals the uninterrupted render bit for bit, ghost layer included; a
// checkpoint without the ghost layer is refused.
TEST(FlareParts, ResumedRenderEqualsUninterruptedRender) {
  const fs::path d = tempDir("resume");
  const scene::Scene s = scene::loadScene(writeScene(d));
  render::RenderCheckpoint last;
  render::RenderOptions o = options();
  o.on_checkpoint = [&](const render::RenderCheckpoint& c) { last = c; };
  const render::RenderResult whole = render::render(s, o);
  ASSERT_TRUE(last.complete());
  ASSERT_EQ(last.tile_done.size(), 6u);
  ASSERT_EQ(last.ghost_sums.size(), last.sums.size());

  // Through the checkpoint file, as lensim render --checkpoint writes it.
  render::Part p;
  p.metadata = render::renderIdentity(s, o, render::planRender(s, o), "test");
  p.metadata["lensim:partial"] = "true";
  p.x_res = s.film.x_resolution, p.y_res = s.film.y_resolution;
  p.bounds = last.bounds;
  p.sums = last.sums;
  p.ghost_sums = last.ghost_sums;
  p.tile_done = last.tile_done;
  // Tiles 1, 3 and 4 unfinished: their sums zero, as the renderer's snapshot leaves them.
  const int w = last.bounds.width();
  for (int t : {1, 3, 4}) {
    p.tile_done[size_t(t)] = 0;
    const int tx = t % 3, ty = t / 3;
    for (int y = ty * 16; y < std::min(last.bounds.height(), (ty + 1) * 16); ++y)
      for (int x = tx * 16; x < std::min(w, (tx + 1) * 16); ++x) {
        p.sums[size_t(y * w + x)] = {};
        p.ghost_sums[size_t(y * w + x)] = {};
      }
  }
  const std::string file = (d / "ck.exr").string();
  render::writePart(file, p);
  const render::Part ck = render::readPart(file);
  render::RenderCheckpoint state;
  state.bounds = ck.bounds;
  state.tile_done = ck.tile_done;
  state.sums = ck.sums;
  state.ghost_sums = ck.ghost_sums;
  render::RenderOptions r = options();
  r.resume = &state;
  const render::RenderResult resumed = render::render(s, r);
  EXPECT_EQ(resumed.stats.tiles_resumed, 3);
  EXPECT_TRUE(sameBits(resumed.image, whole.image));

  state.ghost_sums.clear();
  try {
    render::render(s, r);
    ADD_FAILURE() << "resumed a flare render from a checkpoint without its ghost layer";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ghost layer"), std::string::npos) << e.what();
  }
}

// The same through the command line: `lensim render --spp-range` twice and `lensim merge` give
// the whole render's EXR (R, G, B, ghost.R, ghost.G, ghost.B) bit for bit; so do a render with
// --checkpoint and one resumed from its (complete) checkpoint file.
TEST(FlareParts, CommandLineSplitMergeAndResume) {
  const fs::path d = tempDir("cli");
  const std::string scene = writeScene(d);
  const std::string render = "--quiet render " + scene + " --threads 2 ";
  auto file = [&](const std::string& name) { return (d / name).string(); };
  for (const auto& [args, what] : std::vector<std::pair<std::string, std::string>>{
           {render + "-o " + file("whole.exr"), "whole"},
           {render + "--spp-range 0:5 -o " + file("a.exr"), "slice 0:5"},
           {render + "--spp-range 5:8 -o " + file("b.exr"), "slice 5:8"},
           {"--quiet merge " + file("m.exr") + " " + file("a.exr") + " " + file("b.exr"), "merge"},
           {render + "--checkpoint " + file("ck.exr") + " -o " + file("c.exr"), "checkpointed"},
           {render + "--resume " + file("ck.exr") + " -o " + file("r.exr"), "resumed"}}) {
    const test::CliResult r = test::runLensim(args);
    ASSERT_EQ(r.status, 0) << what << ": " << r.out;
  }
  const io::Image whole = io::readImage(file("whole.exr"));
  ASSERT_EQ(whole.channelCount(), 6);
  for (const char* name : {"m.exr", "c.exr", "r.exr"}) {
    io::Image im = io::readImage(file(name));
    ASSERT_EQ(im.channelCount(), 6) << name;
    // Channel order in the files is the writer's; compare by name.
    io::Image same(im.width, im.height, whole.channels);
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x)
        for (int c = 0; c < 6; ++c)
          same.at(x, y, c) = im.at(x, y, *im.channelIndex(whole.channels[size_t(c)]));
    EXPECT_TRUE(sameBits(same, whole)) << name;
  }
  EXPECT_GT(channelSum(whole, *whole.channelIndex("ghost.G")), 0);
}
