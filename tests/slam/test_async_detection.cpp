// Asynchronous detection in a running System (parallel mode): tracking never
// waits for a slow detector, frames get its latest result carried to them
// with their age; sync mode pairs every frame with its own detection.
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "dslam/core/dataset.h"
#include "dslam/core/detector.h"
#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/registry.h"
#include "dslam/features/frontend.h"
#include "dslam/map/map.h"
#include "dslam/map/map_point.h"
#include "dslam/slam/detection_carry.h"
#include "dslam/slam/system.h"
#include "plugin_util.h"
#include "synth_cache.h"
#include "test_support.h"

namespace dslam_test {

/** A detector that, after its first call, blocks until the test opens the
 *  gate (at most 30 s): a System that waited for it would stall. Its
 *  output: `boxes(frame)`, by default one fixed person box. */
class GatedDetector : public dslam::Detector {
  DEFINE_MRPT_OBJECT(GatedDetector, dslam_test)
 public:
  std::string description() const override { return "test: blocks until released"; }
  unsigned outputs() const override { return dslam::kBoxes; }
  dslam::Detections detect(const dslam::SensorFrame& f) override {
    std::unique_lock<std::mutex> lk(m);
    if (calls++ > 0) timed_out |= !cv.wait_for(lk, std::chrono::seconds(30), [this] { return open; });
    dslam::Detections d;
    d.boxes = boxes(f);
    return d;
  }
  std::function<std::vector<dslam::BoundingBox>(const dslam::SensorFrame&)> boxes =
      [](const dslam::SensorFrame& f) { return std::vector<dslam::BoundingBox>{{cv::Rect2f(100, 60, 80, 120), 1, 0.9f, f.index}}; };
  void release() {
    std::lock_guard<std::mutex> lk(m);
    open = true;
    cv.notify_all();
  }
  std::mutex m;
  std::condition_variable cv;
  bool open = false, timed_out = false;
  int calls = 0;
};

/** Records what each frame's classifier saw. */
class Probe : public dslam::KeypointClassifier {
  DEFINE_MRPT_OBJECT(Probe, dslam_test)
 public:
  std::string description() const override { return "test: records detections"; }
  void classify(dslam::Frame& f, const dslam::Detections& d, const dslam::ClassifierContext&) override {
    seen.push_back({f.index(), d.valid, d.frame_index, d.age_frames});
  }
  struct Seen {
    int frame;
    bool valid;
    int det_frame, age;
  };
  std::vector<Seen> seen;
};

/** Records the boxes and age each frame's classifier saw. */
class BoxProbe : public dslam::KeypointClassifier {
  DEFINE_MRPT_OBJECT(BoxProbe, dslam_test)
 public:
  std::string description() const override { return "test: records boxes"; }
  void classify(dslam::Frame&, const dslam::Detections& d, const dslam::ClassifierContext&) override {
    std::vector<cv::Rect2f> b;
    for (const auto& x : d.boxes) b.push_back(x.box);
    boxes.push_back(b);
    ages.push_back(d.age_frames);
  }
  std::vector<std::vector<cv::Rect2f>> boxes;
  std::vector<int> ages;
};

}  // namespace dslam_test

IMPLEMENTS_MRPT_OBJECT(GatedDetector, dslam::Detector, dslam_test)
IMPLEMENTS_MRPT_OBJECT(Probe, dslam::KeypointClassifier, dslam_test)
IMPLEMENTS_MRPT_OBJECT(BoxProbe, dslam::KeypointClassifier, dslam_test)

using namespace dslam;

namespace {

std::shared_ptr<DatasetSource> scene() {
  return test::openDataset("dslam::TumDataset",
                           test::cat("path: ", test::syntheticSequence("static_office", 40, 320, 240), "\n"));
}

/** A parallel-mode System (no place recognition) whose detector "gated"
 *  feeds the classifier "probe". */
std::unique_ptr<System> probedSystem(const DatasetSource& ds, std::shared_ptr<Detector> det,
                                     std::shared_ptr<KeypointClassifier> probe, System::DetectionMode mode,
                                     bool carry_by_flow = true, double wait_coverage = 0.0) {
  SlamParams sp;
  sp.place.enabled = false;
  auto sys = std::make_unique<System>(*ds.camera(), sp, test::defaultBackend(), config::Mode::Parallel);
  sys->addDetector("gated", std::move(det), 1, mode, carry_by_flow, true, 0, wait_coverage);
  sys->addClassifier("probe", std::move(probe), "gated");
  return sys;
}

}  // namespace

