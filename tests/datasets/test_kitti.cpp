// KITTI odometry reader on shared/data/kitti-stereo-51 and synthetic folders.
#include <cmath>
#include <fstream>

#include "dslam/plugins/datasets/kitti.h"
#include "dslam/trajectory/io.h"
#include "ds_test_util.h"

namespace fs = std::filesystem;
using namespace dslam;
using namespace dslam::test;

TEST(KittiDataset, SharedSequence51) {
  const std::string dir = shared("data/kitti-stereo-51");
  if (dir.empty()) GTEST_SKIP();
  auto ds = openDataset("dslam::KittiDataset", "path: " + yq(dir) + "\n");
  ASSERT_EQ(ds->size(), 51u);
  EXPECT_EQ(ds->sensor(), SensorType::Stereo);
  // No times.txt: 10 Hz.
  EXPECT_DOUBLE_EQ(ds->timestamp(0), 0.0);
  EXPECT_DOUBLE_EQ(ds->timestamp(1), 0.1);
  EXPECT_DOUBLE_EQ(ds->timestamp(50), 5.0);
  for (size_t i = 1; i < ds->size(); i++) ASSERT_GT(ds->timestamp(i), ds->timestamp(i - 1));

  auto cam = ds->camera();
  ASSERT_TRUE(cam);
  EXPECT_EQ(cam->sensor, SensorType::Stereo);
  EXPECT_TRUE(cam->rectified);
  EXPECT_DOUBLE_EQ(cam->left.fx, 718.856);
  EXPECT_DOUBLE_EQ(cam->left.fy, 718.856);
  EXPECT_DOUBLE_EQ(cam->left.cx, 607.1928);
  EXPECT_DOUBLE_EQ(cam->left.cy, 185.2157);
  EXPECT_NEAR(cam->bf(), 386.1448, 1e-9);
  EXPECT_NEAR(cam->baseline, 386.1448 / 718.856, 1e-12);
  EXPECT_NEAR(cam->T_left_right.translation().x(), cam->baseline, 1e-12);
  EXPECT_EQ(cam->left.width, 1241);
  EXPECT_EQ(cam->left.height, 376);
  EXPECT_NEAR(cam->fps, 10.0, 1e-9);

  const SensorFrame f = ds->read(10);
  EXPECT_EQ(f.image.type(), CV_8UC1);
  EXPECT_EQ(f.image.size(), cv::Size(1241, 376));
  EXPECT_EQ(f.image_right.size(), cv::Size(1241, 376));
  EXPECT_EQ(fs::path(f.image_path).filename().string(), "000010.png");
  EXPECT_NE(f.image_right_path.find("image_r"), std::string::npos);
  EXPECT_GT(cv::norm(f.image, f.image_right, cv::NORM_L1), 0.0);  // two different views

  // Ground truth: 51 poses, frame 0 = identity, ~1 m per frame.
  const auto& gt = ds->groundTruth();
  ASSERT_EQ(gt.size(), 51u);
  EXPECT_LT(gt.poses[0].translation().norm(), 1e-9);
  EXPECT_LT(gt.poses[0].angle(), 1e-6);
  EXPECT_NEAR(gt.pathLength(), 51.8, 1.0);
  EXPECT_DOUBLE_EQ(gt.stamps[50], 5.0);
  ASSERT_TRUE(f.gt_T_wc);
  EXPECT_LT((f.gt_T_wc->translation() - gt.poses[10].translation()).norm(), 1e-12);
  // Same numbers as the trajectory reader on poses.txt.
  const Trajectory raw = traj::readKitti(dir + "/poses.txt");
  EXPECT_LT((raw.poses[50].translation() - gt.poses[50].translation()).norm(), 1e-12);

  // Monocular mode.
  auto mono = openDataset("dslam::KittiDataset", "path: " + yq(dir) + "\nstereo: false\n");
  EXPECT_EQ(mono->sensor(), SensorType::Monocular);
  EXPECT_TRUE(mono->read(0).image_right.empty());
}

namespace {
struct TinyKitti {
  std::string dir;
  TinyKitti() {
    dir = tempDir("kitti") + "/00";
    mkdirs(dir + "/image_0");
    mkdirs(dir + "/image_1");
    for (int i = 0; i < 4; i++) {
      char n[32];
      std::snprintf(n, sizeof n, "%06d.png", i);
      writeImage(dir + "/image_0/" + n, cv::Mat(20, 30, CV_8UC1, cv::Scalar(i)));
      writeImage(dir + "/image_1/" + n, cv::Mat(20, 30, CV_8UC1, cv::Scalar(100 + i)));
    }
    // Official layout: labelled lines, 4 cameras + Tr.
    writeFile(dir + "/calib.txt",
              "P0: 500 0 15 0 0 501 10 0 0 0 1 0\n"
              "P1: 500 0 15 -250 0 501 10 0 0 0 1 0\n"
              "P2: 500 0 15 44 0 501 10 0.2 0 0 1 0.003\n"
              "P3: 500 0 15 -300 0 501 10 0.1 0 0 1 0.003\n"
              "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n");
    writeFile(dir + "/times.txt", "0.000000e+00\n1.036e-01\n2.073e-01\n3.109e-01\n");
  }
  std::shared_ptr<DatasetSource> open(const std::string& extra = "") const {
    return openDataset("dslam::KittiDataset", "path: " + yq(dir) + "\n" + extra);
  }
};
}  // namespace

