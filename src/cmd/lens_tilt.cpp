#include "lens_tilt.h"

#include <fmt/format.h>

#include <cmath>
#include <iostream>

#include "lens_options.h"
#include "lensim/util/error.h"

namespace lensim::cmd {

using nlohmann::json;

optics::TiltShift parseTiltShift(const std::string& tilt, const std::string& shift) {
  optics::TiltShift ts;
  if (!tilt.empty()) {
    try {
      ts.tilt_deg = parsePair(tilt, "--tilt");
    } catch (const Error&) {
      throw Error(fmt::format("--tilt '{}': expected two numbers X,Y (degrees)", tilt));
    }
    for (double a : {ts.tilt_deg.x, ts.tilt_deg.y})
      if (!(std::abs(a) < 45))
        throw Error(
            fmt::format("--tilt '{}': {} degrees is out of range; expected tilt angles "
                        "within +-45 degrees",
                        tilt, a));
  }
  if (!shift.empty()) {
    ts.shift_mm = parsePair(shift, "--shift");
    for (double s : {ts.shift_mm.x, ts.shift_mm.y})
      if (!(std::abs(s) <= 1000))
        throw Error(
            fmt::format("--shift '{}': {} mm is out of range; expected shifts within "
                        "+-1000 mm",
                        shift, s));
  }
  return ts;
}

void printTiltShift(const optics::FocusedLens& fl, const optics::TiltShift& ts,
                    double film_diagonal_mm) {
  auto line = [](const std::string& k, const std::string& v) {
    std::cout << fmt::format("  {:<26}{}\n", k, v);
  };
  line("lens shift", fmt::format("({:g}, {:g}) mm: the axis meets the film there; the film "
                                 "reaches {:.3f} mm from the axis",
                                 ts.shift_mm.x, ts.shift_mm.y,
                                 film_diagonal_mm / 2 + std::hypot(ts.shift_mm.x, ts.shift_mm.y)));
  if (!ts.tilted()) return;
  const optics::FilmPlacement placement(ts, fl.lens->filmZ_mm());
  const optics::ScheimpflugData s = optics::scheimpflug(fl.paraxial, placement);
  line("lens tilt", fmt::format("({:g}, {:g}) deg about the film's x, y: {:.4f} deg between the "
                                "film and the lens planes (lens space below)",
                                ts.tilt_deg.x, ts.tilt_deg.y, s.tilt_deg));
  line("hinge line",
       fmt::format("J = f / sin(tilt) = {:.4f} mm from the front nodal point; nearest point "
                   "({:.4f}, {:.4f}, {:.4f}) mm, direction ({:.4f}, {:.4f}, {:.4f})",
                   s.hinge_distance_mm, s.hinge_point_mm.x, s.hinge_point_mm.y, s.hinge_point_mm.z,
                   s.hinge_direction.x, s.hinge_direction.y, s.hinge_direction.z));
  line("plane of focus",
       fmt::format("through the hinge line; meets the axis {}; {:.4f} deg to the film, {:.4f} deg "
                   "to the lens plane; normal ({:.5f}, {:.5f}, {:.5f}) (first-order)",
                   std::isfinite(s.object_distance_mm)
                       ? fmt::format("{:.4f} mm in front of the front principal plane (z = "
                                     "{:.4f})",
                                     s.object_distance_mm, s.focus_plane_axis_z_mm)
                       : std::string("at infinity"),
                   s.focus_plane_to_film_deg, s.focus_plane_to_lens_plane_deg,
                   s.focus_plane_normal.x, s.focus_plane_normal.y, s.focus_plane_normal.z));
}

}  // namespace lensim::cmd
