// One factory for the camera family: an explicit switch on the type name.
#include <fmt/format.h>

#include "lensim/camera/camera.h"
#include "lensim/camera/projective.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::camera {

AnimatedTransform worldFromCamera(const scene::Scene& scene) {
  const scene::Camera& c = scene.camera;
  return AnimatedTransform(inverse(c.camera_from_world), c.transform_start_time,
                           inverse(c.camera_from_world_end), c.transform_end_time);
}

std::unique_ptr<Camera> makeCamera(const scene::Scene& scene, const CameraOptions& options) {
  const scene::Camera& c = scene.camera;
  if (c.type == "realistic") return makeRealisticCamera(scene, options);
  if (c.type == "perspective") return makePerspectiveCamera(scene);
  if (c.type == "orthographic") return makeOrthographicCamera(scene);
  if (c.type == "spherical") return makeSphericalCamera(scene);
  throw Error(c.loc, fmt::format("camera \"{}\" is not rendered yet", c.type));
}

}  // namespace lensim::camera
