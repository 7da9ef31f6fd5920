#include "targets.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <string>

#include "lensim/io/image.h"
#include "lensim/io/ply.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/optics/prescription.h"
#include "lensim/render/materials/fourier.h"
#include "lensim/render/materials/measured.h"
#include "lensim/render/materials/measured_rgl.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/scene/parser.h"
#include "lensim/scene/tokenizer.h"
#include "lensim/util/error.h"
#include "lensim/util/limits.h"
#include "lensim/util/log.h"

namespace lensim::fuzz {

namespace {

std::string_view text(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Runs `f`; lensim::Error is the expected answer to bad input.
template <class F>
int guarded(F&& f) {
  try {
    f();
  } catch (const Error&) {
  }
  return 0;
}

// A per-process scratch directory for the targets that read files by path.
const std::string& scratchDir() {
  static const std::string dir = [] {
    std::string d = "/tmp/lensim-fuzz-" + std::to_string(::getpid());
    ::mkdir(d.c_str(), 0700);
    return d;
  }();
  return dir;
}

std::string writeScratch(const std::string& name, const uint8_t* data, size_t size) {
  const std::string path = scratchDir() + "/" + name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace

void initFuzzing() {
  static std::once_flag once;
  std::call_once(once, [] {
    setMemoryBudgetBytes(uint64_t{256} << 20);
    setQuiet(true);
  });
}

int fuzzLens(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    optics::LensPrescription p = optics::parseLensPrescription(text(data, size), "fuzz.dat");
    optics::LensSetup setup;
    optics::FocusedLens fl = optics::focusLens(std::move(p), setup);
    (void)fl;
  });
}

// The Zemax reader (any bytes: BOMs, UTF-16 and the sequential keywords), then focusing.
int fuzzZmx(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    optics::LensPrescription p = optics::parseZmx(text(data, size), "fuzz.zmx");
    optics::LensSetup setup;
    optics::FocusedLens fl = optics::focusLens(std::move(p), setup);
    (void)fl;
  });
}

// The JSON lens reader (lensim's own format, ISET3d's, one lentil design), then focusing.
int fuzzLensJson(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    optics::LensPrescription p = optics::parseLensJson(text(data, size), "fuzz.json");
    optics::LensSetup setup;
    optics::FocusedLens fl = optics::focusLens(std::move(p), setup);
    (void)fl;
  });
}

int fuzzSceneTokens(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    scene::Tokenizer tok(text(data, size), "fuzz.pbrt");
    while (tok.next().kind != scene::Token::Kind::End) {
    }
  });
}

int fuzzSceneParse(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] { (void)scene::parseString(text(data, size), "fuzz.pbrt"); });
}

int fuzzSceneBuild(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    scene::SceneDesc desc = scene::parseString(text(data, size), scratchDir() + "/fuzz.pbrt");
    (void)scene::build(desc);
  });
}

int fuzzSceneRender(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    scene::SceneDesc desc = scene::parseString(text(data, size), scratchDir() + "/fuzz.pbrt");
    scene::Scene s = scene::build(desc);
    // Small and quick whatever the file asks for.
    s.film.x_resolution = 4;
    s.film.y_resolution = 4;
    render::RenderOptions ro;
    ro.spp = 1;
    ro.threads = 1;
    ro.progress = false;
    (void)render::render(s, ro);
  });
}

int fuzzPly(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] { (void)io::parsePly(std::string(text(data, size)), "fuzz.ply"); });
}

int fuzzImage(const uint8_t* data, size_t size) {
  initFuzzing();
  // The format by the file's magic number, as a user's file would be named; TGA has none (its
  // third byte is the image type, 1-3 or 9-11).
  const char* ext = ".png";
  if (size >= 4 && data[0] == 0x76 && data[1] == 0x2f) ext = ".exr";
  if (size >= 2 && ((data[0] == 'I' && data[1] == 'I') || (data[0] == 'M' && data[1] == 'M')))
    ext = ".tif";
  if (size >= 2 && data[0] == 'P' && (data[1] == 'F' || data[1] == 'f')) ext = ".pfm";
  if (size >= 2 && data[0] == '#' && data[1] == '?') ext = ".hdr";
  if (size >= 2 && data[0] == 0xff && data[1] == 0xd8) ext = ".jpg";
  if (size >= 18 && data[1] <= 1 &&
      ((data[2] >= 1 && data[2] <= 3) || (data[2] >= 9 && data[2] <= 11)))
    ext = ".tga";
  const std::string path = writeScratch(std::string("fuzz") + ext, data, size);
  return guarded([&] { (void)io::readImage(path); });
}

