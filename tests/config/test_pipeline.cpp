#include <gtest/gtest.h>

#include "dslam/config/pipeline.h"
#include "dslam/core/error.h"
#include "dslam/core/registry.h"
#include "test_support.h"

using namespace dslam;

namespace {
const char* kGood = R"(pipeline:
  name: demo
  mode: parallel
  seed: 7
dataset:
  type: dslam::TumDataset
  params:
    path: data/seq
  on_bad_frame: skip
camera:
  preset: tum_fr3
outputs:
  trajectory_format: kitti
)";

std::string errorOf(const std::string& text) {
  register_builtin_plugins();
  try {
    config::loadPipelineText(text, "/cfg");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Pipeline, LoadsAndFillsDefaults) {
  register_builtin_plugins();
  const auto pc = config::loadPipelineText(kGood, "/cfg");
  EXPECT_EQ(pc.name, "demo");
  EXPECT_EQ(pc.mode, config::Mode::Parallel);
  EXPECT_EQ(pc.seed, 7u);
  ASSERT_TRUE(pc.dataset);
  EXPECT_EQ(pc.dataset->type, "dslam::TumDataset");
  EXPECT_EQ(pc.dataset->on_bad_frame, config::OnBadFrame::Skip);
  EXPECT_EQ(pc.dataset->params.getString("path"), "/cfg/data/seq");
  EXPECT_DOUBLE_EQ(pc.dataset->params.getDouble("max_dt"), 0.02);
  ASSERT_TRUE(pc.camera);
  EXPECT_DOUBLE_EQ(pc.camera->left.fx, 535.4);
  EXPECT_EQ(pc.outputs.getString("trajectory_format"), "kitti");
  EXPECT_EQ(pc.outputs.getString("trajectory"), "trajectory.txt");
}

TEST(Pipeline, ResolvedConfigReloadsToTheSameConfig) {
  register_builtin_plugins();
  const auto pc = config::loadPipelineText(kGood, "/cfg");
  const std::string y = pc.toYaml();
  EXPECT_NE(y.find("max_dt: 0.02"), std::string::npos) << y;  // defaults are written
  const auto again = config::loadPipelineText(y, "/cfg");
  EXPECT_EQ(again.toYaml(), y);
}

TEST(Pipeline, MisspelledKeysNameTheKeyAndTheValidOnes) {
  std::string e = errorOf("pipeline:\n  nmae: x\n");
  EXPECT_NE(e.find("<text>:2: key 'pipeline.nmae': unknown parameter, did you mean 'name'?"), std::string::npos) << e;
  EXPECT_NE(e.find("valid: name, mode, seed"), std::string::npos) << e;
  e = errorOf("pipline:\n  name: x\n");
  EXPECT_NE(e.find("unknown section, did you mean 'pipeline'?"), std::string::npos) << e;
  e = errorOf("dataset:\n  type: dslam::TumDataset\n  params:\n    path: x\n    max_dtt: 1\n");
  EXPECT_NE(e.find("key 'dataset.params.max_dtt'"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'max_dt'"), std::string::npos) << e;
}

TEST(Pipeline, WrongTypesMissingKeysUnknownPlugins) {
  EXPECT_NE(errorOf("pipeline:\n  seed: abc\n").find("key 'pipeline.seed': expected an integer"), std::string::npos);
  EXPECT_NE(errorOf("dataset:\n  params: {}\n").find("missing required parameter"), std::string::npos);
  EXPECT_NE(errorOf("dataset:\n  type: dslam::TumDataset\n").find("'dataset.params.path'"), std::string::npos);
  std::string e = errorOf("dataset:\n  type: dslam::Nope\n  params: {}\n");
  EXPECT_NE(e.find("key 'dataset.type'"), std::string::npos) << e;
  EXPECT_NE(e.find("valid DatasetSource plugins:"), std::string::npos) << e;
  e = errorOf("modules:\n  - name: a\n    typ: x\n");
  EXPECT_NE(e.find("key 'modules[0].typ': unknown key, did you mean 'type'?"), std::string::npos) << e;
  e = errorOf("modules:\n  - name: a\n");
  EXPECT_NE(e.find("missing required key 'type'"), std::string::npos) << e;
  e = errorOf("modules:\n  - name: a\n    type: dslam::NoSuchPlugin\n");
  EXPECT_NE(e.find("unknown plugin type 'dslam::NoSuchPlugin'"), std::string::npos) << e;
  e = errorOf("modules:\n  - name: a\n    type: dslam::TumDataset\n");
  EXPECT_NE(e.find("'dataset:' section"), std::string::npos) << e;
  e = errorOf("camera:\n  sensor: rgbd\n");
  EXPECT_NE(e.find("missing required key 'width'"), std::string::npos) << e;
}

TEST(Pipeline, CliConfigCheckAndShow) {
  const std::string d = test::tempDir("pipe");
  test::writeFile(d + "/cam.yaml", "preset: tum_fr1\n");
  test::writeFile(d + "/good.yaml", std::string(kGood).replace(std::string(kGood).find("camera:\n  preset: tum_fr3\n"),
                                                               std::string("camera:\n  preset: tum_fr3\n").size(),
                                                               "camera: $include{cam.yaml}\n"));
  auto r = test::runDslam("config check " + d + "/good.yaml");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("OK"), std::string::npos) << r.out;
  r = test::runDslam("config show " + d + "/good.yaml");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("fx: 517.306408"), std::string::npos) << r.out;  // included camera, resolved
  EXPECT_NE(r.out.find("on_bad_frame: skip"), std::string::npos) << r.out;
  test::writeFile(d + "/bad.yaml", "pipeline:\n  name: x\n  seeed: 3\n");
  r = test::runDslam("config check " + d + "/bad.yaml");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("bad.yaml:3: key 'pipeline.seeed': unknown parameter, did you mean 'seed'?"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("valid: name, mode, seed"), std::string::npos) << r.out;
}

TEST(Pipeline, DetectsDatasetTypeFromLayout) {
  const std::string d = test::tempDir("detect");
  test::writeFile(d + "/tum/rgb.txt", "# x\n");
  test::writeFile(d + "/rgbd_bonn_balloon/rgb.txt", "# x\n");
  test::writeFile(d + "/kitti/calib.txt", "P0: 1\n");
  test::writeFile(d + "/euroc/mav0/cam0/data.csv", "#\n");
  test::writeFile(d + "/x.rawlog", "");
  EXPECT_EQ(config::detectDatasetType(d + "/tum"), "dslam::TumDataset");
  EXPECT_EQ(config::detectDatasetType(d + "/rgbd_bonn_balloon"), "dslam::BonnDataset");
  EXPECT_EQ(config::detectDatasetType(d + "/kitti"), "dslam::KittiDataset");
  EXPECT_EQ(config::detectDatasetType(d + "/euroc"), "dslam::EurocDataset");
  EXPECT_EQ(config::detectDatasetType(d + "/x.rawlog"), "dslam::RawlogDataset");
  EXPECT_EQ(config::detectDatasetType(d), "");
}

TEST(Pipeline, DetectionModeAndCarryOfDetectors) {
  register_builtin_plugins();
  const auto pc = config::loadPipelineText(
      "modules:\n  - name: people\n    type: dslam::HogPeopleDetector\n    detection: async\n    carry: none\n", "/cfg");
  ASSERT_EQ(pc.modules.size(), 1u);
  EXPECT_EQ(pc.modules[0].detection, "async");
  EXPECT_EQ(pc.modules[0].carry, "none");
  EXPECT_NE(pc.toYaml().find("    detection: async\n    carry: none\n"), std::string::npos) << pc.toYaml();
  EXPECT_EQ(config::loadPipelineText("modules:\n  - name: p\n    type: dslam::HogPeopleDetector\n", "/cfg").modules[0].carry,
            "flow");
  std::string e = errorOf("modules:\n  - name: p\n    type: dslam::HogPeopleDetector\n    carry: flwo\n");
  EXPECT_NE(e.find("key 'modules[0].carry': expected flow | none, did you mean 'flow'?, got"), std::string::npos) << e;
  e = errorOf("modules:\n  - name: p\n    type: dslam::HogPeopleDetector\n    detection: later\n");
  EXPECT_NE(e.find("key 'modules[0].detection': expected auto | sync | async"), std::string::npos) << e;
  e = errorOf("modules:\n  - name: f\n    type: dslam::BoxFilter\n    carry: none\n");
  EXPECT_NE(e.find("'carry' applies to detectors only"), std::string::npos) << e;
}

TEST(Pipeline, WaitCoverageOfDetectors) {
  register_builtin_plugins();
  const auto pc = config::loadPipelineText(
      "modules:\n  - name: people\n    type: dslam::HogPeopleDetector\n    wait_coverage: 0.5\n", "/cfg");
  ASSERT_EQ(pc.modules.size(), 1u);
  EXPECT_DOUBLE_EQ(pc.modules[0].wait_coverage, 0.5);
  EXPECT_NE(pc.toYaml().find("    wait_coverage: 0.5\n"), std::string::npos) << pc.toYaml();
  EXPECT_EQ(config::loadPipelineText("modules:\n  - name: p\n    type: dslam::HogPeopleDetector\n", "/cfg")
                .modules[0]
                .wait_coverage,
            0.0);
  for (const char* bad : {"1.5", "-0.1", "half", "''"}) {
    const std::string e =
        errorOf(std::string("modules:\n  - name: p\n    type: dslam::HogPeopleDetector\n    wait_coverage: ") + bad + "\n");
    EXPECT_NE(e.find("key 'modules[0].wait_coverage': expected a number in [0, 1]"), std::string::npos) << bad << ": " << e;
  }
  const std::string e = errorOf("modules:\n  - name: f\n    type: dslam::BoxFilter\n    wait_coverage: 0.5\n");
  EXPECT_NE(e.find("'wait_coverage' applies to detectors only"), std::string::npos) << e;
}

TEST(Pipeline, DetectorsRunEveryNthFrame) {
  register_builtin_plugins();
  const auto pc = config::loadPipelineText(
      "modules:\n  - name: people\n    type: dslam::HogPeopleDetector\n    every: 3\n"
      "  - name: filter\n    type: dslam::BoxFilter\n    inputs: [people]\n",
      "/cfg");
  ASSERT_EQ(pc.modules.size(), 2u);
  EXPECT_EQ(pc.modules[0].every, 3);
  EXPECT_EQ(pc.modules[1].every, 1);
  EXPECT_NE(pc.toYaml().find("    every: 3\n"), std::string::npos) << pc.toYaml();
  std::string e = errorOf("modules:\n  - name: p\n    type: dslam::HogPeopleDetector\n    every: 0\n");
  EXPECT_NE(e.find("key 'modules[0].every': expected an integer >= 1"), std::string::npos) << e;
  e = errorOf("modules:\n  - name: f\n    type: dslam::BoxFilter\n    every: 2\n");
  EXPECT_NE(e.find("'every' applies to detectors only"), std::string::npos) << e;
}
