#include "lensim/render/lights/lightsampler.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lensim/render/lights/lights.h"
#include "lensim/util/error.h"

namespace lensim::render {

using namespace lensim::sampling;

namespace {

constexpr double kOneMinusEpsilon = 1 - 1e-16;

double safeSqrt(double x) {
  return std::sqrt(std::max(0.0, x));
}
double safeAcos(double x) {
  return std::acos(std::clamp(x, -1.0, 1.0));
}
Vec3 diagonal(const Bounds3& b) {
  return b.max - b.min;
}
double surfaceArea(const Bounds3& b) {
  const Vec3 d = diagonal(b);
  return 2 * (d.x * d.y + d.x * d.z + d.y * d.z);
}
double maxComponent(const Vec3& v) {
  return std::max({v.x, v.y, v.z});
}
// Numerically robust angle between unit vectors (pbrt-v4's AngleBetween).
double angleBetween(const Vec3& a, const Vec3& b) {
  if (dot(a, b) < 0) return kPi - 2 * std::asin(std::min(1.0, length(a + b) / 2));
  return 2 * std::asin(std::min(1.0, length(b - a) / 2));
}

}  // namespace

// ---- direction cones and light bounds (pbrt-v4: util/vecmath.{h,cpp}, lights.{h,cpp}) --------

DirectionCone unionCones(const DirectionCone& a, const DirectionCone& b) {
  if (a.empty) return b;
  if (b.empty) return a;
  // The angles of the two cones and between their axes; a cone that holds the other wins.
  const double theta_a = safeAcos(a.cos_theta), theta_b = safeAcos(b.cos_theta);
  const double theta_d = angleBetween(a.w, b.w);
  if (std::min(theta_d + theta_b, kPi) <= theta_a) return a;
  if (std::min(theta_d + theta_a, kPi) <= theta_b) return b;
  // Otherwise the cone spanning both, its axis rotated from a.w toward b.w.
  const double theta_o = (theta_a + theta_d + theta_b) / 2;
  if (theta_o >= kPi) return DirectionCone::entireSphere();
  const double theta_r = theta_o - theta_a;
  const Vec3 wr = cross(a.w, b.w);
  if (dot(wr, wr) == 0) return DirectionCone::entireSphere();
  const Vec3 w = Transform::rotate(theta_r * 180 / kPi, wr).applyVector(a.w);
  return {normalize(w), std::cos(theta_o), false};
}

DirectionCone boundSubtendedDirections(const Bounds3& b, const Vec3& p) {
  const Vec3 c = (b.min + b.max) * 0.5;
  const double r2 = dot(b.max - c, b.max - c);
  const double d2 = dot(p - c, p - c);
  if (d2 < r2) return DirectionCone::entireSphere();
  const double cos_max = safeSqrt(1 - r2 / d2);
  return {normalize(c - p), cos_max, false};
}

namespace {

// LightBounds with what importance() needs precomputed (centroid, the distance clamp, the
// bounding sphere's squared radius, sin theta_o): the light BVH evaluates it at every node it
// descends.
struct ImportanceBounds {
  Vec3 pc, w;
  double d2_min = 0, r2 = 0, phi = 0, cos_o = 1, sin_o = 0, cos_e = 1;
  bool two_sided = false;

  ImportanceBounds() = default;
  explicit ImportanceBounds(const LightBounds& b)
      : pc(b.centroid()),
        w(b.w),
        d2_min(length(diagonal(b.bounds)) / 2),  // pbrt-v4's clamp, as written there
        r2(dot(b.bounds.max - b.centroid(), b.bounds.max - b.centroid())),
        phi(b.phi),
        cos_o(b.cos_theta_o),
        sin_o(safeSqrt(1 - b.cos_theta_o * b.cos_theta_o)),
        cos_e(b.cos_theta_e),
        two_sided(b.two_sided) {}

