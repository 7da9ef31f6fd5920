// The cloud and nanovdb media. See media_volumes.h.
#include "lensim/render/media/media_volumes.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

// pbrt-v4 reads zlib-compressed .nvdb files too (media.cpp defines NANOVDB_USE_ZIP).
#define NANOVDB_USE_ZIP 1
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/IO.h>
#include <nanovdb/util/SampleFromVoxels.h>
#include <tbb/parallel_for.h>

#include "lensim/render/textures/procedural.h"
#include "lensim/render/textures/textures.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::render {

namespace {

/// The ray's direction in a box's unit space [0,1]^3 (t unchanged: the map is affine).
Vec3 unitDirection(const Transform& medium_from_world, const Vec3& p0, const Vec3& p1,
                   const Vec3& d) {
  const Vec3 q = medium_from_world.applyVector(d);
  return {q.x / (p1.x - p0.x), q.y / (p1.y - p0.y), q.z / (p1.z - p0.z)};
}
Vec3 unitPoint(const Transform& medium_from_world, const Vec3& p0, const Vec3& p1, const Vec3& p) {
  const Vec3 q = medium_from_world.applyPoint(p);
  return {(q.x - p0.x) / (p1.x - p0.x), (q.y - p0.y) / (p1.y - p0.y), (q.z - p0.z) / (p1.z - p0.z)};
}

}  // namespace

// ---- cloud ------------------------------------------------------------------------------------

CloudMedium::CloudMedium(const scene::Medium& m)
    : medium_from_world_(m.medium_from_world),
      p0_(m.p0),
      p1_(m.p1),
      sigma_a_(makeSpectrum(m.sigma_a, SpectrumType::Unbounded)),
      sigma_s_(makeSpectrum(m.sigma_s, SpectrumType::Unbounded)),
      scale_(m.scale),
      density_(m.cloud_density),
      wispiness_(m.wispiness),
      frequency_(m.frequency) {
  g_ = m.g;
}

double CloudMedium::density(const Vec3& p) const {
  // pbrt-v4 media.h, CloudMedium::Density (facts: the constants and the order of operations).
  // pbrt's DNoise (the noise's analytic gradient) is taken here by central differences.
  auto gradient = [](const Vec3& q) {
    const double h = 1e-4;
    return Vec3{perlinNoise(q.x + h, q.y, q.z) - perlinNoise(q.x - h, q.y, q.z),
                perlinNoise(q.x, q.y + h, q.z) - perlinNoise(q.x, q.y - h, q.z),
                perlinNoise(q.x, q.y, q.z + h) - perlinNoise(q.x, q.y, q.z - h)} /
           (2 * h);
  };
  Vec3 pp = p * frequency_;
  if (wispiness_ > 0) {
    double vomega = 0.05 * wispiness_, vlambda = 10;
    for (int i = 0; i < 2; ++i) {
      pp = pp + gradient(pp * vlambda) * vomega;
      vomega *= 0.5;
      vlambda *= 1.99;
    }
  }
  double d = 0, omega = 0.5, lambda = 1;
  for (int i = 0; i < 5; ++i) {
    const Vec3 q = pp * lambda;
    d += omega * perlinNoise(q.x, q.y, q.z);
    omega *= 0.5;
    lambda *= 1.99;
  }
  d = std::clamp((1 - p.y) * 4.5 * density_ * d, 0.0, 1.0);
  d += 2 * std::max(0.0, 0.5 - p.y);
  return std::clamp(d, 0.0, 1.0);
}

MediumProperties CloudMedium::at(const Vec3& p, const SampledWavelengths& lambda) const {
  const Vec3 q = medium_from_world_.applyPoint(p);
  MediumProperties mp;
  if (q.x < p0_.x || q.y < p0_.y || q.z < p0_.z || q.x > p1_.x || q.y > p1_.y || q.z > p1_.z)
    return mp;
  const double d = density(q) * scale_;
  mp.sigma_a = sigma_a_->sample(lambda) * d;
  mp.sigma_s = sigma_s_->sample(lambda) * d;
  return mp;
}