TEST(AsyncDetection, TrackingDoesNotWaitForASlowDetector) {
  auto ds = scene();
  auto det = std::make_shared<dslam_test::GatedDetector>();
  auto probe = std::make_shared<dslam_test::Probe>();
  {
    auto sys = probedSystem(*ds, det, probe, System::DetectionMode::Async);
    for (size_t i = 0; i < 20; i++) sys->track(ds->read(i));  // the detector is stuck on frame 1 meanwhile
    det->release();
    // Once released, frames go on getting the latest finished detection.
    for (size_t i = 20; i < ds->size(); i++) sys->track(ds->read(i));
    sys->shutdown();
  }
  EXPECT_FALSE(det->timed_out) << "the System waited for the blocked detector";
  ASSERT_EQ(probe->seen.size(), ds->size());
  // Frame 0 waits for its own detection (no map on undetected movers).
  EXPECT_TRUE(probe->seen[0].valid);
  EXPECT_EQ(probe->seen[0].det_frame, 0);
  EXPECT_EQ(probe->seen[0].age, 0);
  // While the detector is blocked on frame 1, frames 1..19 get frame 0's
  // detection carried to them, ever older.
  for (int k = 1; k < 20; k++) {
    EXPECT_TRUE(probe->seen[k].valid) << k;
    EXPECT_EQ(probe->seen[k].det_frame, 0) << k;
    EXPECT_EQ(probe->seen[k].age, k) << k;
  }
  // After the release, a newer detection arrives and ages stay small.
  EXPECT_GT(probe->seen.back().det_frame, 1);
  EXPECT_LT(probe->seen.back().age, 10);
}

// wait_coverage: a frame whose carried boxes cover more of the image than
// the threshold waits for the running detection; other frames do not.
TEST(AsyncDetection, WaitCoverageWaitsOnlyWhenCarriedBoxesCoverTheImage) {
  auto ds = scene();  // 320 x 240
  struct Case {
    cv::Rect2f box;
    double wait_coverage;
    bool waits;
  };
  for (const Case& c : {Case{{0, 0, 200, 230}, 0.5, true},      // 60 % of the image
                        Case{{100, 60, 80, 120}, 0.5, false},   // 12.5 %
                        Case{{0, 0, 200, 230}, 0.0, false}}) {  // off
    SCOPED_TRACE(testing::Message() << "box area " << c.box.area() / (320.0 * 240.0) << ", wait_coverage "
                                    << c.wait_coverage);
    auto det = std::make_shared<dslam_test::GatedDetector>();
    det->boxes = [box = c.box](const SensorFrame& f) { return std::vector<BoundingBox>{{box, 1, 0.9f, f.index}}; };
    auto probe = std::make_shared<dslam_test::Probe>();
    {
      auto sys = probedSystem(*ds, det, probe, System::DetectionMode::Async, true, c.wait_coverage);
      // The detector blocks on frame 1 until released: 0.3 s after the
      // start when the System is expected to wait, after frame 9 else.
      std::thread releaser;
      if (c.waits)
        releaser = std::thread([&] {
          std::this_thread::sleep_for(std::chrono::milliseconds(300));
          det->release();
        });
      for (size_t i = 0; i < 10; i++) sys->track(ds->read(i));
      det->release();
      if (releaser.joinable()) releaser.join();
      sys->shutdown();
    }
    EXPECT_FALSE(det->timed_out);
    ASSERT_EQ(probe->seen.size(), 10u);
    if (c.waits) {
      // Frame 1 carried frame 0's box (60 %), so it waited for its own
      // detection, started on it.
      EXPECT_EQ(probe->seen[1].det_frame, 1);
      EXPECT_EQ(probe->seen[1].age, 0);
    } else {
      for (int k = 1; k < 10; k++) {
        EXPECT_EQ(probe->seen[k].det_frame, 0) << k;
        EXPECT_EQ(probe->seen[k].age, k) << k;
      }
    }
  }
}