  // As pbrt-v4's LightBounds::Importance (src/pbrt/lights.cpp): phi cos(theta') / d^2, where
  // theta' is the smallest angle between the emission cone and the direction to p, widened by
  // the angle the box's bounding sphere subtends, and cos(theta'_i) for the receiver's normal
  // likewise.
  double operator()(const Vec3& p, const Vec3& n) const {
    const Vec3 v = p - pc;
    const double dist2 = dot(v, v);
    const double d2 = std::max(dist2, d2_min);
    auto cosSubClamped = [](double sin_a, double cos_a, double sin_b, double cos_b) {
      return cos_a > cos_b ? 1.0 : cos_a * cos_b + sin_a * sin_b;
    };
    auto sinSubClamped = [](double sin_a, double cos_a, double sin_b, double cos_b) {
      return cos_a > cos_b ? 0.0 : sin_a * cos_b - cos_a * sin_b;
    };
    const Vec3 wi = dist2 > 0 ? v / std::sqrt(dist2) : Vec3{0, 0, 1};
    double cos_w = dot(w, wi);
    if (two_sided) cos_w = std::abs(cos_w);
    const double sin_w = safeSqrt(1 - cos_w * cos_w);
    // The cone of directions from p to the bounding sphere (boundSubtendedDirections).
    const double cos_b = dist2 < r2 ? -1.0 : safeSqrt(1 - r2 / dist2);
    const double sin_b = safeSqrt(1 - cos_b * cos_b);
    const double cos_x = cosSubClamped(sin_w, cos_w, sin_o, cos_o);
    const double sin_x = sinSubClamped(sin_w, cos_w, sin_o, cos_o);
    const double cos_p = cosSubClamped(sin_x, cos_x, sin_b, cos_b);
    if (cos_p <= cos_e) return 0;
    double imp = phi * cos_p / d2;
    if (n.x != 0 || n.y != 0 || n.z != 0) {
      const double cos_i = std::abs(dot(wi, n));
      const double sin_i = safeSqrt(1 - cos_i * cos_i);
      imp *= cosSubClamped(sin_i, cos_i, sin_b, cos_b);
    }
    return std::max(imp, 0.0);
  }
};

}  // namespace

double LightBounds::importance(const Vec3& p, const Vec3& n) const {
  return ImportanceBounds(*this)(p, n);
}

LightBounds unionBounds(const LightBounds& a, const LightBounds& b) {
  if (a.phi == 0) return b;
  if (b.phi == 0) return a;
  const DirectionCone cone = unionCones({a.w, a.cos_theta_o, false}, {b.w, b.cos_theta_o, false});
  LightBounds u;
  u.bounds = a.bounds;
  u.bounds.extend(b.bounds);
  u.w = cone.w;
  u.phi = a.phi + b.phi;
  u.cos_theta_o = cone.cos_theta;
  u.cos_theta_e = std::min(a.cos_theta_e, b.cos_theta_e);
  u.two_sided = a.two_sided || b.two_sided;
  return u;
}

namespace {

// ---- uniform and power ---------------------------------------------------------------------

class UniformLightSampler final : public LightSampler {
 public:
  explicit UniformLightSampler(const std::vector<const Light*>& lights) : lights_(lights) {}
  std::optional<SampledLight> sample(const LightSampleContext&, double u) const override {
    if (lights_.empty()) return std::nullopt;
    const size_t i = std::min(size_t(u * double(lights_.size())), lights_.size() - 1);
    return SampledLight{lights_[i], 1.0 / double(lights_.size())};
  }
  double pmf(const LightSampleContext&, const Light*) const override {
    return lights_.empty() ? 0 : 1.0 / double(lights_.size());
  }

