// Per-frame latency of each detector plugin at its default input size on
// ../shared/data/images/person.jpg (640x424). Each benchmark runs a fixed
// number of frames after one warm-up call and reports the median in the
// `median_ms` counter (the wall time per iteration is the mean).
//
//   build-*/bin/bench_detectors [--benchmark_filter=Yolox]
#include <benchmark/benchmark.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "dslam/core/detector.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/core/timing.h"
#include "dslam/plugins/detectors/label_io.h"

namespace {

using namespace dslam;

SensorFrame personFrame() {
  SensorFrame f;
  f.index = 0;
  f.image_path = sharedDir() + "/data/images/person.jpg";
  f.image = cv::imread(f.image_path, cv::IMREAD_COLOR);
  return f;
}

std::shared_ptr<Detector> make(const std::string& type, const std::string& yaml, const PluginContext& ctx = {}) {
  register_builtin_plugins();
  auto d = create<Detector>(type);
  d->configure(Params::resolve(d->paramSpecs(), yaml), ctx);
  return d;
}

void run(benchmark::State& state, const std::string& type, const std::string& yaml, SensorFrame f = personFrame(),
         const PluginContext& ctx = {}) {
  if (f.image.empty()) {
    state.SkipWithError("shared image missing: set DSLAM_SHARED_DIR");
    return;
  }
  std::shared_ptr<Detector> det;
  try {
    det = make(type, yaml, ctx);
    det->detect(f);  // warm-up (allocations, lazy layer init)
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  std::vector<double> ms;
  size_t boxes = 0;
  for (auto _ : state) {
    const double t0 = nowSeconds();
    auto d = det->detect(f);
    ms.push_back((nowSeconds() - t0) * 1e3);
    boxes = d.boxes.size();
    benchmark::DoNotOptimize(d);
  }
  state.counters["median_ms"] = median(ms);
  state.counters["boxes"] = double(boxes);
}

void BM_YoloFastestBody(benchmark::State& s) { run(s, "dslam::DarknetYoloDetector", ""); }
void BM_YoloFastestCoco(benchmark::State& s) { run(s, "dslam::DarknetYoloDetector", "model: yolo-fastest-coco"); }
void BM_YoloFastestXl(benchmark::State& s) { run(s, "dslam::DarknetYoloDetector", "model: yolo-fastest-xl"); }
void BM_YoloxNano(benchmark::State& s) { run(s, "dslam::YoloxOnnxDetector", ""); }
void BM_HogPeople(benchmark::State& s) { run(s, "dslam::HogPeopleDetector", ""); }
void BM_EnetCityscapes(benchmark::State& s) { run(s, "dslam::DnnSemanticSegmenter", ""); }

/** FileDetector reading a 640x480 box JSON + semantic PNG + panoptic PNG. */
void BM_FileDetector640x480(benchmark::State& s) {
  const auto dir = std::filesystem::temp_directory_path() / "dslam_bench_detectors";
  std::filesystem::remove_all(dir);
  cv::Mat ids(480, 640, CV_32S, cv::Scalar(1000)), sem(480, 640, CV_8U, cv::Scalar(199));
  labels::PanopticAnnotation a;
  a.file_name = "000000.png";
  PanopticSegment wall;
  wall.id = 1000, wall.category_id = 199;
  a.segments.push_back(wall);
  std::vector<BoundingBox> boxes;
  for (int i = 0; i < 8; i++) {
    const cv::Rect r(20 + 75 * i, 100 + 10 * i, 60, 200);
    ids(r).setTo(i + 1);
    sem(r).setTo(1);
    PanopticSegment p;
    p.id = i + 1, p.category_id = 1, p.instance_id = i + 1;
    a.segments.push_back(p);
    boxes.push_back({cv::Rect2f(r), 1, 1.f, i + 1});
  }
  labels::writePanopticPng((dir / "panoptic/000000.png").string(), ids);
  labels::writePanopticJson((dir / "panoptic.json").string(), {a}, labels::cocoPanopticCategories());
  labels::writeSemanticPng((dir / "semantic/000000.png").string(), sem);
  labels::writeBoxJson((dir / "boxes/000000.json").string(), boxes);
  SensorFrame f;
  f.index = 0;
  f.image_path = "rgb/000000.png";
  f.image = cv::Mat(480, 640, CV_8UC3, cv::Scalar(0));
  run(s, "dslam::FileDetector", "dir: " + dir.string(), f);
  std::filesystem::remove_all(dir);
}

}  // namespace

BENCHMARK(BM_YoloFastestBody)->Unit(benchmark::kMillisecond)->Iterations(30);
BENCHMARK(BM_YoloFastestCoco)->Unit(benchmark::kMillisecond)->Iterations(30);
BENCHMARK(BM_YoloFastestXl)->Unit(benchmark::kMillisecond)->Iterations(20);
BENCHMARK(BM_YoloxNano)->Unit(benchmark::kMillisecond)->Iterations(15);
BENCHMARK(BM_HogPeople)->Unit(benchmark::kMillisecond)->Iterations(10);
BENCHMARK(BM_EnetCityscapes)->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BM_FileDetector640x480)->Unit(benchmark::kMillisecond)->Iterations(20);

BENCHMARK_MAIN();