TEST(AsyncDetection, SyncModePairsEachFrameWithItsOwnDetection) {
  auto ds = scene();
  auto det = std::make_shared<dslam_test::GatedDetector>();
  det->release();
  auto probe = std::make_shared<dslam_test::Probe>();
  {
    auto sys = probedSystem(*ds, det, probe, System::DetectionMode::Sync);
    for (size_t i = 0; i < 10; i++) sys->track(ds->read(i));
  }
  ASSERT_EQ(probe->seen.size(), 10u);
  for (const auto& s : probe->seen) {
    EXPECT_EQ(s.det_frame, s.frame);
    EXPECT_EQ(s.age, 0);
  }
}

TEST(AsyncDetection, CarryNoneLeavesOlderDetectionsInPlace) {
  auto ds = scene();
  auto det = std::make_shared<dslam_test::GatedDetector>();
  auto probe = std::make_shared<dslam_test::BoxProbe>();
  {
    auto sys = probedSystem(*ds, det, probe, System::DetectionMode::Async, /*carry_by_flow=*/false);
    for (size_t i = 0; i < 10; i++) sys->track(ds->read(i));
    det->release();
    sys->shutdown();
  }
  ASSERT_EQ(probe->boxes.size(), 10u);
  for (size_t k = 0; k < probe->boxes.size(); k++) {
    ASSERT_EQ(probe->boxes[k].size(), 1u) << k;
    EXPECT_EQ(probe->boxes[k][0], cv::Rect2f(100, 60, 80, 120)) << "frame " << k << ": moved although carry: none";
    EXPECT_EQ(probe->ages[k], static_cast<int>(k));
  }
}

// The carry runs on the slot's own thread while ORB runs on the tracking
// thread: each frame gets exactly what carrying the previous frame's
// detection to it in line gives.
TEST(AsyncDetection, CarriedOnItsOwnThreadAsInLine) {
  auto ds = test::openDataset("dslam::TumDataset",
                              test::cat("path: ", test::syntheticSequence("walking_xyz", 150, 320, 240), "\n"));
  auto det = std::make_shared<dslam_test::GatedDetector>();
  det->boxes = [](const SensorFrame& f) {
    return std::vector<BoundingBox>{{cv::Rect2f(120, 40, 90, 160), 1, 0.9f, f.index}};
  };
  auto probe = std::make_shared<dslam_test::BoxProbe>();
  const size_t n = 12;
  {
    auto sys = probedSystem(*ds, det, probe, System::DetectionMode::Async);
    for (size_t i = 0; i < n; i++) sys->track(ds->read(i));  // the detector is blocked on frame 1
    det->release();
    sys->shutdown();
  }
  ASSERT_EQ(probe->boxes.size(), n);
  const bool rgb = ds->camera()->rgb_order;
  Detections d;
  d.valid = true;
  d.boxes = {{cv::Rect2f(120, 40, 90, 160), 1, 0.9f, 0}};
  cv::Mat prev = toGray(ds->read(0).image, rgb);
  int moved = 0;
  for (size_t k = 1; k < n; k++) {
    const cv::Mat cur = toGray(ds->read(k).image, rgb);
    d = carryDetections(d, prev, cur, static_cast<int>(k));
    prev = cur;
    ASSERT_EQ(probe->boxes[k].size(), 1u) << k;
    EXPECT_EQ(probe->boxes[k][0], d.boxes[0].box) << "frame " << k;
    EXPECT_EQ(probe->ages[k], static_cast<int>(k));
    moved += d.boxes[0].box != cv::Rect2f(120, 40, 90, 160);
  }
  EXPECT_GT(moved, 5) << "the camera moves: the box must move with the image";
}