 private:
  std::vector<const Light*> lights_;
};

class PowerLightSampler final : public LightSampler {
 public:
  explicit PowerLightSampler(const std::vector<const Light*>& lights) : lights_(lights) {
    std::vector<double> p(lights.size());
    double total = 0;
    for (size_t i = 0; i < lights.size(); ++i) {
      double w = lights[i]->power();
      if (!std::isfinite(w) || w < 0) w = 0;
      p[i] = w;
      total += w;
    }
    // pbrt-v4: all zero → uniform (PowerLightSampler's constructor).
    if (total == 0) std::fill(p.begin(), p.end(), 1.0), total = double(p.size());
    pmf_.resize(p.size());
    cdf_.resize(p.size());
    double c = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      pmf_[i] = p[i] / total;
      cdf_[i] = (c += pmf_[i]);
    }
  }
  std::optional<SampledLight> sample(const LightSampleContext&, double u) const override {
    if (lights_.empty()) return std::nullopt;
    size_t i = size_t(std::upper_bound(cdf_.begin(), cdf_.end(), u * cdf_.back()) - cdf_.begin());
    i = std::min(i, lights_.size() - 1);
    while (pmf_[i] == 0 && i > 0) --i;
    if (pmf_[i] == 0) return std::nullopt;
    return SampledLight{lights_[i], pmf_[i]};
  }
  double pmf(const LightSampleContext&, const Light* light) const override {
    const size_t i = size_t(light->index);
    return i < lights_.size() && lights_[i] == light ? pmf_[i] : 0;
  }

 private:
  std::vector<const Light*> lights_;
  std::vector<double> pmf_, cdf_;
};

// ---- BVH (pbrt-v4's BVHLightSampler) ---------------------------------------------------------

class BVHLightSampler final : public LightSampler {
 public:
  explicit BVHLightSampler(const std::vector<const Light*>& lights) {
    std::vector<std::pair<const Light*, LightBounds>> bvh_lights;
    for (const Light* l : lights) {
      std::optional<LightBounds> lb = l->bounds();
      if (!lb) {
        infinite_.push_back(l);
      } else if (lb->phi > 0 && std::isfinite(lb->phi)) {
        bvh_lights.push_back({l, *lb});
      }
    }
    leaf_of_.assign(lights.size(), -1);
    is_infinite_.assign(lights.size(), false);
    lights_ = lights;
    for (const Light* l : infinite_) is_infinite_[size_t(l->index)] = true;
    if (!bvh_lights.empty()) build(bvh_lights, 0, bvh_lights.size(), -1);
    p_infinite_ = double(infinite_.size()) / double(infinite_.size() + (nodes_.empty() ? 0 : 1));
  }

  std::optional<SampledLight> sample(const LightSampleContext& ctx, double u) const override {
    if (u < p_infinite_) {
      const double v = u / p_infinite_;
      const size_t i = std::min(size_t(v * double(infinite_.size())), infinite_.size() - 1);
      return SampledLight{infinite_[i], p_infinite_ / double(infinite_.size())};
    }
    if (nodes_.empty()) return std::nullopt;
    u = std::min((u - p_infinite_) / (1 - p_infinite_), kOneMinusEpsilon);
    double pmf = 1 - p_infinite_;
    int node = 0;
    for (;;) {
      const Node& nd = nodes_[size_t(node)];
      if (nd.leaf) {
        if (nd.ib(ctx.p, ctx.n) > 0) return SampledLight{nd.light, pmf};
        return std::nullopt;
      }
      const double c0 = nodes_[size_t(node + 1)].ib(ctx.p, ctx.n);
      const double c1 = nodes_[size_t(nd.second)].ib(ctx.p, ctx.n);
      if (c0 == 0 && c1 == 0) return std::nullopt;
      const double p0 = c0 / (c0 + c1);
      if (u < p0) {
        u = std::min(u / p0, kOneMinusEpsilon);
        pmf *= p0;
        node = node + 1;
      } else {
        u = std::min((u - p0) / (1 - p0), kOneMinusEpsilon);
        pmf *= 1 - p0;
        node = nd.second;
      }
    }
  }

  double pmf(const LightSampleContext& ctx, const Light* light) const override {
    const size_t li = size_t(light->index);
    if (li >= lights_.size() || lights_[li] != light) return 0;
    if (is_infinite_[li]) return p_infinite_ / double(infinite_.size());
    int node = leaf_of_[li];
    if (node < 0) return 0;  // not in the tree: no power
    if (nodes_[size_t(node)].ib(ctx.p, ctx.n) == 0) return 0;
    double pmf = 1;
    while (node != 0) {
      const int parent = nodes_[size_t(node)].parent;
      const double c0 = nodes_[size_t(parent + 1)].ib(ctx.p, ctx.n);
      const double c1 = nodes_[size_t(nodes_[size_t(parent)].second)].ib(ctx.p, ctx.n);
      const double c = node == parent + 1 ? c0 : c1;
      if (c == 0) return 0;
      pmf *= c / (c0 + c1);
      node = parent;
    }
    return pmf * (1 - p_infinite_);
  }

