// End-to-end sequential runs on rendered synthetic scenes (regression guards
// for the accuracy targets of docs/slam.md).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include "dslam/config/pipeline.h"
#include "dslam/core/dataset.h"
#include "dslam/core/registry.h"
#include "dslam/eval/eval.h"
#include "dslam/slam/system.h"
#include "dslam/trajectory/io.h"
#include "plugin_util.h"
#include "synth_cache.h"
#include "test_support.h"

using namespace dslam;

namespace {

struct RunResult {
  Trajectory traj;
  size_t frames = 0, tracked = 0;
  double ate = -1;
};

/** Runs the System over a dataset; `mutate` may alter frames (bad-input tests). */
RunResult runSystem(DatasetSource& ds, const SlamParams& sp,
                    const std::function<void(SensorFrame&)>& mutate = nullptr) {
  System sys(*ds.camera(), sp, test::defaultBackend());
  RunResult r;
  for (size_t i = 0; i < ds.size(); i++) {
    SensorFrame f = ds.read(i);
    if (mutate) mutate(f);
    const auto fr = sys.track(f);
    r.frames++;
    r.tracked += fr.track.state == TrackState::Ok;
  }
  sys.shutdown();
  r.traj = sys.cameraTrajectory();
  if (!ds.groundTruth().empty() && r.traj.size() >= 3) r.ate = eval::computeAte(ds.groundTruth(), r.traj).stats.rmse;
  return r;
}

/** One render for every test of this file; with right/ images for the
 *  stereo test, the others read it as RGB-D. */
std::string staticOffice() { return test::syntheticSequence("static_office", 150, 640, 480, /*stereo=*/true); }

}  // namespace

TEST(SlamE2E, RgbdStaticOfficeMeetsAteTarget) {
  const std::string dir = staticOffice();
  auto ds = test::openDataset("dslam::TumDataset", test::cat("path: ", dir, "\n"));
  const RunResult r = runSystem(*ds, SlamParams{});
  std::cout << "static_office RGB-D: " << r.tracked << "/" << r.frames << " tracked, ATE " << r.ate << " m\n";
  EXPECT_EQ(r.tracked, r.frames);
  EXPECT_GE(r.ate, 0.0);
  EXPECT_LT(r.ate, 0.006);  // target 1 cm, with margin
}

TEST(SlamE2E, StereoStaticOfficeMeetsAteTarget) {
  const std::string dir = staticOffice();
  // The synthetic folder doubles as a KITTI-style stereo sequence (rgb/ + right/ + calib.txt + poses.txt).
  auto ds = test::openDataset("dslam::KittiDataset", test::cat("path: ", dir, "\nleft_dir: rgb\nright_dir: right\n"));
  ASSERT_EQ(ds->sensor(), SensorType::Stereo);
  ASSERT_EQ(ds->groundTruth().size(), ds->size());
  const RunResult r = runSystem(*ds, SlamParams{});
  std::cout << "static_office stereo: " << r.tracked << "/" << r.frames << " tracked, ATE " << r.ate << " m\n";
  EXPECT_EQ(r.tracked, r.frames);
  EXPECT_GE(r.ate, 0.0);
  EXPECT_LT(r.ate, 0.01);
}

TEST(SlamE2E, SequentialModeIsDeterministic) {
  const std::string dir = staticOffice();
  auto ds = test::openDataset("dslam::TumDataset", test::cat("path: ", dir, "\n"));
  SlamParams sp;
  const RunResult a = runSystem(*ds, sp);
  const RunResult b = runSystem(*ds, sp);
  ASSERT_EQ(a.traj.size(), b.traj.size());
  for (size_t i = 0; i < a.traj.size(); i++) {
    EXPECT_EQ(a.traj.stamps[i], b.traj.stamps[i]);
    EXPECT_EQ(a.traj.poses[i].matrix(), b.traj.poses[i].matrix()) << "frame " << i;
  }
}