void CloudMedium::majorants(const Vec3& o, const Vec3& d, double tmax,
                            const SampledWavelengths& lambda, const SegmentFn& fn) const {
  static const std::vector<double> one{1.0};
  walkMajorantGrid(unitPoint(medium_from_world_, p0_, p1_, o),
                   unitDirection(medium_from_world_, p0_, p1_, d), tmax, 1, one,
                   (sigma_a_->sample(lambda) + sigma_s_->sample(lambda)) * scale_, fn);
}

// ---- nanovdb ----------------------------------------------------------------------------------

struct NanoVDBMedium::Grids {
  nanovdb::GridHandle<nanovdb::HostBuffer> density_handle, temperature_handle;
  const nanovdb::FloatGrid* density = nullptr;
  const nanovdb::FloatGrid* temperature = nullptr;
};

NanoVDBMedium::NanoVDBMedium(const scene::Medium& m)
    : grids_(std::make_unique<Grids>()),
      medium_from_world_(m.medium_from_world),
      sigma_a_(makeSpectrum(m.sigma_a, SpectrumType::Unbounded)),
      sigma_s_(makeSpectrum(m.sigma_s, SpectrumType::Unbounded)),
      scale_(m.scale),
      Le_scale_(m.Le_scale),
      temperature_offset_(m.temperature_offset),
      temperature_scale_(m.temperature_scale) {
  g_ = m.g;
  auto read = [&](const char* name) {
    try {
      if (!nanovdb::io::hasGrid(m.filename, name))
        return nanovdb::GridHandle<nanovdb::HostBuffer>();
      return nanovdb::io::readGrid<nanovdb::HostBuffer>(m.filename, name);
    } catch (const std::exception& e) {
      throw Error(m.loc, fmt::format("medium \"{}\": cannot read NanoVDB file \"{}\": {}", m.name,
                                     m.filename, e.what()));
    }
  };
  grids_->density_handle = read("density");
  if (!grids_->density_handle)
    throw Error(m.loc, fmt::format("medium \"{}\": NanoVDB file \"{}\" has no \"density\" grid",
                                   m.name, m.filename));
  grids_->density = grids_->density_handle.grid<float>();
  if (!grids_->density)
    throw Error(m.loc, fmt::format("medium \"{}\": the \"density\" grid of \"{}\" is not a float "
                                   "grid",
                                   m.name, m.filename));
  grids_->temperature_handle = read("temperature");
  if (grids_->temperature_handle) {
    grids_->temperature = grids_->temperature_handle.grid<float>();
    if (!grids_->temperature)
      throw Error(m.loc, fmt::format("medium \"{}\": the \"temperature\" grid of \"{}\" is not a "
                                     "float grid",
                                     m.name, m.filename));
  }
  emissive_ = grids_->temperature && Le_scale_ > 0;
  const auto& bbox = grids_->density->worldBBox();
  p0_ = {bbox.min()[0], bbox.min()[1], bbox.min()[2]};
  p1_ = {bbox.max()[0], bbox.max()[1], bbox.max()[2]};
  if (!(p0_.x < p1_.x && p0_.y < p1_.y && p0_.z < p1_.z)) {
    // An empty grid: nothing to render (a zero majorant everywhere).
    p0_ = {0, 0, 0}, p1_ = {1, 1, 1};
    majorant_.assign(size_t(kRes) * kRes * kRes, 0.0);
    return;
  }

  // Majorant cells: the largest voxel value among those a trilinear lookup inside the cell can
  // reach (the index-space box of the cell widened by one voxel), the background included
  // where the box leaves the grid's active bounding box.
  majorant_.assign(size_t(kRes) * kRes * kRes, 0.0);
  const nanovdb::FloatGrid& grid = *grids_->density;
  const auto ibox = grid.indexBBox();
  const float background = grid.tree().background();
  // One slice of cells per task (large grids: pbrt-v4 runs this in parallel too).
  tbb::parallel_for(0, kRes, [&](int z) {
    auto acc = grid.getAccessor();
    for (int y = 0; y < kRes; ++y)
      for (int x = 0; x < kRes; ++x) {
        int lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
        for (int corner = 0; corner < 8; ++corner) {
          const double u[3] = {double(x + (corner & 1)) / kRes,
                               double(y + ((corner >> 1) & 1)) / kRes,
                               double(z + ((corner >> 2) & 1)) / kRes};
          const nanovdb::Vec3d w(p0_.x + u[0] * (p1_.x - p0_.x), p0_.y + u[1] * (p1_.y - p0_.y),
                                 p0_.z + u[2] * (p1_.z - p0_.z));
          const nanovdb::Vec3d i = grid.worldToIndexF(w);
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], int(std::floor(i[a])) - 1);
            hi[a] = std::max(hi[a], int(std::floor(i[a])) + 1);
          }
        }
        double v = 0;
        bool outside = false;
        for (int a = 0; a < 3; ++a) {
          if (lo[a] < ibox.min()[a]) lo[a] = ibox.min()[a], outside = true;
          if (hi[a] > ibox.max()[a]) hi[a] = ibox.max()[a], outside = true;
        }
        if (outside) v = std::max(v, double(background));
        for (int k = lo[2]; k <= hi[2]; ++k)
          for (int j = lo[1]; j <= hi[1]; ++j)
            for (int i = lo[0]; i <= hi[0]; ++i)
              v = std::max(v, double(acc.getValue(nanovdb::Coord(i, j, k))));
        majorant_[(size_t(z) * kRes + y) * kRes + x] = v;
      }
  });
}