 private:
  struct Node {
    LightBounds lb;
    ImportanceBounds ib;           // lb, prepared for importance()
    const Light* light = nullptr;  // leaf
    int second = -1;               // interior: index of the second child (the first is next)
    int parent = -1;
    bool leaf = false;
  };

  // pbrt-v4's cost of a node for the split choice (BVHLightSampler::EvaluateCost): power times
  // the solid-angle measure of its emission cone times its surface area, times the box's
  // aspect along the split axis.
  static double cost(const LightBounds& b, const Bounds3& bounds, int dim) {
    const double theta_o = safeAcos(b.cos_theta_o), theta_e = safeAcos(b.cos_theta_e);
    const double theta_w = std::min(theta_o + theta_e, kPi);
    const double sin_o = safeSqrt(1 - b.cos_theta_o * b.cos_theta_o);
    const double m_omega =
        2 * kPi * (1 - b.cos_theta_o) + kPi / 2 *
                                            (2 * theta_w * sin_o - std::cos(theta_o - 2 * theta_w) -
                                             2 * theta_o * sin_o + b.cos_theta_o);
    const Vec3 d = diagonal(bounds);
    const double kr = d[dim] > 0 ? maxComponent(d) / d[dim] : 1;
    return b.phi * m_omega * kr * surfaceArea(b.bounds);
  }

  // Builds the subtree of lights [start, end); returns its node index and bounds.
  std::pair<int, LightBounds> build(std::vector<std::pair<const Light*, LightBounds>>& ls,
                                    size_t start, size_t end, int parent) {
    if (end - start == 1) {
      const int index = int(nodes_.size());
      Node n;
      n.lb = ls[start].second;
      n.ib = ImportanceBounds(n.lb);
      n.light = ls[start].first;
      n.leaf = true;
      n.parent = parent;
      nodes_.push_back(n);
      leaf_of_[size_t(n.light->index)] = index;
      return {index, n.lb};
    }
    Bounds3 bounds, centroids;
    for (size_t i = start; i < end; ++i) {
      bounds.extend(ls[i].second.bounds);
      centroids.extend(ls[i].second.centroid());
    }
    // Split by the least cost over 12 buckets per axis (pbrt-v4's buildBVH, including its
    // choice among the split positions after buckets 1..10 only).
    constexpr int kBuckets = 12;
    double min_cost = INFINITY;
    int best_bucket = -1, best_dim = -1;
    auto bucketOf = [&](const Vec3& c, int dim) {
      const double off = (c[dim] - centroids.min[dim]) / (centroids.max[dim] - centroids.min[dim]);
      return std::clamp(int(kBuckets * off), 0, kBuckets - 1);
    };
    for (int dim = 0; dim < 3; ++dim) {
      if (centroids.max[dim] == centroids.min[dim]) continue;
      LightBounds bucket[kBuckets];
      for (size_t i = start; i < end; ++i) {
        const int b = bucketOf(ls[i].second.centroid(), dim);
        bucket[b] = unionBounds(bucket[b], ls[i].second);
      }
      for (int i = 1; i < kBuckets - 1; ++i) {
        LightBounds b0, b1;
        for (int j = 0; j <= i; ++j) b0 = unionBounds(b0, bucket[j]);
        for (int j = i + 1; j < kBuckets; ++j) b1 = unionBounds(b1, bucket[j]);
        const double c = cost(b0, bounds, dim) + cost(b1, bounds, dim);
        if (c > 0 && c < min_cost) min_cost = c, best_bucket = i, best_dim = dim;
      }
    }
    size_t mid = (start + end) / 2;
    if (best_dim >= 0) {
      auto it = std::partition(
          ls.begin() + long(start), ls.begin() + long(end),
          [&](const auto& l) { return bucketOf(l.second.centroid(), best_dim) <= best_bucket; });
      mid = size_t(it - ls.begin());
      if (mid == start || mid == end) mid = (start + end) / 2;
    }
    const int index = int(nodes_.size());
    nodes_.push_back(Node{});
    nodes_[size_t(index)].parent = parent;
    auto c0 = build(ls, start, mid, index);
    auto c1 = build(ls, mid, end, index);
    nodes_[size_t(index)].second = c1.first;
    nodes_[size_t(index)].lb = unionBounds(c0.second, c1.second);
    nodes_[size_t(index)].ib = ImportanceBounds(nodes_[size_t(index)].lb);
    return {index, nodes_[size_t(index)].lb};
  }

