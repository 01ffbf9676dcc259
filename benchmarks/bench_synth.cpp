// Render speed of the synthetic scene generator (frames/s). Scenarios are
// read from <source>/config/scenarios (found next to this file or through
// $DSLAM_SOURCE_DIR).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <memory>

#include "dslam/synth/renderer.h"
#include "dslam/synth/scenario.h"

namespace fs = std::filesystem;
using namespace dslam::synth;

namespace {

std::string scenarioPath(const std::string& name) {
  const char* e = std::getenv("DSLAM_SOURCE_DIR");
  const fs::path root = e && *e ? fs::path(e) : fs::path(__FILE__).parent_path().parent_path();
  return (root / "config" / "scenarios" / (name + ".yaml")).string();
}

/** Renders frames of `name` round-robin; args: width, height, right (0/1), threads. */
void BM_Render(benchmark::State& st, const std::string& name) {
  ScenarioOverrides ov;
  ov.width = static_cast<int>(st.range(0));
  ov.height = static_cast<int>(st.range(1));
  const Scenario s = loadScenario(scenarioPath(name), ov);
  RenderOptions ro;
  ro.right = st.range(2) != 0;
  ro.threads = static_cast<int>(st.range(3));
  Renderer r(s, ro);
  int f = 0;
  for (auto _ : st) {
    FrameRender fr = r.render(f);
    benchmark::DoNotOptimize(fr.rgb.data);
    f = (f + 7) % s.frames;
  }
  st.counters["frames/s"] = benchmark::Counter(static_cast<double>(st.iterations()), benchmark::Counter::kIsRate);
}

/** Renderer construction (procedural texture generation); args: width, height. */
void BM_Setup(benchmark::State& st, const std::string& name) {
  ScenarioOverrides ov;
  ov.width = static_cast<int>(st.range(0));
  ov.height = static_cast<int>(st.range(1));
  const Scenario s = loadScenario(scenarioPath(name), ov);
  for (auto _ : st) {
    Renderer r(s);
    benchmark::DoNotOptimize(&r);
  }
}

}  // namespace

BENCHMARK_CAPTURE(BM_Setup, walking_xyz, std::string("walking_xyz"))
    ->Args({640, 480})
    ->Args({320, 240})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Full frame (RGB + right + depth + labels) at 640x480 with both cores, then
// without the right image, with one thread, and the small test resolution.
BENCHMARK_CAPTURE(BM_Render, walking_xyz, std::string("walking_xyz"))
    ->Args({640, 480, 1, 0})
    ->Args({640, 480, 0, 0})
    ->Args({640, 480, 1, 1})
    ->Args({640, 480, 0, 1})
    ->Args({320, 240, 1, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Render, static_office, std::string("static_office"))
    ->Args({640, 480, 1, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Render, crowd, std::string("crowd"))
    ->Args({640, 480, 1, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
