// Progressive rendering (RenderOptions::on_pass, the explorer's preview): the passes, the images
// handed out, stopping from the callback and through the cancel flag, and that the final image
// is bit for bit the one-pass render (each pixel gets the same samples in the same order).
#include <gtest/gtest.h>

#include <atomic>
#include <vector>

#include "render_test_util.h"

using lensim::render::RenderOptions;
using lensim::testutil::renderText;

namespace {

const char* kScene = R"(
LookAt 0 1 -4  0 0.5 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 40 "integer yresolution" 24 "string filename" "p.exr"
Sampler "zsobol" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 4
WorldBegin
LightSource "infinite" "rgb L" [0.4 0.45 0.5]
Material "diffuse" "rgb reflectance" [0.5 0.4 0.3]
Shape "trianglemesh" "point3 P" [-4 0 -4  4 0 -4  4 0 4  -4 0 4] "integer indices" [0 1 2 0 2 3]
Material "dielectric" "float eta" 1.5
Translate 0 0.5 0
Shape "sphere" "float radius" 0.5
)";

}  // namespace

TEST(ProgressiveRender, PassesDoubleAndTheLastImageIsTheOnePassRender) {
  RenderOptions one;
  one.spp = 12;  // zsobol renders the 12 requested; the last pass is short
  const auto whole = renderText(kScene, one);
  RenderOptions prog = one;
  std::vector<int> done;
  std::vector<lensim::io::Image> images;
  prog.on_pass = [&](const lensim::io::Image& im, int spp) {
    done.push_back(spp);
    images.push_back(im);
    return true;
  };
  const auto r = renderText(kScene, prog);
  EXPECT_EQ(done, (std::vector<int>{1, 2, 4, 8, 12}));
  EXPECT_FALSE(r.stats.partial);
  EXPECT_EQ(r.stats.camera_samples, whole.stats.camera_samples);
  ASSERT_EQ(r.image.pixels.size(), whole.image.pixels.size());
  EXPECT_EQ(r.image.pixels, whole.image.pixels);  // same samples, same order: same bits
  EXPECT_EQ(images.back().pixels, whole.image.pixels);
  EXPECT_NE(images.front().pixels, images.back().pixels);
}

TEST(ProgressiveRender, StopsWhenTheCallbackSaysSoOrWhenCancelled) {
  RenderOptions prog;
  prog.spp = 64;
  int calls = 0;
  prog.on_pass = [&](const lensim::io::Image&, int) { return ++calls < 2; };
  auto r = renderText(kScene, prog);
  EXPECT_EQ(calls, 2);
  EXPECT_TRUE(r.stats.partial);
  EXPECT_EQ(r.stats.camera_samples, 40u * 24 * 2);  // two passes of one sample per pixel

  std::atomic<bool> cancel{false};
  calls = 0;
  prog.cancel = &cancel;
  prog.on_pass = [&](const lensim::io::Image&, int) {
    if (++calls == 3) cancel = true;
    return true;
  };
  r = renderText(kScene, prog);
  EXPECT_EQ(calls, 3);
  EXPECT_TRUE(r.stats.partial);
  EXPECT_EQ(r.stats.camera_samples, 40u * 24 * 4);
}
