// `lensim merge OUT PART...`: the exact sum of the parts of a distributed render.
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "lensim/io/image.h"
#include "lensim/render/parts.h"
#include "lensim/render/sensor/raw_output.h"
#include "lensim/util/error.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

void registerMergeCommand(CLI::App& app, Action& action) {
  struct Options {
    std::string out;
    std::vector<std::string> parts;
    bool keep_sums = false, partial_samples = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* m = app.add_subcommand(
      "merge",
      "Merge the parts of a distributed render (lensim render --tile / --spp-range) exactly into "
      "one image");
  m->add_option("output", o->out,
                "Merged image (.exr, .tif, .png), written atomically; the same pixels as one "
                "render of the whole")
      ->required();
  m->add_option("parts", o->parts, "Part files (EXR) written by lensim render --tile/--spp-range")
      ->required();
  m->add_flag("--part", o->keep_sums,
              "Write the output as a part (exact sums) so it can be merged again, e.g. with "
              "more sample slices");
  m->add_flag("--partial-samples", o->partial_samples,
              "Accept parts that hold only some of the samples per pixel, the same contiguous "
              "range in every pixel (progressive sample splitting: a preview, or with --part a "
              "part to merge with the other slices later)");
  m->callback([o, &action]() {
    action = [o]() -> int {
      std::vector<render::Part> parts;
      parts.reserve(o->parts.size());
      if (o->keep_sums && io::imageFormatFromPath(o->out) != io::ImageFormat::Exr)
        throw Error(FileLoc{o->out}, "--part writes an EXR part: use an .exr output");
      if (!render::isDngPath(o->out)) io::imageFormatFromPath(o->out);  // fail before reading
      for (const std::string& p : o->parts) parts.push_back(render::readPart(p));
      render::Part merged = render::mergeParts(parts, o->partial_samples);
      merged.metadata["lensim:merged_parts"] = std::to_string(parts.size());
      if (o->keep_sums) {
        render::writePart(o->out, merged);
      } else {
        io::Image im = render::sumsImage(merged.bounds, merged.sums, merged.ghost_sums);
        for (const auto& [key, value] : merged.metadata)
          if (key != "lensim:part") im.metadata[key] = value;
        // A raw film's parts hold expected electrons: the sensor's noise is applied here, once.
        if (render::isRawImage(im))
          render::writeRawImage(o->out, im, merged.bounds.x0, merged.bounds.y0);
        else if (render::isDngPath(o->out))
          throw Error(FileLoc{o->out}, "a .dng output needs the parts of a Film \"raw\" render");
        else
          io::writeImage(o->out, im);
      }
      if (!lensim::quiet())
        logInfo(fmt::format("merged {} parts into {} ({}x{}, {} spp)", parts.size(), o->out,
                            merged.bounds.width(), merged.bounds.height(),
                            merged.metadata["lensim:spp_total"]));
      return 0;
    };
  });
}

}  // namespace lensim::cmd
