#include "lensim/optics/coating/ghost_trace.h"

#include <fmt/format.h>

#include <cmath>

#include "lensim/util/error.h"

namespace lensim::optics {

std::vector<Interface> ghostPathInterfaces(const LensSystem& lens, int first, int second) {
  const int n = lens.surfaceCount();
  const std::string pair = fmt::format("{},{}", first, second);
  if (lens.mirrorCount() > 0)
    throw Error(
        fmt::format("ghost {}: the lens has mirrors (ghosts of catadioptric lenses are "
                    "not modelled)",
                    pair));
  if (!(second >= 0 && second < first && first < n))
    throw Error(
        fmt::format("ghost {}: expected I,J with 0 <= J < I <= {} (surface indices as "
                    "`lens ghosts` lists them: reflected first at I, then at J)",
                    pair, n - 1));
  const auto& s = lens.interfaces();
  for (int k : {first, second})
    if (s[size_t(k)].ior_before == s[size_t(k)].ior_after)
      throw Error(
          fmt::format("ghost {}: surface {} has the same index on both sides ({}) and "
                      "reflects nothing",
                      pair, k, s[size_t(k)].is_stop ? "the aperture stop" : "a dummy"));
  std::vector<Interface> path;
  for (int k = 0; k < first; ++k) path.push_back(s[size_t(k)]);
  auto mirror = [&](int k, double medium, int dir_before) {
    Interface m = s[size_t(k)];
    m.is_mirror = true;
    m.is_stop = false;
    m.ior_before = m.ior_after = medium;
    m.dir_before = dir_before;
    m.dir_after = -dir_before;
    path.push_back(m);
  };
  mirror(first, s[size_t(first)].ior_before, 1);
  for (int k = first - 1; k > second; --k) {
    Interface b = s[size_t(k)];
    std::swap(b.ior_before, b.ior_after);
    b.dir_before = b.dir_after = -1;
    path.push_back(b);
  }
  mirror(second, s[size_t(second)].ior_after, -1);
  for (int k = second + 1; k < n; ++k) path.push_back(s[size_t(k)]);
  return path;
}

int ghostPathSurface(int first, int second, int index) {
  if (index <= first) return index;
  const int back = 2 * first - second;  // where the path meets `second`
  if (index <= back) return 2 * first - index;
  return index - 2 * (first - second);
}

LensTracer<double> ghostTracer(const LensSystem& lens, int first, int second) {
  return LensTracer<double>(ghostPathInterfaces(lens, first, second));
}

std::optional<double> axisCrossingZ(const Ray& out) {
  if (out.direction.x == 0) return std::nullopt;
  return out.origin.z - out.origin.x * out.direction.z / out.direction.x;
}

}  // namespace lensim::optics
