// Per-frame input costs: PNG decoding of a real TUM colour and 16-bit depth
// frame with cv::imread and with dslam::readPngFast (libdeflate, the dataset
// readers' path), and carrying two person-sized boxes from one frame to the
// next by optical flow (dslam::carryDetections, asynchronous detection):
// BM_Carry/0 the same pair every time (both pyramids built), BM_Carry/1
// frame to frame as System carries (the last image's pyramid reused).
//
//   build/bin/bench_io --benchmark_repetitions=7 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include <iostream>

#include "dslam/core/paths.h"
#include "dslam/core/png.h"
#include "dslam/slam/detection_carry.h"

using namespace dslam;

namespace {

std::string tumFile(const char* name) { return sharedDir() + "/data/tum-frames/rgbd-pair/" + name; }

void decode(benchmark::State& state, const char* name, int flags, bool fast) {
  cv::setNumThreads(1);
  const std::string f = tumFile(name);
  if (cv::imread(f, flags).empty()) {
    state.SkipWithError(("missing " + f + ": set DSLAM_SHARED_DIR").c_str());
    return;
  }
  for (auto _ : state) {
    cv::Mat m = fast ? readPngFast(f, flags) : cv::imread(f, flags);
    benchmark::DoNotOptimize(m.data);
  }
}

void BM_Carry(benchmark::State& state) {
  cv::setNumThreads(1);
  const cv::Mat a = cv::imread(tumFile("1.png"), cv::IMREAD_GRAYSCALE);
  const cv::Mat b = cv::imread(tumFile("2.png"), cv::IMREAD_GRAYSCALE);
  if (a.empty() || b.empty()) {
    state.SkipWithError("missing data/tum-frames/rgbd-pair: set DSLAM_SHARED_DIR");
    return;
  }
  Detections d;
  d.valid = true;
  for (const cv::Rect2f r : {cv::Rect2f(100, 80, 150, 350), cv::Rect2f(350, 100, 130, 330)}) {
    BoundingBox bb;
    bb.box = r;
    d.boxes.push_back(bb);
  }
  if (state.range(0) == 0) {  // the same pair every time: both pyramids built
    for (auto _ : state) benchmark::DoNotOptimize(carryDetections(d, a, b, 1).boxes.data());
  } else {  // carried frame to frame as System does (a -> b -> a ...): one pyramid built per call
    bool ab = true;
    for (auto _ : state) {
      benchmark::DoNotOptimize(carryDetections(d, ab ? a : b, ab ? b : a, 1).boxes.data());
      ab = !ab;
    }
  }
}

}  // namespace

BENCHMARK_CAPTURE(decode, TumColour_imread, "1.png", cv::IMREAD_UNCHANGED, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(decode, TumColour_readPngFast, "1.png", cv::IMREAD_UNCHANGED, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(decode, TumDepth_imread, "1_depth.png", cv::IMREAD_ANYDEPTH, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(decode, TumDepth_readPngFast, "1_depth.png", cv::IMREAD_ANYDEPTH, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Carry)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
