// End to end: the synthetic STDyn-SLAM pipeline (stereo) on a short walking
// scene writes the dense map and its pictures by default; with the dynamic
// mask the map holds (almost) no voxel where only the walkers ever were,
// without it many: the ghost-rate ratio of the dense-map issue.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <filesystem>

#include "dslam/config/pipeline.h"
#include "dslam/core/registry.h"
#include "dslam/dense/dense_eval.h"
#include "dslam/slam/system.h"
#include "synth_cache.h"
#include "test_support.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

dense::DenseEvalResult runAndEvaluate(const std::string& scene, const std::string& out, bool mask, RunSummary* sum) {
  register_builtin_plugins();
  auto pc = config::loadPipeline(test::source("config/pipelines/synthetic/stdyn_slam.yaml"));
  EXPECT_TRUE(pc.outputs.getBool("dense_map"));  // on by default in this pipeline
  if (!mask) pc.sections.at("dense_map").set("mask", "false");
  RunOverrides ov;
  ov.dataset = scene;
  ov.out_dir = out;
  ov.quiet_progress = true;
  *sum = runPipeline(pc, ov);
  const dense::DenseMapFile m = dense::loadDenseMap(out + "/map.bt");
  EXPECT_EQ(m.dataset_scenario, "walking_xyz");  // dense.json names the scene, for eval dense's check
  EXPECT_EQ(m.dataset_frames, 150);
  return dense::evaluateDense(m, dense::sceneScenario(scene));
}

}  // namespace

TEST(DenseE2E, StdynWalkingGhostRateWithAndWithoutTheMask) {
  const std::string scene = test::syntheticSequence("walking_xyz", 150, 320, 240, /*stereo=*/true);
  // A fixed folder in the build tree: CI keeps the pictures of this run.
  const std::string out = std::string(DSLAM_TEST_BINARY_DIR) + "/test_output/dense_e2e";
  fs::remove_all(out);
  RunSummary with_sum, without_sum;
  const auto with = runAndEvaluate(scene, out + "/masked", true, &with_sum);
  const auto without = runAndEvaluate(scene, out + "/unmasked", false, &without_sum);
  std::cout << "walking_xyz 150 frames 320x240, stdyn_slam, 5 cm voxels:\n  masked:   " << dense::toJson(with)
            << "\n  unmasked: " << dense::toJson(without) << "\n  pictures: " << out << "/masked/dense_top.png\n";
  EXPECT_EQ(with_sum.tracked, with_sum.frames);
  EXPECT_GT(with.occupied, 2000u);
  EXPECT_LE(with.ghost_rate, 0.01);
  EXPECT_GE(without.ghost_rate, 10 * with.ghost_rate);
  EXPECT_GE(without.ghost, 50u);  // 149 measured: the walkers of the first 5 s
  EXPECT_LE(with.alignment_rmse, 0.05);
  // Pictures: readable, of a sensible size, not blank.
  for (const char* name : {"dense_top.png", "dense_side.png"}) {
    const cv::Mat img = cv::imread(out + "/masked/" + name);
    ASSERT_FALSE(img.empty()) << name;
    EXPECT_GE(img.cols, 300) << name;
    EXPECT_GE(img.rows, 200) << name;
    cv::Scalar mean, sd;
    cv::meanStdDev(img, mean, sd);
    EXPECT_GT(sd[0] + sd[1] + sd[2], 30.0) << name;
  }
  for (const char* name : {"map.bt", "dense.ply", "dense.json"}) EXPECT_TRUE(fs::exists(out + "/masked/" + name)) << name;
}