TEST(KittiDataset, LabelledCalibAndTimes) {
  TinyKitti k;
  auto ds = k.open();
  ASSERT_EQ(ds->size(), 4u);
  EXPECT_DOUBLE_EQ(ds->timestamp(1), 0.1036);
  EXPECT_DOUBLE_EQ(ds->timestamp(3), 0.3109);
  EXPECT_DOUBLE_EQ(ds->camera()->left.fx, 500);
  EXPECT_DOUBLE_EQ(ds->camera()->left.fy, 501);
  EXPECT_DOUBLE_EQ(ds->camera()->baseline, 0.5);
  EXPECT_EQ(ds->camera()->left.width, 30);
  EXPECT_TRUE(ds->groundTruth().empty());
  const auto f = ds->read(2);
  EXPECT_EQ(f.image.at<uint8_t>(0, 0), 2);
  EXPECT_EQ(f.image_right.at<uint8_t>(0, 0), 102);
  EXPECT_FALSE(f.gt_T_wc);

  const auto c = readKittiCalib(k.dir + "/calib.txt");
  ASSERT_EQ(c.matrices.size(), 5u);
  ASSERT_NE(c.find("P3"), nullptr);
  EXPECT_DOUBLE_EQ((*c.find("P3"))[3], -300);
  EXPECT_EQ(c.find("P4"), nullptr);
}

TEST(KittiDataset, ColourPairUsesP2P3) {
  TinyKitti k;
  fs::rename(k.dir + "/image_0", k.dir + "/image_2");
  fs::rename(k.dir + "/image_1", k.dir + "/image_3");
  auto ds = k.open();
  EXPECT_DOUBLE_EQ(ds->camera()->baseline, (44.0 + 300.0) / 500.0);
}

TEST(KittiDataset, PosesGiveGroundTruth) {
  TinyKitti k;
  writeFile(k.dir + "/poses.txt",
            "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 1\n1 0 0 0 0 1 0 0 0 0 1 2\n1 0 0 0 0 1 0 0 0 0 1 3\n");
  auto ds = k.open();
  ASSERT_EQ(ds->groundTruth().size(), 4u);
  EXPECT_DOUBLE_EQ(ds->groundTruth().stamps[2], 0.2073);  // frame times
  EXPECT_NEAR(ds->read(3).gt_T_wc->translation().z(), 3.0, 1e-12);
}

TEST(KittiDataset, BadInputs) {
  std::string e = dataError([] { openDataset("dslam::KittiDataset", "path: /nonexistent/kitti\n"); });
  EXPECT_NE(e.find("/nonexistent/kitti"), std::string::npos) << e;
  EXPECT_NE(e.find("calib.txt"), std::string::npos) << e;  // layout described
  {
    TinyKitti k;
    fs::remove(k.dir + "/calib.txt");
    e = dataError([&] { k.open(); });
    EXPECT_NE(e.find(k.dir + "/calib.txt"), std::string::npos) << e;
  }
  {
    TinyKitti k;
    expectOpenError(k.dir + "/calib.txt", "P0: 500 0 15 0 0 501 10 0 0 0 1\n", [&] { k.open(); },
                    {"calib.txt:1", "11 numbers"});
    // cx = 150 in 30x20 images: a typo, not a calibration.
    expectOpenError(k.dir + "/calib.txt",
                    "P0: 500 0 150 0 0 501 10 0 0 0 1 0\nP1: 500 0 150 -250 0 501 10 0 0 0 1 0\n", [&] { k.open(); },
                    {"calib.txt: matrix P0 puts the principal point (150, 10) outside the 30x20 images"});
  }
  {
    TinyKitti k;
    expectOpenError(k.dir + "/times.txt", "0\n0.1\n0.05\n0.3\n", [&] { k.open(); }, {"times.txt", "must increase"});
    expectOpenError(k.dir + "/times.txt", "0\n0.1\n", [&] { k.open(); }, {"2 times"});
  }
  {
    TinyKitti k;
    auto ds = k.open();
    fs::remove(k.dir + "/image_1/000002.png");
    e = dataError([&] { ds->read(2); });
    EXPECT_NE(e.find("frame 2"), std::string::npos) << e;
    EXPECT_NE(e.find("image_1/000002.png"), std::string::npos) << e;
    writeFile(k.dir + "/image_0/000001.png", std::string(100, '\x42'));
    e = dataError([&] { ds->read(1); });
    EXPECT_NE(e.find("frame 1"), std::string::npos) << e;
    EXPECT_NE(e.find("image_0/000001.png"), std::string::npos) << e;
    EXPECT_NE(e.find("corrupt"), std::string::npos) << e;
  }
  {
    TinyKitti k;
    fs::remove_all(k.dir + "/image_1");
    e = dataError([&] { k.open(); });
    EXPECT_NE(e.find("image_1"), std::string::npos) << e;
    EXPECT_EQ(k.open("stereo: false\n")->size(), 4u);
  }
}
