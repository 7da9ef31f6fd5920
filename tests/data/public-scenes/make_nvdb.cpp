// Writes the three small NanoVDB files the stand-ins of pbrt-v4-scenes' bunny-cloud,
// disney-cloud and explosion name (their originals are hundreds of MB): a 4 x 4 x 4 fog volume
// "density" (and, for fire.nvdb, a "temperature" grid), ZIP-compressed. Header-only NanoVDB
// (Debian libnanovdb-dev) and zlib:
//   c++ -std=c++17 -O1 tests/data/public-scenes/make_nvdb.cpp -lz -o /tmp/make_nvdb
//   /tmp/make_nvdb tests/data/public-scenes/pbrt-v4-scenes
#define NANOVDB_USE_ZIP 1
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/IO.h>

#include <string>
#include <vector>

namespace {

nanovdb::GridHandle<nanovdb::HostBuffer> grid(const char* name, float base) {
  nanovdb::GridBuilder<float> builder(0.0f, nanovdb::GridClass::FogVolume);
  auto acc = builder.getAccessor();
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i)
        acc.setValue(nanovdb::Coord(i, j, k), base * float(1 + i + j + k) / 10);
  return builder.getHandle<>(0.5, nanovdb::Vec3d(-1, -1, -1), name);
}

void write(const std::string& file, bool temperature) {
  std::vector<nanovdb::GridHandle<nanovdb::HostBuffer>> handles;
  handles.push_back(grid("density", 1));
  if (temperature) handles.push_back(grid("temperature", 2000));
  nanovdb::io::writeGrids(file, handles, nanovdb::io::Codec::ZIP);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : ".";
  write(dir + "/bunny_cloud.nvdb", false);
  write(dir + "/wdas_cloud_quarter.nvdb", false);
  write(dir + "/fire.nvdb", true);
  return 0;
}
