// `dslam plugins`, `dslam dataset info` and `dslam convert` from the command line.
#include <cstdlib>

#include "ds_test_util.h"

namespace fs = std::filesystem;
using namespace dslam::test;

namespace {
bool has(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }
}  // namespace

TEST(DatasetsCli, PluginsListsEveryReader) {
  const auto r = runDslam("plugins -i DatasetSource");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  for (const char* n : {"dslam::TumDataset", "dslam::BonnDataset", "dslam::KittiDataset", "dslam::EurocDataset",
                        "dslam::RawlogDataset"})
    EXPECT_TRUE(has(r.out, n)) << n << "\n" << r.out;
}

TEST(DatasetsCli, InfoKitti) {
  const std::string dir = shared("data/kitti-stereo-51");
  if (dir.empty()) GTEST_SKIP();
  const auto r = runDslam("dataset info " + dir + " --check");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "type:         dslam::KittiDataset")) << r.out;
  EXPECT_TRUE(has(r.out, "frames:       51")) << r.out;
  EXPECT_TRUE(has(r.out, "last stamp:   5.000000")) << r.out;
  EXPECT_TRUE(has(r.out, "rate:         10.00 Hz")) << r.out;
  EXPECT_TRUE(has(r.out, "image:        1241x376 8-bit grey")) << r.out;
  EXPECT_TRUE(has(r.out, "fx=718.856 fy=718.856 cx=607.1928 cy=185.2157")) << r.out;
  EXPECT_TRUE(has(r.out, "bf=386.1448")) << r.out;
  EXPECT_TRUE(has(r.out, "ground truth: 51 poses")) << r.out;
  EXPECT_TRUE(has(r.out, "51 of 51 frames read")) << r.out;
}

TEST(DatasetsCli, InfoEurocAndRawlog) {
  const std::string eu = shared("data/euroc-v101-micro");
  const std::string rl = shared("data/mrpt/tests_rgbd.rawlog");
  if (eu.empty() || rl.empty()) GTEST_SKIP();
  auto r = runDslam("dataset info " + eu);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "dslam::EurocDataset")) << r.out;
  EXPECT_TRUE(has(r.out, "frames:       40")) << r.out;
  EXPECT_TRUE(has(r.out, "rate:         20.00 Hz")) << r.out;
  EXPECT_TRUE(has(r.out, "unrectified")) << r.out;
  EXPECT_TRUE(has(r.out, "ground truth: 41 poses")) << r.out;
  EXPECT_TRUE(has(r.out, "body frame")) << r.out;

  r = runDslam("dataset info " + rl);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "dslam::RawlogDataset")) << r.out;
  EXPECT_TRUE(has(r.out, "frames:       1")) << r.out;
  EXPECT_TRUE(has(r.out, "label 'OPENNI2': mrpt::obs::CObservation3DRangeScan x1")) << r.out;
  EXPECT_TRUE(has(r.out, "image:        640x480 8-bit colour")) << r.out;
  EXPECT_TRUE(has(r.out, "depth factor: 1000")) << r.out;

  r = runDslam("dataset info " + rl + " -p register_depth=false");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "273225 valid pixels")) << r.out;
}

TEST(DatasetsCli, InfoErrors) {
  auto r = runDslam("dataset info /nonexistent/dataset");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "error: dataset not found: /nonexistent/dataset")) << r.out;
  const std::string d = tempDir("cli_unknown");
  r = runDslam("dataset info " + d);
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "--type")) << r.out;
  r = runDslam("dataset info " + d + " --type dslam::TumDataset");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_TRUE(has(r.out, d + "/rgb.txt")) << r.out;
  // --check reports bad frames and exits 1.
  TinyTum t;
  writeFile(t.dir + "/rgb/1.033000.png", "garbage");
  r = runDslam("dataset info " + t.dir + " --check");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "frame 1: cannot read image")) << r.out;
  EXPECT_TRUE(has(r.out, "3 of 4 frames read (1 bad)")) << r.out;
}

TEST(DatasetsCli, ConvertRoundTrip) {
  TinyTum t;
  const std::string dir = tempDir("cli_convert");
  auto r = runDslam("convert tum2rawlog " + t.dir + " " + dir + "/a.rawlog --preset tum_fr1 --label KINECT");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "4 CObservation3DRangeScan, sensor 'KINECT', depth factor 5000")) << r.out;
  r = runDslam("convert rawlog2tum " + dir + "/a.rawlog " + dir + "/tum");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "4 frames, depth factor 5000 (raw depth copied bit-exactly)")) << r.out;
  r = runDslam("dataset info " + dir + "/tum");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "frames:       4")) << r.out;
  EXPECT_TRUE(has(r.out, "fx=517.306408")) << r.out;  // tum_fr1 intrinsics carried through camera.yaml
  r = runDslam("convert rawlog2tum " + dir + "/a.rawlog " + dir + "/tum");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "--overwrite")) << r.out;
  r = runDslam("convert tum2rawlog /nonexistent/x " + dir + "/b.rawlog");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "/nonexistent/x")) << r.out;
}
