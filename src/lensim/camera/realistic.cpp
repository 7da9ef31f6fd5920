// The realistic camera is being written (issue 6); until then the factory reports it clearly.
#include "lensim/camera/camera.h"
#include "lensim/scene/builder.h"
#include "lensim/util/error.h"

namespace lensim::camera {

std::unique_ptr<Camera> makeRealisticCamera(const scene::Scene& scene) {
  throw Error(scene.camera.loc, "the realistic camera is not available in this build yet");
}

}  // namespace lensim::camera
