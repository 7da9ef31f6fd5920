// Builder: the Integrator directive.
#include "lensim/scene/build/builder_internal.h"

namespace lensim::scene::detail {

void Builder::integrator(const Directive& d) {
  const std::string& type = d.strings[0];
  ParamSet ps(d.params, d.loc, fmt::format("{} \"{}\"", d.name, type));
  Integrator& it = scene_.integrator;
  it.defaulted = false;
  it.type_as_written = type;
  it.loc = d.loc;
  it.type = "path";
  it.max_depth = ps.getInt({"maxdepth"}, 5);
  if (type == "path" || type == "volpath") {
    it.regularize = ps.getBool({"regularize"}, false);
    it.light_sampler = ps.getString({"lightsampler", "lightsamplestrategy"}, "bvh");
    // pbrt-v4's samplers (LightSampler::Create, src/pbrt/lightsamplers.cpp): an unknown name
    // is reported and "bvh" used. pbrt-v3's "spatial" (its default, a light distribution
    // that depends on position) is nearest to "bvh".
    if (it.light_sampler == "spatial") it.light_sampler = "bvh";
    if (it.light_sampler != "bvh" && it.light_sampler != "power" && it.light_sampler != "uniform" &&
        it.light_sampler != "exhaustive") {
      const Param* p = ps.peek({"lightsampler", "lightsamplestrategy"});
      warn(p ? p->loc : d.loc,
           fmt::format("unknown light sampler \"{}\" (expected bvh, power, uniform or "
                       "exhaustive); \"bvh\" is used",
                       it.light_sampler));
      it.light_sampler = "bvh";
    }
    ps.getFloat({"rrthreshold"}, 1);  // pbrt-v3
    if (const Param* p = ps.find({"pixelbounds"}, {ParamType::Integer})) ps.expectCount(*p, 4);
    if (type == "volpath") it.type = "volpath";
  } else if (type == "lighttracer") {
    it.type = "lighttracer";  // pbrt-v4's LightPathIntegrator (render/integrators/lighttracer.h)
  } else if (type == "bdpt") {
    integratorBdpt(ps, it);
  } else if (type == "directlighting") {
    integratorDirectLighting(ps, it);
  } else {
    ps.markAllUsed();
    // pbrt-v4's other integrators (bdpt, mlt, sppm, ...) handle media: volpath keeps them.
    if (!scene_.legacy_syntax) it.type = "volpath";
    warnOnce("integrator " + type, d.loc,
             fmt::format("integrator \"{}\" is not rendered by lensim; it renders as \"{}\" "
                         "with maxdepth {}",
                         type, it.type, it.max_depth));
  }
  finish(ps);
}

// pbrt-v4's BDPTIntegrator::Create (src/pbrt/cpu/integrators.cpp): maxdepth, regularize,
// lightsampler (default "power"), visualizestrategies, visualizeweights.
void Builder::integratorBdpt(ParamSet& ps, Integrator& it) {
  it.type = "bdpt";
  it.regularize = ps.getBool({"regularize"}, false);
  it.light_sampler = ps.getString({"lightsampler"}, "power");
  if (it.light_sampler != "power" && it.light_sampler != "uniform") {
    const Param* p = ps.peek({"lightsampler"});
    warn(p ? p->loc : it.loc,
         fmt::format("bdpt chooses lights by \"power\" or \"uniform\" (light subpaths need a "
                     "choice that does not depend on a point), not \"{}\"; \"power\" is used",
                     it.light_sampler));
    it.light_sampler = "power";
  }
  for (const char* name : {"visualizestrategies", "visualizeweights"})
    if (ps.getBool({name}, false)) {
      const Param* p = ps.peek({name});
      warn(p ? p->loc : it.loc,
           fmt::format("bdpt \"{}\" (pbrt-v4's per-strategy debug images) is not supported; "
                       "the image is rendered as usual",
                       name));
    }
}

// pbrt-v3's CreateDirectLightingIntegrator (src/integrators/directlighting.cpp): maxdepth
// (default 5, read above), strategy "all" (default) or "one", an unknown strategy warned and
// "all" used; pixelbounds as path's. pbrt-v2's DirectLightingIntegrator reads the same two.
void Builder::integratorDirectLighting(ParamSet& ps, Integrator& it) {
  it.type = "directlighting";
  const std::string strategy = ps.getString({"strategy"}, "all");
  it.all_lights = strategy != "one";
  if (strategy != "all" && strategy != "one")
    warn(ps.peek({"strategy"})->loc,
         fmt::format("directlighting strategy \"{}\" is unknown (expected \"all\" or \"one\"); "
                     "\"all\" is used, as pbrt-v3 does",
                     strategy));
  if (it.max_depth < 0)
    throw Error(ps.peek({"maxdepth"})->loc,
                fmt::format("directlighting maxdepth {} must not be negative", it.max_depth));
  if (const Param* p = ps.find({"pixelbounds"}, {ParamType::Integer})) ps.expectCount(*p, 4);
}

}  // namespace lensim::scene::detail
