// Bundle adjustment and pose-graph timings of CeresBackend, SchurBackend and MrptBackend on
// the seeded synthetic problems of tests/backends/ba_synthetic.h.
//
//   bench_backends --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Counters: cost0 / cost = evaluateCost() before / after, it = iterations,
// outliers = observations flagged.
#include <benchmark/benchmark.h>

#include "../tests/backends/ba_synthetic.h"
#include "dslam/core/registry.h"

using namespace dslam;

namespace {

std::shared_ptr<Backend> backend(const char* name, const std::string& yaml = "") {
  register_builtin_plugins();
  auto b = create<Backend>(name);
  b->configure(Params::resolve(b->paramSpecs(), yaml), PluginContext{});
  return b;
}

void runBA(benchmark::State& state, const char* name, test::SynthBAConfig cfg, BAOptions opt,
           const std::string& yaml = "") {
  auto b = backend(name, yaml);
  const auto synth = test::makeBA(cfg);
  BAResult r;
  for (auto _ : state) {
    state.PauseTiming();
    BAProblem p = synth.problem;
    state.ResumeTiming();
    r = b->bundleAdjust(p, opt);
    benchmark::DoNotOptimize(r);
  }
  if (!r.success) state.SkipWithError(r.message.c_str());
  state.counters["obs"] = static_cast<double>(synth.problem.observations.size());
  state.counters["cost0"] = r.initial_cost;
  state.counters["cost"] = r.final_cost;
  state.counters["it"] = r.iterations;
  state.counters["outliers"] = r.num_outliers;
}

test::SynthBAConfig small() {  // 10 KF, 1000 points, monocular
  return {};
}

BAOptions orbslam() { return BAOptions{}; }  // Huber + outlier rejection, 5 + 10 iterations

BAOptions leastSquares() {
  BAOptions o;
  o.robust = false;
  o.reject_outliers = false;
  o.max_iterations = 10;
  return o;
}

void runPG(benchmark::State& state, const char* name) {
  auto b = backend(name);
  const auto synth = test::makePoseGraph(static_cast<int>(state.range(0)));
  PoseGraphResult r;
  for (auto _ : state) {
    state.PauseTiming();
    PoseGraph g = synth.graph;
    state.ResumeTiming();
    r = b->optimizePoseGraph(g, PoseGraphOptions{});
    benchmark::DoNotOptimize(r);
  }
  if (!r.success) state.SkipWithError(r.message.c_str());
  state.counters["cost0"] = r.initial_cost;
  state.counters["cost"] = r.final_cost;
  state.counters["it"] = r.iterations;
}

}  // namespace

BENCHMARK_CAPTURE(runBA, Ceres_10kf_1000pt_mono_orbslam, "dslam::CeresBackend", small(), orbslam())
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Schur_10kf_1000pt_mono_orbslam, "dslam::SchurBackend", small(), orbslam())
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Mrpt_10kf_1000pt_mono_orbslam, "dslam::MrptBackend", small(), orbslam())
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Ceres_10kf_1000pt_mono_lsq10, "dslam::CeresBackend", small(), leastSquares())
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Mrpt_10kf_1000pt_mono_lsq10, "dslam::MrptBackend", small(), leastSquares())
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Ceres_20kf_3000pt_stereo_orbslam, "dslam::CeresBackend", test::localBAConfig(), orbslam())
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Schur_20kf_3000pt_stereo_orbslam, "dslam::SchurBackend", test::localBAConfig(), orbslam())
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Ceres_20kf_3000pt_stereo_orbslam_sparse, "dslam::CeresBackend", test::localBAConfig(), orbslam(),
                  "linear_solver: sparse_schur")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Ceres_20kf_3000pt_stereo_orbslam_2threads, "dslam::CeresBackend", test::localBAConfig(), orbslam(),
                  "num_threads: 2")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runBA, Mrpt_20kf_3000pt_stereo_orbslam, "dslam::MrptBackend", test::localBAConfig(), orbslam())
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);
BENCHMARK_CAPTURE(runPG, Ceres, "dslam::CeresBackend")->Arg(30)->Arg(300)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runPG, Mrpt, "dslam::MrptBackend")->Arg(30)->Arg(300)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
