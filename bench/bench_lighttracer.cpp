// The light tracer's cost per sample against the path tracer's (issue 13): renders the scene with
// "path" and "lighttracer" in turn, one thread, `rounds` times, alternating which goes first so
// that both see the same load, and reports the shortest and median render time
// (RenderStats::wall_s, without scene set-up) per pixel sample of each. A lighttracer sample is one
// light path with a camera connection at each vertex; a path sample one camera path with
// next-event estimation.
// Usage (bench/lighttracer runs it):
//   lensim_bench_lighttracer SCENE [--spp N] [--rounds R]
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

using namespace lensim;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: lensim_bench_lighttracer SCENE [--spp N] [--rounds R]\n");
    return 2;
  }
  int spp = 4, rounds = 5;
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--spp") && i + 1 < argc) {
      spp = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--rounds") && i + 1 < argc) {
      rounds = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "lensim_bench_lighttracer: unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  try {
    scene::Scene scene = scene::loadScene(argv[1]);
    render::RenderOptions o;
    o.spp = spp;
    o.threads = 1;
    std::vector<double> t[2];
    const char* names[2] = {"path", "lighttracer"};
    double samples = 0;
    for (int r = 0; r < rounds; ++r)
      for (int k = 0; k < 2; ++k) {
        const int which = (r % 2) ? 1 - k : k;
        scene.integrator.type = names[which];
        const render::RenderStats st = render::render(scene, o).stats;
        t[which].push_back(st.wall_s);
        samples = double(st.camera_samples);
      }
    double best[2], median[2];
    for (int k = 0; k < 2; ++k) {
      std::sort(t[k].begin(), t[k].end());
      best[k] = t[k].front() / samples * 1e6;
      median[k] = t[k][t[k].size() / 2] / samples * 1e6;
      fmt::print("{:<12} per sample: shortest {:.3f} us  median {:.3f} us\n", names[k], best[k],
                 median[k]);
    }
    fmt::print(
        "lighttracer/path: shortest {:.3f}, median {:.3f} ({} rounds, {} spp, {:.0f} "
        "samples, 1 thread)\n",
        best[1] / best[0], median[1] / median[0], rounds, spp, samples);
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
