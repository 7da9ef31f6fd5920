// `lensim compare IMAGE REFERENCE`: is a render the reference within noise? Block means, their
// standard errors, a Bonferroni-corrected per-block z-test (lensim/render/image_compare.h).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "lensim/io/image.h"
#include "lensim/render/image_compare.h"

namespace lensim::cmd {

namespace {

/// Bit-for-bit equality of the R, G, B channels; prints the verdict, returns the exit status.
int compareExact(const io::Image& a, const io::Image& b) {
  if (a.width != b.width || a.height != b.height) {
    std::printf("differ: sizes %dx%d and %dx%d\n", a.width, a.height, b.width, b.height);
    return 1;
  }
  long long differing = 0;
  std::string first;
  for (const char* name : {"R", "G", "B"}) {
    const auto ca = a.channelIndex(name), cb = b.channelIndex(name);
    if (!ca || !cb) {
      std::printf("differ: channel %s missing\n", name);
      return 1;
    }
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x) {
        const float va = a.at(x, y, *ca), vb = b.at(x, y, *cb);
        if (std::memcmp(&va, &vb, sizeof va) != 0) {
          if (differing++ == 0)
            first = fmt::format("first at ({}, {}) {}: {:.9g} vs {:.9g}", x, y, name, va, vb);
        }
      }
  }
  if (differing) {
    std::printf("differ: %lld of %lld values; %s\n", differing, 3LL * a.width * a.height,
                first.c_str());
    return 1;
  }
  std::printf("identical: %dx%d pixels, R G B bit for bit\n", a.width, a.height);
  return 0;
}

}  // namespace

void registerCompareCommand(CLI::App& app, Action& action) {
  struct Options {
    std::string image, reference, second, reference_low;
    render::CompareOptions c;
    render::VerdictOptions v;
    bool json = false, exact = false;
    int list = 10;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "Compare a render with a reference image: block means, z-test within noise");
  cmd->add_option("image", o->image, "The render (EXR, TIFF or PNG)")->required();
  cmd->add_option("reference", o->reference, "The reference image")->required();
  cmd->add_option("--second", o->second,
                  "The same render with another seed: gives the render's noise (needed for "
                  "the z-test)");
  cmd->add_option("--spp", o->c.spp, "Samples per pixel of each render")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--reference-spp", o->c.reference_spp, "Samples per pixel of the reference")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--reference-low", o->reference_low,
                  "The reference's renderer at fewer samples: gives the reference's noise");
  cmd->add_option("--reference-low-spp", o->c.reference_low_spp,
                  "Samples per pixel of --reference-low")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--block", o->c.block, "Block side in pixels (default 10)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--family-error", o->c.family_error,
                  "Family-wise error rate of the z-test over all blocks (default 0.01)")
      ->check(CLI::Range(1e-12, 0.5));
  cmd->add_option("--list", o->list, "Blocks beyond the bound to list (default 10)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--max-fail-share", o->v.max_fail_share,
                  "With --second: share of blocks allowed beyond the z bound and still pass "
                  "(default 0)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--tolerance", o->v.tolerance,
                  "Without --second: largest |mean ratio - 1| and mean |block difference| "
                  "(relative) that pass (default 0.05)")
      ->check(CLI::Range(0.0, 1e9));
  cmd->add_flag("--json", o->json, "Print one JSON object");
  cmd->add_flag("--exact", o->exact,
                "Check that the R, G, B values are equal bit for bit (e.g. a merged distributed "
                "render and a single render); exit status 1 when they are not");
  cmd->footer(
      "Exit status: 0 if the render passes (a line \"verdict: PASS ...\"), 1 if it fails "
      "(\"verdict: FAIL ...\") or on an error (a message and no verdict).");
  cmd->callback([o, &action]() {
    action = [o]() -> int {
      const io::Image image = io::readImage(o->image);
      const io::Image reference = io::readImage(o->reference);
      if (o->exact) return compareExact(image, reference);
      std::optional<io::Image> second, low;
      render::CompareOptions c = o->c;
      if (!o->second.empty()) c.second = &second.emplace(io::readImage(o->second));
      if (!o->reference_low.empty())
        c.reference_low = &low.emplace(io::readImage(o->reference_low));
      const render::CompareResult r = render::compareImages(image, reference, c);
      const render::Verdict v = render::verdict(r, o->v);
      if (!o->json) {
        const std::string text = render::formatCompare(r, o->list);
        std::fwrite(text.data(), 1, text.size(), stdout);
        std::printf("verdict: %s (%s)\n", v.pass ? "PASS" : "FAIL", v.reason.c_str());
        return v.pass ? 0 : 1;
      }
      nlohmann::json j;
      j["blocks"] = r.blocks;
      j["block_size"] = c.block;
      j["mean_ratio"] = r.mean_ratio;
      j["mean_abs_block_difference_rel"] = r.mad_rel;
      if (r.has_noise) {
        j["reference_noise"] = r.reference_noise;
        j["z_bound"] = r.z_bound;
        j["z_failures"] = r.z_failures;
        j["outliers"] = r.outliers;
        nlohmann::json f = nlohmann::json::array();
        for (const auto& b : r.failing)
          f.push_back({{"bx", b.bx},
                       {"by", b.by},
                       {"render", b.test},
                       {"reference", b.reference},
                       {"z", b.z}});
        j["failing_blocks"] = f;
      }
      j["verdict"] = v.pass ? "pass" : "fail";
      j["verdict_reason"] = v.reason;
      std::printf("%s\n", j.dump(2).c_str());
      return v.pass ? 0 : 1;
    };
  });
}

}  // namespace lensim::cmd
