// The realistic camera's options that a scene sets and the camera takes as they are: lensim's
// extras to pbrt's `realistic` camera (docs/scene-support.md). One definition for both the scene
// description (scene::Realistic) and the camera's settings (camera::RealisticSettings), which
// derive from it, so that a new option is declared once and reaches the camera by one assignment.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lensim/optics/tilt_shift.h"
#include "lensim/util/error.h"

namespace lensim::scene {

struct RealisticOptions {
  /// pbrt-v3's "simpleweighting" (its default true in v1–v3 files; false, irradiance, in v4):
  /// pixel values on a pinhole camera's scale instead of film irradiance. The weight is
  /// T cos^4(theta) A / A0, A0 the sampled region's area at the centre of the film (pbrt-v3 used
  /// cos^4(theta) alone, which loses the vignetting its bounds leave out): a flat field of
  /// radiance L reads about L at the centre (L times the mean cos^4 of the rays and the share of
  /// the centre's samples that get through: 0.94 for the double Gauss at f/4) and falls off
  /// toward the corners as the irradiance does.
  bool simple_weighting = false;
  /// "bool glassmatch": every element of the lens gets the catalogue glass nearest to its index
  /// (and V_d), as `lens info --glass-match` does, so an old lens disperses.
  bool glass_match = false;
  /// "bool glassabsorption": each wavelength of a camera ray is weighed by the internal
  /// transmittance (catalogue `IT` data) of its path through the lens's glasses
  /// (optics/absorption.h). Glasses without transmittance data absorb nothing.
  bool glass_absorption = true;
  /// A multi-configuration (zoom) lens: "integer configuration" N (1-based), or "float
  /// focallength", the focal length in mm the spacings are interpolated for
  /// (optics/configurations.h). zoom_loc: the parameter, for errors.
  std::optional<int> configuration;
  std::optional<double> zoom_focal_length_mm;
  FileLoc zoom_loc;
  /// Tilt and shift ("lensshift" [x y] mm and "lenstilt" [x y] degrees; optics/tilt_shift.h):
  /// the lens placed off the film's centre and turned against it; camera space is then the
  /// film's frame. tilt_shift_loc: the parameter, for errors.
  optics::TiltShift tilt_shift;
  FileLoc tilt_shift_loc;
  /// Lens flare ("bool flare"; docs/flare.md): reflection losses in every camera ray's weight
  /// and a two-reflection ghost path per sample. flare_coating ("string flarecoating"): the
  /// lens-wide coating instead of the lens file's (as `lens ghosts --coating`); empty: the lens
  /// file's. The locations, for errors.
  bool flare = false;
  std::string flare_coating;
  FileLoc flare_loc, flare_coating_loc;
  /// An as-built lens ("string tolerances", a design job, and "integer asbuilt"; docs/design.md):
  /// Monte Carlo build `as_built` of the job's tolerancing, as `lens tolerance --write-builds`
  /// writes it, replaces the lens file, which must be the job's lens. tolerance_loc: for errors.
  std::string tolerance_job;
  int as_built = -1;
  FileLoc tolerance_loc;
  /// A diagnostic ("string flareghosts" "I,J;I,J"): render only these ghost pairs (first
  /// reflection at I, then at J, as `lens ghosts` lists them); empty: all. Checked against the
  /// lens at setup (a pair that reflects nothing is refused at flare_ghosts_loc).
  std::vector<std::pair<int, int>> flare_ghosts;
  FileLoc flare_ghosts_loc;
};

}  // namespace lensim::scene