namespace {

struct KeyFrameLabels {
  int keyframes = 0;    ///< keyframes of frames 1..37 (made while the detector was blocked)
  int left_usable = 0;  ///< their usable keypoints in the left half
  int left_points = 0;  ///< their map points in the left half
  size_t awaiting = 0;  ///< keyframes registered for labels that local mapping never took
};

/** Crowd-SLAM's box filter behind a left-half person detector, asynchronous: the
 *  detector blocks on frame 1 until frame 37 was tracked, then runs. */
KeyFrameLabels runLeftHalf(bool redetect, bool& timed_out, bool reversed = false) {
  // The camera of walking_xyz moves enough for keyframes in the first 40 frames.
  auto ds = test::openDataset("dslam::TumDataset",
                              test::cat("path: ", test::syntheticSequence("walking_xyz", 150, 320, 240), "\n"));
  // Frame 0: nothing, later frames a person box over the left half of the
  // image (reversed: the box on frame 0 only). The detector blocks on frame
  // 1, so frames 1.. are given frame 0's detection meanwhile.
  auto det = std::make_shared<dslam_test::GatedDetector>();
  det->boxes = [reversed](const SensorFrame& f) {
    std::vector<BoundingBox> b;
    if ((f.index > 0) != reversed) b.push_back({cv::Rect2f(0, 0, f.image.cols / 2.f, static_cast<float>(f.image.rows)), 1, 0.9f, -1});
    return b;
  };
  SlamParams sp;
  sp.place.enabled = false;
  auto sys = std::make_unique<System>(*ds->camera(), sp, test::defaultBackend(), config::Mode::Parallel);
  sys->addDetector("people", det, 1, System::DetectionMode::Async, true, redetect);
  auto box = create<KeypointClassifier>("dslam::BoxFilter");
  box->configure(Params::resolve(box->paramSpecs(), ""), PluginContext{});
  sys->addClassifier("box_filter", box, "people");
  auto count = create<KeypointClassifier>("dslam::AdaptiveFeatureCount");  // labels nothing: labels are still replaced
  count->configure(Params::resolve(count->paramSpecs(), ""), PluginContext{});
  sys->addClassifier("feature_count", count, "people");
  for (size_t i = 0; i < 38; i++) sys->track(ds->read(i));
  det->release();
  for (size_t i = 38; i < 50; i++) sys->track(ds->read(i));
  sys->shutdown();
  timed_out = det->timed_out;
  KeyFrameLabels out;
  out.awaiting = sys->keyFramesAwaitingLabels();
  const float half = ds->camera()->left.width / 2.f;
  for (const auto& [id, kf] : sys->map()->keyframes()) {
    if (kf->bad) continue;
    for (size_t i = 0; i < kf->size(); i++) {
      if (kf->keys_un[i].pt.x >= half - 2) continue;
      const bool point = kf->points[i] && !kf->points[i]->bad;
      if (kf->frame_index < 1 || kf->frame_index > 37) continue;
      out.left_usable += kf->usable(i);
      out.left_points += point;
    }
    out.keyframes += kf->frame_index >= 1 && kf->frame_index <= 37;
  }
  return out;
}

}  // namespace

TEST(AsyncDetection, KeyFramesAreLabelledAgainFromTheirOwnDetection) {
  bool timed_out = false;
  const KeyFrameLabels redetect = runLeftHalf(true, timed_out);
  EXPECT_FALSE(timed_out);
  const KeyFrameLabels carried = runLeftHalf(false, timed_out);
  EXPECT_FALSE(timed_out);
  // Frames 1..37 were tracked with frame 0's empty detection carried to them.
  ASSERT_GT(carried.keyframes, 0) << "no keyframe while the detector was blocked: the test shows nothing";
  ASSERT_GT(redetect.keyframes, 0);
  EXPECT_GT(carried.left_usable, 50 * carried.keyframes) << "keyframes kept their carried (empty) labels";
  EXPECT_GT(carried.left_points, 20);
  // keyframes: redetect: local mapping waited for each keyframe's own
  // detection (a person over the left half) and labelled it again.
  EXPECT_EQ(redetect.left_usable, 0);
  EXPECT_EQ(redetect.left_points, 0) << "map points of keypoints that became dynamic were dropped";
  EXPECT_EQ(redetect.awaiting, 0u) << "a keyframe taken by local mapping before it was registered";
}

TEST(AsyncDetection, KeyFramesLabelledOnlyByACarriedBoxBecomeUsable) {
  // The person box is on frame 0 only: frames 1..37 get it carried while
  // the detector is blocked; their own detections have no box.
  bool timed_out = false;
  const KeyFrameLabels redetect = runLeftHalf(true, timed_out, /*reversed=*/true);
  EXPECT_FALSE(timed_out);
  const KeyFrameLabels carried = runLeftHalf(false, timed_out, true);
  EXPECT_FALSE(timed_out);
  ASSERT_GT(carried.keyframes, 0);
  ASSERT_GT(redetect.keyframes, 0);
  EXPECT_EQ(carried.left_usable, 0) << "the carried box made the left half dynamic";
  EXPECT_GT(redetect.left_usable, 50 * redetect.keyframes) << "labels from the keyframes' own detections replace the carried ones";
  EXPECT_EQ(redetect.awaiting, 0u);
}
