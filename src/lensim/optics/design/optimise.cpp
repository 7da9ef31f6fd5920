// optimiseDesign: the job's merit function handed to damped least squares, then glass snapping.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/levenberg_marquardt.h"
#include "lensim/optics/glass.h"

namespace lensim::optics::design {

namespace {

// Finite-difference step per variable kind: about 1e-6 of the variable's scale.
double fdStep(const Variable& v, double x) {
  switch (v.kind) {
    case Variable::Kind::Curvature: return 1e-6 * std::max(std::abs(x), 1e-3);
    case Variable::Kind::Thickness:
    case Variable::Kind::StopPosition: return 1e-6 * std::max(std::abs(x), 1.0);
    case Variable::Kind::Conic: return 1e-6 * std::max(std::abs(x), 1.0);
    case Variable::Kind::Asphere: return 1e-6 * std::max(std::abs(x), std::pow(10.0, -v.power));
    case Variable::Kind::GlassIndex: return 1e-7;
    case Variable::Kind::GlassAbbe: return 1e-5;
  }
  return 1e-7;
}

// The scale of a variable's random perturbation in a global search when it is not bounded on
// both sides: a 100 mm radius, 1 mm, a conic of 1, an aspheric term's r^p at r = 10 mm.
double searchScale(const Variable& v) {
  switch (v.kind) {
    case Variable::Kind::Curvature: return 1e-2;
    case Variable::Kind::Thickness:
    case Variable::Kind::StopPosition: return 1;
    case Variable::Kind::Conic: return 1;
    case Variable::Kind::Asphere: return std::pow(10.0, -v.power);
    case Variable::Kind::GlassIndex: return 0.1;
    case Variable::Kind::GlassAbbe: return 10;
  }
  return 1;
}

}  // namespace

DesignResult optimiseDesign(const DesignJob& job,
                            const std::function<void(const std::string&)>& log) {
  auto say = [&](const std::string& s) {
    if (log) log(s);
  };
  DesignResult out;
  out.lens = job.start;
  auto stage = [&](const std::vector<Variable>& vars, const char* name, int starts) {
    const LensPrescription base = out.lens;
    ResidualFn f = [&](const std::vector<double>& x, std::vector<double>& r) {
      try {
        const LensPrescription p = applyVariables(vars, base, x);
        const std::vector<double> v = operandValues(job, p);
        r.resize(v.size());
        for (size_t i = 0; i < v.size(); ++i) r[i] = operandResidual(job.operands[i], v[i]);
        return true;
      } catch (const Error&) {
        return false;
      }
    };
    const std::vector<double> x0 = variableValues(vars, base);
    std::vector<double> lo, hi, steps;
    for (size_t k = 0; k < vars.size(); ++k) {
      lo.push_back(vars[k].lower);
      hi.push_back(vars[k].upper);
      steps.push_back(fdStep(vars[k], x0[k]));
    }
    LmOptions opts;
    opts.max_iterations = job.max_iterations;
    opts.steps = steps;
    opts.progress = [&](int it, double merit, double lambda, const std::vector<double>& r) {
      // The three operands that contribute most to the merit.
      std::vector<size_t> idx(r.size());
      std::iota(idx.begin(), idx.end(), 0);
      std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return r[a] * r[a] > r[b] * r[b]; });
      std::string top;
      for (size_t k = 0; k < std::min<size_t>(3, idx.size()); ++k)
        top += fmt::format("{}{} {:.1f}%", k ? ", " : "", job.operands[idx[k]].label(),
                           merit > 0 ? 100 * r[idx[k]] * r[idx[k]] / merit : 0.0);
      say(fmt::format("{} iteration {:3d}  merit {:.6e}  lambda {:.1e}  dominant: {}", name, it,
                      merit, lambda, top));
    };
    try {
      operandValues(job, base);
    } catch (const Error& e) {
      throw Error(fmt::format("{}: the starting lens cannot be evaluated: {} (every operand must "
                              "be computable: a focal lens, real chief rays at every field, beams "
                              "that reach the film)",
                              job.path, e.message()));
    }
    LmResult res;
    if (starts > 1) {
      GlobalOptions g;
      g.starts = starts;
      g.seed = job.global_seed;
      for (const Variable& v : vars) g.scales.push_back(searchScale(v));
      g.on_start = [&](int k, const std::vector<double>&, const LmResult& r) {
        say(fmt::format("{} start {:3d}  merit {:.6e} -> {:.6e} in {} iterations ({})", name, k,
                        r.initial_merit, r.merit, r.iterations, r.stop_reason));
      };
      res = multiStartLevenbergMarquardt(f, x0, lo, hi, opts, g);
    } else {
      res = levenbergMarquardt(f, x0, lo, hi, opts);
    }
    out.lens = applyVariables(vars, base, res.x);
    if (out.iterations == 0) out.initial_merit = res.initial_merit;
    out.merit = res.merit;
    out.iterations += res.iterations;
    out.evaluations += res.evaluations;
    out.stop_reason = res.stop_reason;
    say(fmt::format("{}: merit {:.6e} -> {:.6e} in {} iterations ({})", name, res.initial_merit,
                    res.merit, res.iterations, res.stop_reason));
  };
  if (job.variables.empty()) {
    const std::vector<double> v = operandValues(job, out.lens);
    double m = 0;
    for (size_t i = 0; i < v.size(); ++i) m += std::pow(operandResidual(job.operands[i], v[i]), 2);
    out.initial_merit = out.merit = m;
    out.stop_reason = "no variables";
  } else {
    stage(job.variables, "optimise", job.global_starts);
  }
  // Model glasses to the nearest catalogue glasses, then the other variables again.
  std::vector<Variable> rest;
  bool any_glass = false;
  for (const Variable& v : job.variables) {
    if (v.kind == Variable::Kind::GlassIndex || v.kind == Variable::Kind::GlassAbbe)
      any_glass = true;
    else
      rest.push_back(v);
  }
  if (any_glass && job.snap_glass) {
    std::vector<int> done;
    for (const Variable& v : job.variables) {
      if (v.kind != Variable::Kind::GlassIndex && v.kind != Variable::Kind::GlassAbbe) continue;
      if (std::find(done.begin(), done.end(), v.surface) != done.end()) continue;
      done.push_back(v.surface);
      LensSurface& s = out.lens.surfaces[v.surface];
      const Glass model = resolveGlass(s.glass, s.ior);
      const CatalogGlass& g = GlassCatalog::builtin().nearest(model.n_d(), model.v_d());
      const std::string line = fmt::format("surface {}: model n_d {:.4f} V_d {:.2f} -> {} (n_d {:.4f} V_d {:.2f})",
                                           v.surface, model.n_d(), model.v_d(), g.qualifiedName(),
                                           g.listed_n_d, g.listed_v_d);
      out.snapped.push_back(line);
      say("snap " + line);
      s.glass.name = g.qualifiedName();
      s.glass.n_d = g.listed_n_d;
      s.glass.v_d = g.listed_v_d;
      s.ior = g.listed_n_d;
    }
    if (!rest.empty()) stage(rest, "re-optimise", 1);
  }
  out.values = operandValues(job, out.lens);
  out.merit = 0;
  for (size_t i = 0; i < out.values.size(); ++i)
    out.merit += std::pow(operandResidual(job.operands[i], out.values[i]), 2);
  return out;
}

}  // namespace lensim::optics::design
