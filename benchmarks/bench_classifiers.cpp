// Keypoint classifiers: time per frame of each plugin (default parameters)
// on a real 640x480 TUM fr1 RGB-D pair with ~1000 ORB keypoints (the
// features front end with 1000 features) and crafted detections (a person
// box over ~23 % of the image, a chair box, matching semantic / panoptic
// labels). Single core (cv::setNumThreads(1)).
//
// Classifiers that look at the previous frame alternate between the two
// frames (each call has the other as its previous frame), so cached state
// (the LK pyramid of the previous frame, panoptic associations) is in its
// steady state as in a running pipeline.
//
// Medians: --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <iostream>
#include <mutex>

#include <opencv2/core/utility.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dslam/core/camera_presets.h"
#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/features/frontend.h"
#include "dslam/plugins/classifiers/epipolar_consistency.h"

using namespace dslam;

namespace {

struct Data {
  CameraModel cam;
  Frame f[2];
  Detections d[2];
  SE3 T_wc[2];  ///< camera poses (frame 0 = world), from PnP-RANSAC on ORB matches: the motion-model prior
};

/** Pose of frame 1 relative to frame 0 by PnP-RANSAC on brute-force ORB
 *  matches with frame 0's depth (independent of dslam's tracker). */
SE3 relativePose(const CameraModel& cam, const Frame& a, const Frame& b) {
  cv::BFMatcher bf(cv::NORM_HAMMING, true);
  std::vector<cv::DMatch> m;
  bf.match(a.descriptors, b.descriptors, m);
  std::vector<cv::Point3f> X;
  std::vector<cv::Point2f> x;
  for (const auto& d : m) {
    const float z = a.depth[d.queryIdx];
    if (z <= 0 || d.distance > 50) continue;
    const cv::Point2f& u = a.keypoints_un[d.queryIdx].pt;
    X.emplace_back(static_cast<float>((u.x - cam.left.cx) / cam.left.fx * z),
                   static_cast<float>((u.y - cam.left.cy) / cam.left.fy * z), z);
    x.push_back(b.keypoints_un[d.trainIdx].pt);
  }
  const cv::Mat K = (cv::Mat_<double>(3, 3) << cam.left.fx, 0, cam.left.cx, 0, cam.left.fy, cam.left.cy, 0, 0, 1);
  cv::Mat rvec, tvec, R;
  cv::solvePnPRansac(X, x, K, cv::noArray(), rvec, tvec, false, 500, 2.0f, 0.999);
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) Re(r, c) = R.at<double>(r, c);
  return SE3(Re, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2))).inverse();  // T_w(=a) b
}

Detections labels(int index) {
  Detections d;
  d.frame_index = index;
  const cv::Rect person(200, 80, 180, 360), chair(430, 280, 150, 150), unknown(20, 20, 120, 100);
  BoundingBox p, c;
  p.box = cv::Rect2f(person);
  p.class_id = 1;
  p.score = 0.9f;
  c.box = cv::Rect2f(chair);
  c.class_id = 62;
  c.score = 0.8f;
  d.boxes = {p, c};
  d.semantic = cv::Mat(480, 640, CV_8U, cv::Scalar(199));
  d.semantic(unknown).setTo(255);
  d.semantic(person).setTo(1);
  d.semantic(chair).setTo(62);
  d.panoptic = cv::Mat(480, 640, CV_32S, cv::Scalar(199));
  d.panoptic(unknown).setTo(0);
  d.panoptic(person).setTo(1001);
  d.panoptic(chair).setTo(1002);
  d.segments = {{199, 199, SegmentKind::Stuff, -1, 0, {}, 1.f},
                {1001, 1, SegmentKind::Thing, 1, 0, {}, 0.9f},
                {1002, 62, SegmentKind::Thing, 2, 0, {}, 0.8f}};
  return d;
}

const Data& data() {
  static const Data D = [] {
    Data x;
    x.cam = *cameraPreset("tum_fr1");
    FrontendParams fp;
    fp.orb.n_features = 1000;
    FeatureFrontend fe(x.cam, fp);
    const std::string s = sharedDir() + "/data/tum-frames/rgbd-pair/";
    for (int k = 0; k < 2; k++) {
      SensorFrame in;
      in.index = k;
      in.timestamp = k / 30.0;
      in.image = cv::imread(s + std::to_string(k + 1) + ".png", cv::IMREAD_COLOR);
      const cv::Mat raw = cv::imread(s + std::to_string(k + 1) + "_depth.png", cv::IMREAD_UNCHANGED);
      if (in.image.empty() || raw.empty()) {
        std::cerr << "bench_classifiers: images missing under " << s << "\n";
        std::exit(1);
      }
      raw.convertTo(in.depth, CV_32F, 1.0 / x.cam.depth_factor);
      x.f[k] = fe.process(in);
      x.d[k] = labels(k);
    }
    x.T_wc[1] = relativePose(x.cam, x.f[0], x.f[1]);
    return x;
  }();
  return D;
}

std::shared_ptr<KeypointClassifier> make(const std::string& name, const std::string& yaml = "") {
  static std::once_flag once;
  std::call_once(once, [] { register_builtin_plugins(); });
  auto c = create<KeypointClassifier>("dslam::" + name);
  PluginContext pc;
  pc.camera = &data().cam;
  c->configure(Params::resolve(c->paramSpecs(), yaml), pc);
  return c;
}

