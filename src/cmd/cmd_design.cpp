// `lensim lens optimise|tolerance JOB.json`: lens design on the workbench (issue 33;
// src/lensim/optics/design/, docs/design.md).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "lensim/optics/design/design_job.h"
#include "lensim/optics/design/tolerance.h"
#include "lensim/optics/lens_formats.h"
#include "lensim/util/file.h"
#include "lensim/util/log.h"

namespace lensim::cmd {

namespace {

using nlohmann::json;
using namespace lensim::optics;
using namespace lensim::optics::design;

// A lens written in the format its extension names (.json any coaxial lens, .dat spherical
// lenses, .zmx tilted and decentred ones too).
void writeLens(const LensPrescription& p, const std::string& out) {
  const std::string ext = std::filesystem::path(out).extension().string();
  if (ext != ".json" && ext != ".dat" && ext != ".zmx")
    throw Error(fmt::format("cannot write '{}': lensim writes lenses as .json (any coaxial lens), "
                            ".dat (spherical lenses) or .zmx",
                            out));
  writeFileAtomically(out, ext == ".json"  ? writeLensJson(p)
                           : ext == ".dat" ? writeLensDat(p)
                                           : writeLensZmx(p));
}

int runOptimise(const std::string& job_path, const std::string& out, const std::string& report) {
  const DesignJob job = readDesignJob(job_path);
  // Checked before the run: a bad output name must not cost the optimisation.
  const std::string ext = std::filesystem::path(out).extension().string();
  if (ext != ".json" && ext != ".dat" && ext != ".zmx")
    throw Error(fmt::format("-o '{}': expected a .json, .dat or .zmx lens file", out));
  DesignResult r = optimiseDesign(job, [](const std::string& s) { std::cout << s << "\n" << std::flush; });
  r.lens.name = job.start.name + " (optimised)";
  writeLens(r.lens, out);
  std::cout << fmt::format("merit {:.6e} -> {:.6e}, {} iterations, {} evaluations ({})\n",
                           r.initial_merit, r.merit, r.iterations, r.evaluations, r.stop_reason);
  json ops = json::array();
  for (size_t i = 0; i < job.operands.size(); ++i) {
    const Operand& o = job.operands[i];
    std::cout << fmt::format("  {:<36} {:>14.6g}  residual {:.3e}\n", o.label(), r.values[i],
                             operandResidual(o, r.values[i]));
    ops.push_back({{"operand", o.label()}, {"value", r.values[i]},
                   {"residual", operandResidual(o, r.values[i])}});
  }
  if (!report.empty()) {
    json j = {{"job", job_path}, {"lens", out}, {"initial_merit", r.initial_merit},
              {"merit", r.merit}, {"iterations", r.iterations}, {"evaluations", r.evaluations},
              {"stop_reason", r.stop_reason}, {"glass_snapped", r.snapped}, {"operands", ops}};
    writeFileAtomically(report, j.dump(2) + "\n");
  }
  logInfo(fmt::format("wrote {}", out));
  return 0;
}

int runTolerance(const std::string& job_path, const std::string& report, const std::string& builds_dir,
                 int build_count) {
  const DesignJob job = readDesignJob(job_path);
  if (job.tolerance.tolerances.empty())
    throw Error(FileLoc{job_path, 1, 1}, "the job has no \"tolerancing\" section with tolerances");
  if (build_count > job.tolerance.monte_carlo)
    throw Error(fmt::format("--write-builds {}: the job runs only {} Monte Carlo builds", build_count,
                            job.tolerance.monte_carlo));
  // A build that cannot be written is refused before the run (the nominal lens in the builds'
  // format stands for them all).
  if (!builds_dir.empty() && placedTolerancing(job)) {
    for (const Tolerance& t : job.tolerance.tolerances)
      if (t.kind == Tolerance::Kind::Irregularity)
        throw Error(t.loc, "--write-builds: builds with decentres or tilts are written as .zmx, "
                           "whose surfaces cannot hold an irregular one (a biconic with a "
                           "polynomial term); run the irregularity in a job without them to "
                           "write its builds");
    writeLensZmx(toleranceNominal(job));
  }
  const ToleranceResult r = runTolerancing(job);
  const std::string unit =
      job.tolerance.criterion == "f_number" || job.tolerance.criterion == "mtf" ? "" : " mm";
  std::cout << fmt::format("criterion {} (compensator {}), nominal {:.6g}{}\n",
                           job.tolerance.criterion,
                           job.tolerance.back_focus_compensator ? "back focus" : "none", r.nominal, unit);
  const bool per_field = !r.nominal_fields.empty();
  std::string fields_line;
  for (size_t i = 0; i < r.nominal_fields.size(); ++i)
    fields_line += fmt::format("{}{:g} deg {:.6g}", i ? ", " : "", job.fields_deg[i], r.nominal_fields[i]);
  if (per_field) std::cout << "nominal RMS spot per field (mm): " << fields_line << "\n";
  std::cout << fmt::format("{:<36} {:>13} {:>13}{}\n", "tolerance", "change at +", "change at -",
                           per_field ? "  RMS spot per field at + / - (mm)" : "");
  json rows = json::array();
  for (const SensitivityRow& s : r.sensitivity) {
    std::string fields;
    for (size_t i = 0; i < s.fields_plus.size() && i < s.fields_minus.size(); ++i)
      fields += fmt::format("  {:.4g}/{:.4g}", s.fields_plus[i], s.fields_minus[i]);
    std::cout << fmt::format("{:<36} {:>13.4e} {:>13.4e}{}\n", s.label, s.plus, s.minus, fields);
    json row = {{"tolerance", s.label}, {"plus", s.plus}, {"minus", s.minus}};
    if (per_field) row["rms_spot_plus"] = s.fields_plus, row["rms_spot_minus"] = s.fields_minus;
    rows.push_back(row);
  }
  std::cout << fmt::format("root-sum-square change {:.4e}{}\n", r.rss_change, unit);
  if (!r.builds.empty())
    std::cout << fmt::format(
        "Monte Carlo {} builds (seed {}): mean {:.6g}, sd {:.3g}, 10% {:.6g}, median {:.6g}, "
        "90% {:.6g}, worst {:.6g}{}\n",
        r.builds.size(), job.tolerance.seed, r.mean, r.stddev, r.p10, r.p50, r.p90, r.worst, unit);
  if (!report.empty()) {
    json j = {{"job", job_path}, {"criterion", job.tolerance.criterion},
              {"compensator", job.tolerance.back_focus_compensator ? "back_focus" : "none"},
              {"nominal", r.nominal}, {"fields_deg", job.fields_deg},
              {"nominal_rms_spot", r.nominal_fields}, {"sensitivity", rows},
              {"rss_change", r.rss_change},
              {"seed", job.tolerance.seed}, {"builds", r.builds}, {"mean", r.mean},
              {"stddev", r.stddev}, {"p10", r.p10}, {"p50", r.p50}, {"p90", r.p90},
              {"worst", r.worst}};
    writeFileAtomically(report, j.dump(2) + "\n");
  }
  if (!builds_dir.empty()) {
    std::filesystem::create_directories(builds_dir);
    // Decentred or tilted builds as .zmx (coordinate breaks), coaxial ones as lensim JSON.
    const char* ext = placedTolerancing(job) ? "zmx" : "json";
    for (int k = 0; k < build_count; ++k)
      writeLens(asBuiltLens(job, k),
                (std::filesystem::path(builds_dir) / fmt::format("build-{:04d}.{}", k, ext)).string());
    logInfo(fmt::format("wrote {} as-built lenses to {}", build_count, builds_dir));
  }
  return 0;
}

}  // namespace

void registerDesignCommands(CLI::App* lens, Action& action) {
  {
    auto* opt = lens->add_subcommand(
        "optimise", "Optimise a lens by damped least squares on a design job (docs/design.md)");
    auto job = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    auto report = std::make_shared<std::string>();
    opt->add_option("JOB", *job, "Design job (.json, docs/design-job.schema.json)")->required();
    opt->add_option("-o,--output", *out, "The optimised lens (.json or .dat)")->required();
    opt->add_option("--report", *report, "Also write the result as JSON");
    opt->callback([&action, job, out, report] {
      action = [job, out, report] { return runOptimise(*job, *out, *report); };
    });
  }
  {
    auto* tol = lens->add_subcommand(
        "tolerance", "Sensitivity table and Monte Carlo builds of a design job's lens");
    auto job = std::make_shared<std::string>();
    auto report = std::make_shared<std::string>();
    auto dir = std::make_shared<std::string>();
    auto count = std::make_shared<int>(0);
    tol->add_option("JOB", *job, "Design job with a \"tolerancing\" section")->required();
    tol->add_option("-o,--output", *report, "Write the results as JSON");
    tol->add_option("--builds-dir", *dir,
                    "Folder for as-built lenses (build-NNNN.json; .zmx when decentred or tilted)");
    tol->add_option("--write-builds", *count, "How many as-built lenses to write (first N builds)")
        ->check(CLI::Range(1, 1000000));
    tol->callback([&action, job, report, dir, count] {
      action = [job, report, dir, count] {
        if (dir->empty() != (*count == 0))
          throw Error("--builds-dir and --write-builds go together");
        return runTolerance(*job, *report, *dir, *count);
      };
    });
  }
}

}  // namespace lensim::cmd
