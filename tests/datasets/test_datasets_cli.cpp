// `dslam plugins`, `dslam dataset info` and `dslam convert` from the command line.
#include <cstdlib>

#include "ds_test_util.h"

namespace fs = std::filesystem;
using namespace dslam::test;

namespace {
bool has(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

/** Every line of `want` appears in the command's output. */
void expectAll(const CmdResult& r, std::initializer_list<const char*> want) {
  for (const char* w : want) EXPECT_TRUE(has(r.out, w)) << w << "\n" << r.out;
}

/** Runs `dslam args`: the exit code is `code` and every text of `want` is in the output. */
void expectRun(const std::string& args, int code, std::initializer_list<const char*> want) {
  const auto r = runDslam(args);
  EXPECT_EQ(r.exit_code, code) << args << "\n" << r.out;
  expectAll(r, want);
}
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
  expectAll(
      r, {"type:         dslam::KittiDataset", "frames:       51", "last stamp:   5.000000", "rate:         10.00 Hz",
          "image:        1241x376 8-bit grey", "fx=718.856 fy=718.856 cx=607.1928 cy=185.2157", "bf=386.1448",
          "ground truth: 51 poses", "51 of 51 frames read"});
}

TEST(DatasetsCli, InfoEurocAndRawlog) {
  const std::string eu = shared("data/euroc-v101-micro");
  const std::string rl = shared("data/mrpt/tests_rgbd.rawlog");
  if (eu.empty() || rl.empty()) GTEST_SKIP();
  auto r = runDslam("dataset info " + eu);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  expectAll(r, {"dslam::EurocDataset", "frames:       40", "rate:         20.00 Hz", "unrectified",
                "ground truth: 41 poses", "body frame"});

  r = runDslam("dataset info " + rl);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  expectAll(r, {"dslam::RawlogDataset", "frames:       1", "label 'OPENNI2': mrpt::obs::CObservation3DRangeScan x1",
                "image:        640x480 8-bit colour", "depth factor: 1000"});

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
  expectAll(r, {"frame 1: cannot read image", "3 of 4 frames read (1 bad)"});
}

TEST(DatasetsCli, ConvertRoundTrip) {
  TinyTum t("rgbd_dataset_freiburg2_tiny", {640, 480});
  const std::string dir = tempDir("cli_convert");
  expectRun("convert tum2rawlog " + t.dir + " " + dir + "/a.rawlog --preset tum_fr1 --label KINECT", 0,
            {"4 CObservation3DRangeScan, sensor 'KINECT', depth factor 5000"});
  expectRun("convert rawlog2tum " + dir + "/a.rawlog " + dir + "/tum", 0,
            {"4 frames, depth factor 5000 (raw depth copied bit-exactly)"});
  // tum_fr1 intrinsics carried through camera.yaml
  expectRun("dataset info " + dir + "/tum", 0, {"frames:       4", "fx=517.306408"});
  expectRun("convert rawlog2tum " + dir + "/a.rawlog " + dir + "/tum", 1, {"--overwrite"});
  expectRun("convert tum2rawlog /nonexistent/x " + dir + "/b.rawlog", 1, {"/nonexistent/x"});
}
