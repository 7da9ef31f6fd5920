// Lens design (issue 33): merit-function evaluations per second for a 10-surface lens (the
// double Gauss, lenses/dgauss.50mm.dat) with 3 fields x 3 wavelengths x a 12-ring pupil, the
// cost of one Levenberg-Marquardt Jacobian column.
#include <benchmark/benchmark.h>

#include <string>

#include "lensim/optics/design/design_job.h"

namespace {

using namespace lensim::optics::design;
using lensim::optics::LensPrescription;

DesignJob doubleGaussJob() {
  const std::string lens = std::string(LENSIM_SOURCE_DIR) + "/lenses/dgauss.50mm.dat";
  std::string vars;
  for (int s : {0, 1, 2, 3, 4, 6, 7, 8, 9, 10})
    vars += (vars.empty() ? "" : ",\n") + std::string("{\"type\": \"curvature\", \"surface\": ") +
            std::to_string(s) + "}";
  const std::string text = "{\"lens\": \"" + lens +
                           "\", \"wavelengths_nm\": [587.56, 486.13, 656.27],"
                           " \"fields_deg\": [0, 10, 15], \"rings\": 12,"
                           " \"variables\": [" + vars + "],"
                           " \"operands\": [{\"type\": \"efl\", \"target\": 50},"
                           " {\"type\": \"rms_spot\"}]}";
  return parseDesignJob(text, "bench.json");
}

// One merit evaluation: the variables written into the lens, every operand computed (EFL and
// the 9 RMS spots, 12 rings each).
void BM_MeritEvaluation(benchmark::State& state) {
  const DesignJob job = doubleGaussJob();
  const std::vector<double> x = variableValues(job.variables, job.start);
  // Film at the paraxial-ish focus the file leaves (its last thickness is 0): put it at 40 mm so
  // the spots are those of a focused lens.
  LensPrescription start = job.start;
  start.surfaces.back().thickness_mm = 40;
  for (auto _ : state) {
    const LensPrescription p = applyVariables(job.variables, start, x);
    benchmark::DoNotOptimize(operandValues(job, p));
  }
  state.counters["evaluations/s"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MeritEvaluation)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
