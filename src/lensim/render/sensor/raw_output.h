// Writing a raw film's image (Film "raw"): the film holds each pixel's expected photo-electrons
// per colour channel (R, G, B); the sensor's noise and electronics are applied here, once, when
// the final image is written (by lensim render, or by lensim merge for a split render).
#pragma once

#include <map>
#include <string>

#include "lensim/io/image.h"
#include "lensim/scene/sensor_config.h"

namespace lensim::scene {
struct Scene;
}
namespace lensim::camera {
class Camera;
}

namespace lensim::render {

/// Metadata keys a raw film's image carries (also through parts to lensim merge).
inline constexpr const char* kRawSensorKey = "lensim:raw_sensor";  ///< SensorConfig::toText
inline constexpr const char* kRawLensKey = "lensim:raw_lens";      ///< lens title
inline constexpr const char* kRawFNumberKey = "lensim:raw_fnumber";
inline constexpr const char* kRawFocalKey = "lensim:raw_focal_mm";
inline constexpr const char* kRawWhiteBalanceKey = "lensim:raw_whitebalance";
/// A QE file's content, so that lensim merge does not need the file.
inline constexpr const char* kRawQeKey = "lensim:raw_qe";

/// The sensor of a scene's Film "raw" as rendered: exposure time from the camera's shutter
/// interval (1 s if none), the film's ISO, the noise seed from the sampler's seed and the film's
/// "noiseseed", and the irradiance scale from the film's "nits": the film of a realistic camera
/// records spectral irradiance, that of a camera without a lens radiance, which "fnumber" N (4 if
/// not given) turns into irradiance as pi / (4 N^2).
scene::SensorConfig rawSensorConfig(const scene::Scene& scene);
/// The metadata a raw film's image carries (the keys above).
std::map<std::string, std::string> rawMetadata(const scene::Scene& scene,
                                               const scene::SensorConfig& config);

/// The lens metadata (EXIF FocalLength, FNumber, LensModel) of the camera rendering a raw film:
/// for a realistic camera its lens's paraxial effective focal length, its f-number at the set
/// aperture (EFL / entrance pupil diameter, focused at infinity) and its title (the lens file's
/// first comment line, else its name); none for a camera without a lens (pinhole, perspective).
std::map<std::string, std::string> rawLensMetadata(const camera::Camera& camera);

/// Whether the image is a raw film's (carries kRawSensorKey).
bool isRawImage(const io::Image& image);
/// A raw film's image of expected electrons as linear sRGB, noise free and without the mosaic:
/// lensim develop's linearisation, white balance (AsShotNeutral) and colour (ColorMatrix2) on
/// each pixel's three channels (serve's preview of a raw film). Other images are returned as
/// they are.
io::Image previewRawImage(const io::Image& image);

/// Whether `path` names a DNG file (by extension, case-insensitive).
bool isDngPath(const std::string& path);

/// Writes a raw film's image whose top-left pixel is (x0, y0) of the full image: a .dng (the DN
/// mosaic with the colour calibration), or an .exr with channels R, G, B (expected electrons per
/// channel), "electrons" (the noise-free mosaic) and "DN" (the noisy raw values), then a lens-flare
/// render's ghost layer (ghost.R, ghost.G, ghost.B: the ghost paths' part of R, G, B); throws
/// lensim::Error for another extension.
void writeRawImage(const std::string& path, const io::Image& image, int x0, int y0);

}  // namespace lensim::render
