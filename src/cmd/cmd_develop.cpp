// `lensim develop RAW.dng -o OUT`: lensim's simple raw pipeline (render/sensor/develop.h).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cmath>
#include <memory>
#include <string>

#include "commands.h"
#include "lensim/io/dng.h"
#include "lensim/io/image.h"
#include "lensim/render/sensor/develop.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

void registerDevelopCommand(CLI::App& app, Action& action) {
  struct Options {
    std::string in, out;
    double exposure = 0;
    bool ignore_w = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* d = app.add_subcommand(
      "develop",
      "Develop a raw DNG (as Film \"raw\" writes) to an image: white balance, Malvar-He-Cutler "
      "demosaic, the DNG's colour matrix to sRGB, sRGB tone curve (docs/sensor.md)");
  d->add_option("raw", o->in, "The DNG file (uncompressed 16-bit CFA or LinearRaw)")->required();
  d->add_option("-o,--outfile", o->out, "Output image (.png, .jpg, .tif, .exr: linear)")
      ->required();
  d->add_option("--exposure", o->exposure, "Exposure correction in stops (EV)");
  d->add_flag("--ignore-w", o->ignore_w,
              "RGBW: leave the W pixels out (by default they give the luminance with R + G + B)");
  d->callback([o, &action]() {
    action = [o]() -> int {
      io::imageFormatFromPath(o->out);  // fail before reading
      if (!std::isfinite(o->exposure) || std::abs(o->exposure) > 64)
        throw Error(fmt::format("--exposure {}: expected a number of stops in [-64, 64]",
                                o->exposure));
      const io::DngImage raw = io::readDng(o->in);
      io::writeImage(o->out, render::developRaw(raw, o->exposure,
                                                     o->ignore_w ? render::WPixels::kIgnore
                                                                 : render::WPixels::kLuminance));
      if (!lensim::quiet())
        logInfo(fmt::format("developed {} into {} ({}x{})", o->in, o->out, raw.width,
                            raw.height));
      return 0;
    };
  });
}

}  // namespace lensim::cmd
