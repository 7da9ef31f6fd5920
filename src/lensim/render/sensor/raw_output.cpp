// Raw film output (raw_output.h).
#include "lensim/render/sensor/raw_output.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>

#include <fmt/format.h>

#include "lensim/camera/realistic.h"
#include "lensim/io/dng.h"
#include "lensim/render/film/film.h"
#include "lensim/render/film/pixel_sensor.h"
#include "lensim/render/sensor/cfa_interpolate.h"
#include "lensim/render/sensor/develop.h"
#include "lensim/render/sensor/remosaic.h"
#include "lensim/render/sensor/sensor_color.h"
#include "lensim/render/sensor/sensor_model.h"
#include "lensim/render/spectra/spectrum.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"
#include "lensim/util/file.h"

namespace lensim::render {

namespace {

double metaNumber(const io::Image& im, const char* key) {
  auto it = im.metadata.find(key);
  if (it == im.metadata.end()) return 0;
  try {
    return std::stod(it->second);
  } catch (const std::exception&) {
    return 0;
  }
}

std::string lowerExtension(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || path.find('/', dot) != std::string::npos) return "";
  std::string e = path.substr(dot + 1);
  for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace

scene::SensorConfig rawSensorConfig(const scene::Scene& scene) {
  const scene::Film& f = scene.film;
  SensorConfig c = f.raw_sensor;
  const double shutter = scene.camera.shutter_close - scene.camera.shutter_open;
  c.exposure_s = shutter > 0 ? shutter : 1;
  c.iso = f.iso;
  c.seed = uint64_t(uint32_t(scene.sampler.seed)) * 0x100000000ULL + uint32_t(f.raw_noise_seed);
  // Luminance L_v = 683 lm/W x integral(L ybar); lensim's unit radiance has
  // integral(L ybar) = CIE_Y_integral (its spectra have unit luminance Y).
  double scale = f.raw_nits / (683.0 * cieYIntegral());
  const bool irradiance = scene.camera.realistic && !scene.camera.realistic->simple_weighting;
  if (!irradiance) {
    const double n = f.raw_fnumber > 0 ? f.raw_fnumber : 4;
    scale *= M_PI / (4 * n * n);
  }
  c.irradiance_scale = scale;
  return c;
}

std::map<std::string, std::string> rawMetadata(const scene::Scene& scene,
                                               const SensorConfig& config) {
  std::map<std::string, std::string> m;
  m[kRawSensorKey] = config.toText();
  const auto& names = cameraSensorNames();
  if (std::find(names.begin(), names.end(), config.qe) == names.end())
    m[kRawQeKey] = readRegularFile(config.qe, "QE file", uint64_t{16} << 20);
  const scene::Film& f = scene.film;
  if (f.white_balance_k > 0) m[kRawWhiteBalanceKey] = fmt::format("{:.17g}", f.white_balance_k);
  return m;
}

std::map<std::string, std::string> rawLensMetadata(const camera::Camera& camera) {
  std::map<std::string, std::string> m;
  const auto* realistic = dynamic_cast<const camera::RealisticCamera*>(&camera);
  if (!realistic) return m;
  const optics::FocusedLens& lens = realistic->lens();
  const double efl = lens.paraxial.effective_focal_length_mm, n = lens.paraxial.f_number;
  if (std::isfinite(efl) && efl > 0) m[kRawFocalKey] = fmt::format("{:.17g}", efl);
  if (std::isfinite(n) && n > 0) m[kRawFNumberKey] = fmt::format("{:.17g}", n);
  if (!lens.lens->prescription().name.empty()) m[kRawLensKey] = lens.lens->prescription().name;
  return m;
}

bool isRawImage(const io::Image& image) { return image.metadata.count(kRawSensorKey) > 0; }

io::Image previewRawImage(const io::Image& image) {
  auto it = image.metadata.find(kRawSensorKey);
  if (it == image.metadata.end() || image.channelCount() < 3) return image;
  auto qe = image.metadata.find(kRawQeKey);
  const SensorModel model(SensorConfig::fromText(it->second), FileLoc{},
                          qe == image.metadata.end() ? nullptr : &qe->second);
  const SensorConfig& cfg = model.config();
  // Electrons to the linearised raw value (DN above black over the DN range).
  const double scale = cfg.gainDnPerE() / double(cfg.whiteLevel() - cfg.black_level_dn);
  Mat3d m = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 3> neutral{1, 1, 1};
  if (!model.cfa().mono) {
    const DngColor col = fitDngColor(model, metaNumber(image, kRawWhiteBalanceKey));
    m = srgbFromCamera(col.color_matrix2);
    neutral = {col.as_shot_neutral.x, col.as_shot_neutral.y, col.as_shot_neutral.z};
  }
  io::Image out(image.width, image.height, {"R", "G", "B"});
  out.metadata = image.metadata;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      Vec3 v;
      if (model.cfa().mono) {
        v = Vec3{1, 1, 1} * (image.at(x, y, 0) * scale);
      } else {
        v = mulMat3(m, Vec3{image.at(x, y, 0) * scale / neutral[0],
                            image.at(x, y, 1) * scale / neutral[1],
                            image.at(x, y, 2) * scale / neutral[2]});
      }
      out.at(x, y, 0) = float(std::max(0.0, v.x));
      out.at(x, y, 1) = float(std::max(0.0, v.y));
      out.at(x, y, 2) = float(std::max(0.0, v.z));
    }
  return out;
}

bool isDngPath(const std::string& path) { return lowerExtension(path) == "dng"; }

void writeRawImage(const std::string& path, const io::Image& image, int x0, int y0) {
  auto it = image.metadata.find(kRawSensorKey);
  if (it == image.metadata.end())
    throw Error(FileLoc{path}, "not a raw film's image (no sensor description)");
  const std::string ext = lowerExtension(path);
  if (ext != "dng" && ext != "exr")
    throw Error(FileLoc{path}, fmt::format("Film \"raw\" writes .dng or .exr files; got \".{}\"",
                                           ext));
  auto qe = image.metadata.find(kRawQeKey);
  const SensorModel model(SensorConfig::fromText(it->second), FileLoc{},
                          qe == image.metadata.end() ? nullptr : &qe->second);
  const SensorConfig& cfg = model.config();
  const int w = image.width, h = image.height;
  if (image.channelCount() < 3)
    throw Error(FileLoc{path}, "a raw film's image needs its R, G, B electron channels");
  std::vector<float> rgb(size_t(w) * size_t(h) * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) rgb[(size_t(y) * size_t(w) + size_t(x)) * 3 + size_t(c)] =
          image.at(x, y, c);
  const std::vector<uint16_t> dn = digitizeImage(model, rgb, w, h, x0, y0);
  if (ext == "exr") {
    // Lens flare: the ghost layer's expected electrons (already in R, G, B) after the others.
    std::vector<std::string> channels = {"R", "G", "B", "electrons", "DN"};
    std::array<int, 3> ghost{-1, -1, -1};
    for (int c = 0; c < 3; ++c)
      if (const auto i = image.channelIndex(Film::ghostChannels()[size_t(c)])) {
        ghost[size_t(c)] = *i;
        channels.push_back(Film::ghostChannels()[size_t(c)]);
      }
    io::Image out(w, h, std::move(channels));
    out.metadata = image.metadata;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = image.at(x, y, c);
        for (int c = 0, k = 5; c < 3; ++c)
          if (ghost[size_t(c)] >= 0) out.at(x, y, k++) = image.at(x, y, ghost[size_t(c)]);
        out.at(x, y, 3) = float(SensorModel::channelElectrons(
            cfaChannel(model.cfa(), x0 + x, y0 + y),
            {image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2)}));
        out.at(x, y, 4) = float(dn[size_t(y) * size_t(w) + size_t(x)]);
      }
    io::writeImage(path, out);
    return;
  }
  io::DngImage d;
  d.width = w;
  d.height = h;
  d.data = dn;
  const CfaPattern& cfa = model.cfa();
  d.mono = cfa.mono;
  if (!d.mono && cfg.dng_cfa == "bayer" && !isBayerTile(cfa.width, cfa.height, cfa.colors)) {
    // Remosaiced to RGGB (from the full image's top-left pixel), stated in ImageDescription.
    d.data = remosaicToBayer(dn, w, h, cfa, x0, y0, cfg.black_level_dn, cfg.whiteLevel());
    d.description = fmt::format("Bayer RGGB remosaic by lensim of the sensor's {}x{} CFA {} "
                                "(tent-weighted normalised convolution; W pixels unused)",
                                cfa.width, cfa.height, cfa.text());
    d.cfa.clear();
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) d.cfa.push_back(uint8_t(bayerChannel(x0 + x, y0 + y)));
  } else if (!d.mono) {
    scene::checkDngCfa(cfa, FileLoc{path});
    // The written image's tile starts at (x0, y0) of the full image's. A tile one pixel wide is
    // written two wide: dcraw and LibRaw read a CFAPattern as rows of two columns.
    d.cfa_width = cfa.width == 1 ? 2 : cfa.width;
    d.cfa_height = cfa.height;
    d.cfa.clear();
    for (int y = 0; y < d.cfa_height; ++y)
      for (int x = 0; x < d.cfa_width; ++x) {
        const int c = cfa.channel(x0 + x, y0 + y);
        d.cfa.push_back(uint8_t(c == CfaPattern::kW ? 6 : c));  // TIFF/EP: 6 white
      }
  }
  d.bits = cfg.adc_bits;
  d.black_level = uint32_t(cfg.black_level_dn);
  d.white_level = uint32_t(cfg.whiteLevel());
  if (!d.mono) {
    const DngColor col = fitDngColor(model, metaNumber(image, kRawWhiteBalanceKey));
    std::copy(col.color_matrix1.begin(), col.color_matrix1.end(), d.color_matrix1.begin());
    std::copy(col.color_matrix2.begin(), col.color_matrix2.end(), d.color_matrix2.begin());
    std::copy(col.forward_matrix1.begin(), col.forward_matrix1.end(), d.forward_matrix1.begin());
    std::copy(col.forward_matrix2.begin(), col.forward_matrix2.end(), d.forward_matrix2.begin());
    d.as_shot_neutral = {col.as_shot_neutral.x, col.as_shot_neutral.y, col.as_shot_neutral.z};
    d.w_color_row1 = {col.w_color_row1.x, col.w_color_row1.y, col.w_color_row1.z};
    d.w_color_row2 = {col.w_color_row2.x, col.w_color_row2.y, col.w_color_row2.z};
    d.w_neutral = col.w_neutral;
    d.illuminant1 = DngColor::kIlluminant1;
    d.illuminant2 = DngColor::kIlluminant2;
  }
  d.model = "lensim sensor " + cfg.qe;
  d.unique_model = "lensim " + cfg.qe;
  d.exposure_s = cfg.exposure_s;
  d.iso = cfg.iso;
  d.f_number = metaNumber(image, kRawFNumberKey);
  d.focal_length_mm = metaNumber(image, kRawFocalKey);
  if (auto l = image.metadata.find(kRawLensKey); l != image.metadata.end()) d.lens_model = l->second;
  io::writeDng(path, d);
}

}  // namespace lensim::render