TEST(SlamE2E, BadFramesAreLostNotFatal) {
  const std::string dir = staticOffice();
  auto ds = test::openDataset("dslam::TumDataset", test::cat("path: ", dir, "\n"));
  // Frames 60-64: all-zero depth; 65-69: black image; 70-74: no depth at all.
  std::vector<int> state(ds->size(), -1);
  System sys(*ds->camera(), SlamParams{}, test::defaultBackend());
  for (size_t i = 0; i < ds->size(); i++) {
    SensorFrame f = ds->read(i);
    if (i >= 60 && i < 65) f.depth.setTo(0);
    if (i >= 65 && i < 70) f.image.setTo(0);
    if (i >= 70 && i < 75) f.depth.release();
    state[i] = static_cast<int>(sys.track(f).track.state);
  }
  sys.shutdown();
  for (size_t i = 65; i < 70; i++) EXPECT_EQ(state[i], static_cast<int>(TrackState::Lost)) << "black frame " << i;
  // Tracking comes back after the bad frames (relocalisation) and stays.
  int ok_after = 0;
  for (size_t i = 80; i < ds->size(); i++) ok_after += state[i] == static_cast<int>(TrackState::Ok);
  EXPECT_EQ(ok_after, static_cast<int>(ds->size()) - 80);
  std::vector<int> lost;
  const Trajectory t = sys.cameraTrajectory(&lost);
  EXPECT_GE(lost.size(), 5u);
  EXPECT_EQ(t.size() + lost.size(), ds->size());
  const double ate = eval::computeAte(ds->groundTruth(), t).stats.rmse;
  EXPECT_LT(ate, 0.01);
}

TEST(SlamE2E, RunCommandWritesOutputsAndReportsAte) {
  const std::string dir = staticOffice();
  const std::string out = test::tempDir("run");
  const auto r = test::runDslam(test::cat("run ", test::source("config/pipelines/orbslam_baseline.yaml"), " --dataset ",
                                          dir, " --out ", out, " --max-frames 60 --no-progress"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  for (const char* f : {"trajectory.txt", "keyframes.txt", "map.ply", "config.resolved.yaml", "timing.csv",
                        "summary.json", "events.jsonl"})
    EXPECT_TRUE(std::filesystem::exists(test::cat(out, "/", f))) << f;
  EXPECT_NE(r.out.find("ATE: 0.0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("tracking time per frame: median"), std::string::npos) << r.out;
  const std::string traj = test::readFile(out + "/trajectory.txt");
  EXPECT_NE(traj.find("tracked frames only: 60 of 60"), std::string::npos) << traj.substr(0, 300);
  const std::string csv = test::readFile(out + "/timing.csv");
  EXPECT_NE(csv.find("frame,orb_ms"), std::string::npos);
  // summary.json: the run as counted by the runner.
  const auto sum = nlohmann::json::parse(test::readFile(out + "/summary.json"));
  EXPECT_EQ(sum.at("pipeline"), "orbslam_baseline");
  EXPECT_EQ(sum.at("finished"), true);
  EXPECT_EQ(sum.at("stopped_by"), "");
  EXPECT_EQ(sum.at("frames"), 60);
  EXPECT_EQ(sum.at("tracked"), 60);
  EXPECT_EQ(sum.at("maps"), 1);
  EXPECT_GE(sum.at("keyframes").get<int>(), 2);
  EXPECT_GE(sum.at("map_points").get<int>(), 500);  // >= 100 points with depth per keyframe, several keyframes
  EXPECT_EQ(sum.at("ate_pairs"), 60);
  EXPECT_GT(sum.at("ate_rmse").get<double>(), 0.0);
  EXPECT_LT(sum.at("ate_rmse").get<double>(), 0.01);
  EXPECT_GT(sum.at("median_ms").get<double>(), 0.0);
  EXPECT_EQ(traj::read(out + "/trajectory.txt").size(), sum.at("tracked").get<size_t>());
  // events.jsonl: one JSON object per line; a clean static run initialises
  // one map at frame 0 and has nothing else to report (no loss, no loop).
  std::ifstream ev(out + "/events.jsonl");
  std::vector<nlohmann::json> events;
  for (std::string l; std::getline(ev, l);) events.push_back(nlohmann::json::parse(l));
  ASSERT_EQ(events.size(), 1u) << test::readFile(out + "/events.jsonl");
  EXPECT_EQ(events[0].at("event"), "map_initialised");
  EXPECT_EQ(events[0].at("frame"), 0);
  EXPECT_EQ(events[0].at("map"), 0);
  // The resolved config re-validates.
  EXPECT_EQ(test::runDslam(test::cat("config check ", out, "/config.resolved.yaml")).exit_code, 0);
}
