#include "lensim/camera/aperture.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lensim/io/image.h"
#include "lensim/util/error.h"

namespace lensim::camera {

namespace {
constexpr double kPi = std::numbers::pi;

// Distance from the centre to the boundary of a star-shaped polygon whose vertices alternate
// between radii r0 (at angles rot + 2 pi k / n) and r1 (half-way between), along angle phi.
double polygonReach(double phi, int n, double rot, double r0, double r1) {
  const double sector = 2 * kPi / n;
  double a = std::fmod(phi - rot, sector);
  if (a < 0) a += sector;
  // The edge runs from the vertex at angle 0 (radius r0) to the one at angle sector/2 (radius r1)
  // or, in the second half, from sector/2 (r1) to sector (r0).
  double a0 = 0, ra = r0, rb = r1, span = sector / 2;
  if (a > sector / 2) {
    a0 = sector / 2;
    ra = r1;
    rb = r0;
  }
  const Vec2 A{ra, 0}, B{rb * std::cos(span), rb * std::sin(span)};
  const double t = a - a0;
  const Vec2 w{std::cos(t), std::sin(t)};
  const Vec2 e = B - A;
  const double denom = e.x * w.y - e.y * w.x;  // cross(w, e) sign-flipped below
  const double num = e.x * A.y - e.y * A.x;
  return denom != 0 ? num / denom : ra;
}
}  // namespace

ApertureShape ApertureShape::round() {
  ApertureShape s;
  s.name_ = "round";
  return s;
}

ApertureShape ApertureShape::polygon(int blades, double rotation_deg) {
  if (blades < 3)
    throw Error(fmt::format("a polygonal stop needs at least 3 blades, not {}", blades));
  ApertureShape s;
  s.kind_ = Kind::Polygon;
  s.sides_ = blades;
  s.rotation_rad_ = rotation_deg * kPi / 180;
  // Area of a regular n-gon of circumradius R: n R^2 sin(2 pi / n) / 2 = pi.
  s.outer_ = std::sqrt(2 * kPi / (blades * std::sin(2 * kPi / blades)));
  s.extent_ = s.outer_;
  s.name_ = fmt::format("{} blades", blades);
  return s;
}

bool ApertureShape::isNamed(const std::string& name) {
  return name == "gaussian" || name == "square" || name == "pentagon" || name == "star";
}

ApertureShape ApertureShape::named(const std::string& name) {
  if (name == "square") {
    ApertureShape s = polygon(4, 45);
    s.name_ = "square";
    return s;
  }
  if (name == "pentagon") {
    ApertureShape s = polygon(5, 90);
    s.name_ = "pentagon";
    return s;
  }
  if (name == "star") {
    // A regular five-pointed star (pentagram outline): inner/outer radius = sin(18)/sin(126).
    ApertureShape s;
    s.kind_ = Kind::Star;
    s.sides_ = 5;
    s.rotation_rad_ = kPi / 2;
    const double ratio = std::sin(kPi / 10) / std::sin(7 * kPi / 10);
    // Area: 10 triangles of sides R and r with angle pi/5 between them = 5 R r sin(pi/5) = pi.
    s.outer_ = std::sqrt(kPi / (5 * ratio * std::sin(kPi / 5)));
    s.inner_ = ratio * s.outer_;
    s.extent_ = s.outer_;
    s.name_ = "star";
    return s;
  }
  if (name == "gaussian") {
    // exp(-r^2 / (2 (sigma E)^2)) inside radius E, with sigma = 0.5: 2 pi sigma^2 E^2 (1 - e^-2)
    // = pi gives E.
    ApertureShape s;
    s.kind_ = Kind::Gaussian;
    s.sigma_ = 0.5;
    s.extent_ =
        std::sqrt(1 / (2 * s.sigma_ * s.sigma_ * (1 - std::exp(-1 / (2 * s.sigma_ * s.sigma_)))));
    s.name_ = "gaussian";
    return s;
  }
  throw Error(
      fmt::format("unknown aperture \"{}\": expected gaussian, square, pentagon, star or an "
                  "image file",
                  name));
}

ApertureShape ApertureShape::image(const std::string& path) {
  io::Image img = io::readImage(path);
  ApertureShape s;
  s.kind_ = Kind::Image;
  s.width_ = img.width;
  s.height_ = img.height;
  const size_t nc = img.channels.size();
  s.texels_.resize(static_cast<size_t>(img.width) * img.height);
  double sum = 0;
  for (size_t i = 0; i < s.texels_.size(); ++i) {
    double v = 0;
    for (size_t c = 0; c < std::min<size_t>(nc, 3); ++c) v += img.pixels[i * nc + c];
    v /= static_cast<double>(std::min<size_t>(nc, 3));
    s.texels_[i] = static_cast<float>(std::clamp(v, 0.0, 1.0));
    sum += s.texels_[i];
  }
  const double mean = sum / s.texels_.size();
  if (!(mean > 0)) throw Error(FileLoc{path}, "aperture image is black: it would pass no light");
  // The image fills the square [-E, E]^2: area 4 E^2 mean = pi.
  s.extent_ = std::sqrt(kPi / (4 * mean)) * std::sqrt(2.0);  // reach of the square's corners
  s.outer_ = std::sqrt(kPi / (4 * mean));                    // half side of the square
  s.name_ = "image " + path;
  return s;
}

double ApertureShape::transmission(Vec2 p) const {
  const double r = std::hypot(p.x, p.y);
  switch (kind_) {
    case Kind::Round:
      return r <= 1 ? 1.0 : 0.0;
    case Kind::Polygon: {
      const double phi = std::atan2(p.y, p.x);
      // Edges of a regular polygon: the boundary along phi, from the vertex on either side.
      const double sector = 2 * kPi / sides_;
      double a = std::fmod(phi - rotation_rad_, sector);
      if (a < 0) a += sector;
      const double apothem = outer_ * std::cos(kPi / sides_);
      return r * std::cos(a - sector / 2) <= apothem ? 1.0 : 0.0;
    }
    case Kind::Star:
      return r <= polygonReach(std::atan2(p.y, p.x), sides_, rotation_rad_, outer_, inner_) ? 1.0
                                                                                            : 0.0;
    case Kind::Gaussian: {
      if (r > extent_) return 0.0;
      const double s = sigma_ * extent_;
      return std::exp(-r * r / (2 * s * s));
    }
    case Kind::Image: {
      // Bilinear lookup; image row 0 at the top (+y).
      const double u = (p.x / outer_ + 1) * 0.5 * width_ - 0.5;
      const double v = (1 - (p.y / outer_ + 1) * 0.5) * height_ - 0.5;
      if (u < -0.5 || v < -0.5 || u > width_ - 0.5 || v > height_ - 0.5) return 0.0;
      const int x0 = std::clamp(static_cast<int>(std::floor(u)), 0, width_ - 1);
      const int y0 = std::clamp(static_cast<int>(std::floor(v)), 0, height_ - 1);
      const int x1 = std::min(x0 + 1, width_ - 1), y1 = std::min(y0 + 1, height_ - 1);
      const double fx = std::clamp(u - x0, 0.0, 1.0), fy = std::clamp(v - y0, 0.0, 1.0);
      auto t = [&](int x, int y) {
        return static_cast<double>(texels_[static_cast<size_t>(y) * width_ + x]);
      };
      return (1 - fy) * ((1 - fx) * t(x0, y0) + fx * t(x1, y0)) +
             fy * ((1 - fx) * t(x0, y1) + fx * t(x1, y1));
    }
  }
  return 0.0;
}

std::string ApertureShape::describe() const {
  return name_;
}

}  // namespace lensim::camera