NanoVDBMedium::~NanoVDBMedium() = default;

double NanoVDBMedium::density(const Vec3& q) const {
  const nanovdb::FloatGrid& grid = *grids_->density;
  const nanovdb::Vec3d i = grid.worldToIndexF(nanovdb::Vec3d(q.x, q.y, q.z));
  auto sampler = nanovdb::createSampler<1, nanovdb::FloatGrid::TreeType, false>(grid.tree());
  return std::max(0.0, double(sampler(i)));
}

MediumProperties NanoVDBMedium::at(const Vec3& p, const SampledWavelengths& lambda) const {
  const Vec3 q = medium_from_world_.applyPoint(p);
  MediumProperties mp;
  if (q.x < p0_.x || q.y < p0_.y || q.z < p0_.z || q.x > p1_.x || q.y > p1_.y || q.z > p1_.z)
    return mp;
  const double d = density(q) * scale_;
  mp.sigma_a = sigma_a_->sample(lambda) * d;
  mp.sigma_s = sigma_s_->sample(lambda) * d;
  if (emissive_) {
    const nanovdb::FloatGrid& tg = *grids_->temperature;
    const nanovdb::Vec3d i = tg.worldToIndexF(nanovdb::Vec3d(q.x, q.y, q.z));
    auto sampler = nanovdb::createSampler<1, nanovdb::FloatGrid::TreeType, false>(tg.tree());
    const double T = (double(sampler(i)) - temperature_offset_) * temperature_scale_;
    if (T > 100) mp.Le = BlackbodySpectrum(T).sample(lambda) * Le_scale_;
  }
  return mp;
}

void NanoVDBMedium::majorants(const Vec3& o, const Vec3& d, double tmax,
                              const SampledWavelengths& lambda, const SegmentFn& fn) const {
  walkMajorantGrid(unitPoint(medium_from_world_, p0_, p1_, o),
                   unitDirection(medium_from_world_, p0_, p1_, d), tmax, kRes, majorant_,
                   (sigma_a_->sample(lambda) + sigma_s_->sample(lambda)) * scale_, fn);
}

}  // namespace lensim::render