/** Times classify() (and afterTracking() if `after`) per frame. */
void run(benchmark::State& st, const std::string& name, const std::string& yaml = "", bool after = false) {
  cv::setNumThreads(1);
  const Data& D = data();
  auto c = make(name, yaml);
  Frame f[2] = {D.f[0], D.f[1]};
  size_t k = 0, dyn = 0, moved = 0;
  for (auto _ : st) {
    const int cur = static_cast<int>(k & 1), prev = 1 - cur;
    Frame& fr = f[cur];
    fr.resetMeta();
    ClassifierContext ctx;
    ctx.camera = &D.cam;
    ctx.previous = &f[prev];
    ctx.previous_detections = &D.d[prev];
    ctx.previous_T_wc = D.T_wc[prev];
    ctx.predicted_T_wc = D.T_wc[cur];  // a perfect motion model
    c->classify(fr, D.d[cur], ctx);
    if (after) c->afterTracking(fr, D.d[cur], SE3());
    dyn += fr.countLabel(KpLabel::Dynamic);
    moved += fr.countLabel(KpLabel::Movable);
    k++;
  }
  st.counters["keypoints"] = static_cast<double>(D.f[1].size());
  if (auto e = std::dynamic_pointer_cast<EpipolarConsistency>(c)) {
    st.counters["fit"] = e->lastStats().fit_matches;
    st.counters["inliers"] = e->lastStats().fit_inliers;
    st.counters["matched"] = e->lastStats().matched;
  }
  st.counters["dynamic"] = benchmark::Counter(static_cast<double>(dyn), benchmark::Counter::kAvgIterations);
  st.counters["movable"] = benchmark::Counter(static_cast<double>(moved), benchmark::Counter::kAvgIterations);
}

void BM_BoxFilter(benchmark::State& st) { run(st, "BoxFilter"); }
void BM_SemanticFilter(benchmark::State& st) { run(st, "SemanticFilter"); }
void BM_SemanticFilterDilated(benchmark::State& st) { run(st, "SemanticFilter", "dilation: 5"); }
void BM_SemanticFilterPanoptic(benchmark::State& st) { run(st, "SemanticFilter", "source: panoptic"); }
void BM_AdaptiveFeatureCount(benchmark::State& st) { run(st, "AdaptiveFeatureCount"); }
void BM_DepthRepopulation(benchmark::State& st) { run(st, "DepthRepopulation"); }
void BM_DepthRepopulationStride1(benchmark::State& st) { run(st, "DepthRepopulation", "pixel_stride: 1"); }
void BM_EpipolarFlow(benchmark::State& st) { run(st, "EpipolarConsistency"); }
// Cheaper settings than the papers': USAC instead of RANSAC on at most 300
// correspondences, smaller LK window / fewer levels, a search radius.
const char* kFastRansac = "ransac_method: usac\nmax_fit_points: 300\n";
void BM_EpipolarFlowFast(benchmark::State& st) {
  run(st, "EpipolarConsistency", std::string(kFastRansac) + "lk_window: 15\nlk_levels: 3\nlk_iterations: 10\nlk_epsilon: 0.03");
}
void BM_EpipolarDescriptors(benchmark::State& st) { run(st, "EpipolarConsistency", "matching: descriptors"); }
void BM_EpipolarDescriptorsFast(benchmark::State& st) {
  run(st, "EpipolarConsistency", std::string(kFastRansac) + "matching: descriptors\nsearch_radius: 80");
}
// The settings of the shipped pipelines (config/pipelines/*.yaml): motion-model prior, few LK levels.
const char* kPrior = "motion_prior: true\n";
void BM_EpipolarFlowShipped(benchmark::State& st) {
  // DSLAM_BENCH_FLOW_PARAMS (YAML lines) replaces the LK settings, for tuning.
  const char* env = std::getenv("DSLAM_BENCH_FLOW_PARAMS");
  const std::string lk = env ? env : "lk_window: 11\nlk_levels: 0\nlk_iterations: 10\n";
  run(st, "EpipolarConsistency", std::string(kPrior) + lk + "\nmax_fit_points: 300");
}
void BM_EpipolarDescriptorsShipped(benchmark::State& st) {
  run(st, "EpipolarConsistency", std::string(kPrior) + "matching: descriptors\nsearch_radius: 80\nmax_fit_points: 300");
}
void BM_PanopticClassifierShipped(benchmark::State& st) {
  run(st, "PanopticClassifier", std::string(kPrior) + "search_radius: 80\nmax_fit_points: 300");
}
void BM_PanopticClassifier(benchmark::State& st) { run(st, "PanopticClassifier"); }
void BM_PanopticClassifierFast(benchmark::State& st) {
  run(st, "PanopticClassifier", std::string(kFastRansac) + "search_radius: 80");
}
void BM_EkfObjectTracker(benchmark::State& st) { run(st, "EkfObjectTracker", "", true); }

}  // namespace

BENCHMARK(BM_BoxFilter)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SemanticFilter)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SemanticFilterDilated)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SemanticFilterPanoptic)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AdaptiveFeatureCount)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DepthRepopulation)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DepthRepopulationStride1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EpipolarFlow)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EpipolarFlowFast)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EpipolarDescriptors)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EpipolarDescriptorsFast)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PanopticClassifier)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PanopticClassifierFast)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EpipolarFlowShipped)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EpipolarDescriptorsShipped)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PanopticClassifierShipped)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EkfObjectTracker)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