int fuzzBrdf(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    render::IrregularBRDFData d = render::parseIrregularBRDF(text(data, size), "fuzz.brdf");
    render::MeasuredBRDF::Options o;
    o.n_theta = 6;  // a small table: the fuzzer looks for bad data, not for speed
    o.n_phi = 5;
    render::MeasuredBRDF brdf(std::move(d), o);
    (void)brdf;
  });
}

int fuzzBsdf(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    const render::RGLMeasuredBRDF b =
        render::RGLMeasuredBRDF::parse(std::string(text(data, size)), "fuzz.bsdf");
    // A file that loads is evaluated and sampled a few times: tables that pass the checks must
    // give finite, non-negative values.
    const render::SampledWavelengths lambda = render::SampledWavelengths::sampleUniform(0.37);
    const Vec3 dirs[3] = {{0, 0, 1}, {0.6, 0.0, 0.8}, {-0.28, 0.6, 0.7483314773547883}};
    for (const Vec3& wo : dirs)
      for (int k = 0; k < 4; ++k) {
        const auto s = b.sample(wo, {0.13 + 0.25 * k, 0.71 - 0.17 * k}, lambda);
        if (s && !(s->pdf > 0 && std::isfinite(s->pdf))) std::abort();
        for (const Vec3& wi : dirs) {
          const double p = b.pdf(wo, wi);
          const render::SampledSpectrum f = b.f(wo, wi, lambda);
          if (!(p >= 0 && std::isfinite(p))) std::abort();
          for (int i = 0; i < render::kSpectrumSamples; ++i)
            if (!(f[i] >= 0 && std::isfinite(f[i]))) std::abort();
        }
      }
  });
}

int fuzzFourier(const uint8_t* data, size_t size) {
  initFuzzing();
  return guarded([&] {
    auto table = std::make_shared<const render::FourierBSDFTable>(
        render::FourierBSDFTable::parse(text(data, size), "fuzz.bsdf"));
    // A table that loads is evaluated and sampled in both modes: values must be finite and
    // non-negative, pdfs finite and non-negative, samples with a positive pdf.
    const render::SampledWavelengths lambda = render::SampledWavelengths::sampleUniform(0.37);
    const render::FourierBxDF bx(table, lambda);
    const Vec3 dirs[4] = {
        {0, 0, 1}, {0.6, 0.0, 0.8}, {-0.28, 0.6, 0.7483314773547883}, {0.3, -0.4, -0.8660254}};
    for (const render::TransportMode mode :
         {render::TransportMode::Radiance, render::TransportMode::Importance})
      for (const Vec3& wo : dirs)
        for (int k = 0; k < 4; ++k) {
          const auto s = bx.sample_f(wo, 0.5, {0.13 + 0.25 * k, 0.71 - 0.17 * k}, mode);
          if (s && !(s->pdf > 0 && std::isfinite(s->pdf))) std::abort();
          for (const Vec3& wi : dirs) {
            const double p = bx.pdf(wo, wi, mode);
            const render::SampledSpectrum f = bx.f(wo, wi, mode);
            if (!(p >= 0 && std::isfinite(p))) std::abort();
            for (int i = 0; i < render::kSpectrumSamples; ++i)
              if (!(f[i] >= 0 && std::isfinite(f[i]))) std::abort();
          }
        }
  });
}

const Target* targets(size_t& count) {
  static const Target all[] = {
      {"lens", fuzzLens},
      {"scene_tokens", fuzzSceneTokens},
      {"scene_parse", fuzzSceneParse},
      {"scene_build", fuzzSceneBuild},
      {"scene_render", fuzzSceneRender},
      {"ply", fuzzPly},
      {"image", fuzzImage},
      {"brdf", fuzzBrdf},
      {"zmx", fuzzZmx},
      {"lens_json", fuzzLensJson},
      {"bsdf", fuzzBsdf},
      {"fourier", fuzzFourier},
  };
  count = sizeof all / sizeof all[0];
  return all;
}

}  // namespace lensim::fuzz
