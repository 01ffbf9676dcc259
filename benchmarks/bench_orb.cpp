// ORB front end: dslam::OrbExtractor vs cv::ORB on a real 640x480 TUM frame
// (1000 features) and a real KITTI 1241x376 frame (2000 features), stereo
// matching and the whole FeatureFrontend.
//
// Single core by default (cv::setNumThreads(1)); the *_2threads variants use
// two. Medians: --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <iostream>

#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/core/camera_presets.h"
#include "dslam/core/paths.h"
#include "dslam/features/frontend.h"
#include "dslam/features/orb_extractor.h"
#include "dslam/features/stereo_matcher.h"

using namespace dslam;

namespace {

struct Images {
  cv::Mat tum_bgr, tum_gray, tum_depth, kitti_l, kitti_r;
};

const Images& images() {
  static const Images im = [] {
    Images i;
    const std::string s = sharedDir();
    i.tum_bgr = cv::imread(s + "/data/tum-frames/rgbd-pair/1.png", cv::IMREAD_COLOR);
    i.tum_depth = cv::imread(s + "/data/tum-frames/rgbd-pair/1_depth.png", cv::IMREAD_UNCHANGED);
    i.kitti_l = cv::imread(s + "/data/kitti-stereo-51/image_l/000000.png", cv::IMREAD_GRAYSCALE);
    i.kitti_r = cv::imread(s + "/data/kitti-stereo-51/image_r/000000.png", cv::IMREAD_GRAYSCALE);
    if (i.tum_bgr.empty() || i.tum_depth.empty() || i.kitti_l.empty() || i.kitti_r.empty()) {
      std::cerr << "bench_orb: images missing under " << s << "/data (tum-frames/rgbd-pair, kitti-stereo-51)\n";
      std::exit(1);
    }
    cv::cvtColor(i.tum_bgr, i.tum_gray, cv::COLOR_BGR2GRAY);
    return i;
  }();
  return im;
}

/** Runs the body with `n` OpenCV threads, restoring the setting. */
struct Threads {
  explicit Threads(int n) : old(cv::getNumThreads()) { cv::setNumThreads(n); }
  ~Threads() { cv::setNumThreads(old); }
  int old;
};

void runOurs(benchmark::State& st, const cv::Mat& img, int n, bool parallel) {
  OrbParams p;
  p.n_features = n;
  p.parallel_levels = parallel;
  OrbExtractor ex(p);
  Threads th(parallel ? 2 : 1);
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  double pyr = 0, det = 0, des = 0;
  for (auto _ : st) {
    ex.extract(img, kps, desc);
    pyr += ex.lastTimings().pyramid_ms;
    det += ex.lastTimings().detect_ms;
    des += ex.lastTimings().describe_ms;
  }
  st.counters["kps"] = static_cast<double>(kps.size());
  st.counters["pyr_cpu_ms"] = benchmark::Counter(pyr, benchmark::Counter::kAvgIterations);
  st.counters["detect_cpu_ms"] = benchmark::Counter(det, benchmark::Counter::kAvgIterations);
  st.counters["describe_cpu_ms"] = benchmark::Counter(des, benchmark::Counter::kAvgIterations);
}

void runCvOrb(benchmark::State& st, const cv::Mat& img, int n) {
  Threads th(1);
  auto orb = cv::ORB::create(n);  // OpenCV defaults: 1.2, 8 levels, Harris score
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  for (auto _ : st) orb->detectAndCompute(img, cv::noArray(), kps, desc);
  st.counters["kps"] = static_cast<double>(kps.size());
}

void BM_Ours_VGA_1000(benchmark::State& st) { runOurs(st, images().tum_gray, 1000, false); }
void BM_Ours_VGA_1000_2threads(benchmark::State& st) { runOurs(st, images().tum_gray, 1000, true); }
void BM_CvOrb_VGA_1000(benchmark::State& st) { runCvOrb(st, images().tum_gray, 1000); }
void BM_Ours_Kitti_2000(benchmark::State& st) { runOurs(st, images().kitti_l, 2000, false); }
void BM_Ours_Kitti_2000_2threads(benchmark::State& st) { runOurs(st, images().kitti_l, 2000, true); }
void BM_CvOrb_Kitti_2000(benchmark::State& st) { runCvOrb(st, images().kitti_l, 2000); }

/** Descriptors only: our BRIEF (blur + pattern) vs cv::ORB::compute on our
 *  keypoints (it rebuilds and blurs its own pyramid). */
void BM_DescribeOurs_VGA(benchmark::State& st) {
  Threads th(1);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  double des = 0;
  for (auto _ : st) {
    ex.extract(images().tum_gray, kps, desc);
    des += ex.lastTimings().describe_ms;
  }
  st.counters["describe_cpu_ms"] = benchmark::Counter(des, benchmark::Counter::kAvgIterations);
}
void BM_DescribeCvOrbCompute_VGA(benchmark::State& st) {
  Threads th(1);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  ex.extract(images().tum_gray, kps, desc);
  auto orb = cv::ORB::create(1000, 1.2f, 8, 19, 0, 2, cv::ORB::FAST_SCORE, 31, 20);
  cv::Mat d2;
  for (auto _ : st) {
    std::vector<cv::KeyPoint> k = kps;
    orb->compute(images().tum_gray, k, d2);
  }
  st.counters["kps"] = static_cast<double>(d2.rows);
}

void BM_StereoMatch_Kitti_2000(benchmark::State& st) {
  Threads th(1);
  OrbParams p;
  p.n_features = 2000;
  OrbExtractor l(p), r(p);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  l.extract(images().kitti_l, kl, dl);
  r.extract(images().kitti_r, kr, dr);
  std::vector<float> ur, depth;
  StereoMatchParams sp = st.range(0) ? StereoMatchParams::orbSlam2() : StereoMatchParams();
  StereoMatchStats s;
  for (auto _ : st) s = computeStereoMatches(l, kl, dl, r, kr, dr, 386.1448f, 386.1448f / 718.856f, ur, depth, sp);
  st.counters["matches"] = s.matched;
  st.SetLabel(st.range(0) ? "orb-slam2 refinement" : "default refinement");
}

void runFrontendKitti(benchmark::State& st, bool parallel) {
  Threads th(parallel ? 2 : 1);
  FrontendParams p;
  p.orb.n_features = 2000;
  p.parallel_stereo = parallel;
  FeatureFrontend fe(*cameraPreset("kitti_00_02"), p);
  SensorFrame in;
  in.image = images().kitti_l;
  in.image_right = images().kitti_r;
  size_t matched = 0;
  for (auto _ : st) {
    Frame f = fe.process(in);
    matched = static_cast<size_t>(fe.lastStereoStats().matched);
    benchmark::DoNotOptimize(f.keypoints.data());
  }
  st.counters["matches"] = static_cast<double>(matched);
}
void BM_FrontendStereo_Kitti_2000(benchmark::State& st) { runFrontendKitti(st, false); }
void BM_FrontendStereo_Kitti_2000_2threads(benchmark::State& st) { runFrontendKitti(st, true); }

void BM_FrontendRgbd_TUM_1000(benchmark::State& st) {
  Threads th(1);
  FeatureFrontend fe(*cameraPreset("tum_fr2"));
  SensorFrame in;
  in.image = images().tum_bgr;
  in.depth = images().tum_depth;  // uint16, 5000 per metre
  for (auto _ : st) {
    Frame f = fe.process(in);
    benchmark::DoNotOptimize(f.keypoints.data());
  }
}

}  // namespace

BENCHMARK(BM_Ours_VGA_1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CvOrb_VGA_1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ours_VGA_1000_2threads)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Ours_Kitti_2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CvOrb_Kitti_2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ours_Kitti_2000_2threads)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DescribeOurs_VGA)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DescribeCvOrbCompute_VGA)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StereoMatch_Kitti_2000)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FrontendStereo_Kitti_2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FrontendStereo_Kitti_2000_2threads)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_FrontendRgbd_TUM_1000)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
