// The cost of the volpath integrator on a scene without media, against path (issue 13: at most
// 5% more). Renders the scene with each integrator in turn, one thread, `rounds` times, the two
// alternating so that both see the same load, and reports the shortest and the median render
// time (RenderStats::wall_s, the render loop without scene set-up) of each and their ratios.
// Usage (bench/volpath runs it):
//   lensim_bench_volpath SCENE [--spp N] [--rounds R] [--pixelbounds x0 x1 y0 y1]
#include <fmt/format.h>
#include <sys/resource.h>

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
    std::fprintf(stderr,
                 "usage: lensim_bench_volpath SCENE [--spp N] [--rounds R] [--pixelbounds x0 x1 "
                 "y0 y1]\n");
    return 2;
  }
  int spp = 4, rounds = 9;
  std::optional<std::array<int, 4>> bounds;
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--spp") && i + 1 < argc) {
      spp = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--rounds") && i + 1 < argc) {
      rounds = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--pixelbounds") && i + 4 < argc) {
      bounds = std::array<int, 4>{std::atoi(argv[i + 1]), std::atoi(argv[i + 2]),
                                  std::atoi(argv[i + 3]), std::atoi(argv[i + 4])};
      i += 4;
    } else {
      std::fprintf(stderr, "lensim_bench_volpath: unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  try {
    scene::Scene scene = scene::loadScene(argv[1]);
    if (!scene.media.empty()) std::fprintf(stderr, "note: the scene has media\n");
    render::RenderOptions o;
    o.spp = spp;
    o.threads = 1;
    o.pixelbounds = bounds;
    // The scene's world (Embree scene, textures, lights) is built once, outside the timing.
    o.world = render::prepareWorld(scene);
    // Wall time of the render loop, and the process's CPU time around render() (on a loaded
    // machine the CPU time is the steadier measure: time spent waiting for a core is left out).
    auto cpuSeconds = [] {
      rusage u;
      getrusage(RUSAGE_SELF, &u);
      return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
             1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
    };
    std::vector<double> t[2], cpu[2];
    const char* names[2] = {"path", "volpath"};
    for (int r = 0; r < rounds; ++r)
      for (int k = 0; k < 2; ++k) {
        const int which = (r % 2) ? 1 - k : k;  // alternate which goes first
        scene.integrator.type = names[which];
        const double c0 = cpuSeconds();
        t[which].push_back(render::render(scene, o).stats.wall_s);
        cpu[which].push_back(cpuSeconds() - c0);
      }
    double best[2], median[2], cbest[2], cmedian[2];
    for (int k = 0; k < 2; ++k) {
      std::sort(t[k].begin(), t[k].end());
      std::sort(cpu[k].begin(), cpu[k].end());
      best[k] = t[k].front();
      median[k] = t[k][t[k].size() / 2];
      cbest[k] = cpu[k].front();
      cmedian[k] = cpu[k][cpu[k].size() / 2];
    }
    for (int k = 0; k < 2; ++k)
      fmt::print(
          "{:<8} shortest {:.4f} s  median {:.4f} s  (CPU: shortest {:.4f} s, median "
          "{:.4f} s)\n",
          names[k], best[k], median[k], cbest[k], cmedian[k]);
    fmt::print(
        "volpath/path: shortest {:.3f}, median {:.3f}; CPU time: shortest {:.3f}, median "
        "{:.3f} ({} rounds, {} spp, 1 thread)\n",
        best[1] / best[0], median[1] / median[0], cbest[1] / cbest[0], cmedian[1] / cmedian[0],
        rounds, spp);
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
