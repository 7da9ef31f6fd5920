// The projective cameras (perspective, orthographic) and the spherical camera, built from the
// scene's camera and film descriptions with pbrt-v4's parameters.
#pragma once

#include <array>
#include <memory>

#include "lensim/camera/camera.h"
#include "lensim/util/transform.h"

namespace lensim::camera {

/// The screen window (x0, x1, y0, y1) a projective camera uses: the scene's `screenwindow`, or
/// pbrt's default from the frame aspect ratio (the shorter image axis spans [-1, 1]).
std::array<double, 4> screenWindow(const scene::Scene& scene);

/// Maps a raster position (pixels, full image, y down) to the screen window (y up).
Vec2 rasterToScreen(const scene::Scene& scene, const std::array<double, 4>& window, Vec2 raster);

/// `perspective`: `fov` (degrees, spanning the shorter image axis), `lensradius` and
/// `focaldistance` (scene units) for a thin lens.
std::unique_ptr<Camera> makePerspectiveCamera(const scene::Scene& scene);
/// `orthographic`: the screen window in camera-space units, optional thin lens.
std::unique_ptr<Camera> makeOrthographicCamera(const scene::Scene& scene);
/// `spherical`: the whole sphere of directions, equal-area (pbrt-v4's default) or
/// equirectangular (raster x: azimuth, raster y: polar angle from the camera's +y axis).
std::unique_ptr<Camera> makeSphericalCamera(const scene::Scene& scene);

}  // namespace lensim::camera