  std::vector<const Light*> lights_, infinite_;
  std::vector<bool> is_infinite_;  ///< per light index
  std::vector<Node> nodes_;
  std::vector<int> leaf_of_;  ///< per light index: its leaf node, or -1
  double p_infinite_ = 0;
};

// pbrt-v4's ExhaustiveLightSampler: the BVH's importance of every light, every time.
class ExhaustiveLightSampler final : public LightSampler {
 public:
  explicit ExhaustiveLightSampler(const std::vector<const Light*>& lights) {
    for (const Light* l : lights) {
      if (auto lb = l->bounds()) {
        bounded_.push_back(l);
        bounds_.push_back(*lb);
      } else {
        infinite_.push_back(l);
      }
    }
    p_infinite_ = double(infinite_.size()) / double(infinite_.size() + (bounded_.empty() ? 0 : 1));
  }
  std::optional<SampledLight> sample(const LightSampleContext& ctx, double u) const override {
    if (u < p_infinite_) {
      const size_t i =
          std::min(size_t(u / p_infinite_ * double(infinite_.size())), infinite_.size() - 1);
      return SampledLight{infinite_[i], p_infinite_ / double(infinite_.size())};
    }
    u = std::min((u - p_infinite_) / (1 - p_infinite_), kOneMinusEpsilon);
    std::vector<double> imp(bounded_.size());
    double total = 0;
    for (size_t i = 0; i < bounded_.size(); ++i)
      total += imp[i] = bounds_[i].importance(ctx.p, ctx.n);
    if (total <= 0) return std::nullopt;
    double c = 0;
    for (size_t i = 0; i < bounded_.size(); ++i) {
      c += imp[i];
      if (u * total < c && imp[i] > 0)
        return SampledLight{bounded_[i], imp[i] / total * (1 - p_infinite_)};
    }
    for (size_t i = bounded_.size(); i-- > 0;)
      if (imp[i] > 0) return SampledLight{bounded_[i], imp[i] / total * (1 - p_infinite_)};
    return std::nullopt;
  }
  double pmf(const LightSampleContext& ctx, const Light* light) const override {
    for (const Light* l : infinite_)
      if (l == light) return p_infinite_ / double(infinite_.size());
    double total = 0, mine = 0;
    for (size_t i = 0; i < bounded_.size(); ++i) {
      const double imp = bounds_[i].importance(ctx.p, ctx.n);
      total += imp;
      if (bounded_[i] == light) mine = imp;
    }
    return total > 0 ? mine / total * (1 - p_infinite_) : 0;
  }

 private:
  std::vector<const Light*> bounded_, infinite_;
  std::vector<LightBounds> bounds_;
  double p_infinite_ = 0;
};

}  // namespace

const std::vector<std::string>& LightSampler::names() {
  static const std::vector<std::string> n = {"bvh", "power", "uniform", "exhaustive"};
  return n;
}

std::unique_ptr<LightSampler> LightSampler::create(const std::string& name,
                                                   const std::vector<const Light*>& lights) {
  if (name == "bvh") return std::make_unique<BVHLightSampler>(lights);
  if (name == "power") return std::make_unique<PowerLightSampler>(lights);
  if (name == "uniform") return std::make_unique<UniformLightSampler>(lights);
  if (name == "exhaustive") return std::make_unique<ExhaustiveLightSampler>(lights);
  throw Error(
      fmt::format("unknown light sampler \"{}\" (expected bvh, power, uniform or "
                  "exhaustive)",
                  name));
}

}  // namespace lensim::render
