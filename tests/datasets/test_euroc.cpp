// EuRoC MAV reader on shared/data/euroc-v101-micro and synthetic folders.
#include <cmath>
#include <fstream>

#include "dslam/plugins/datasets/euroc.h"
#include "ds_test_util.h"

namespace fs = std::filesystem;
using namespace dslam;
using namespace dslam::test;

TEST(EurocDataset, SharedV101Micro) {
  const std::string dir = shared("data/euroc-v101-micro");
  if (dir.empty()) GTEST_SKIP();
  auto ds = openDataset("dslam::EurocDataset", "path: " + yq(dir) + "\n");
  auto* eu = dynamic_cast<EurocDataset*>(ds.get());
  ASSERT_NE(eu, nullptr);
  ASSERT_EQ(ds->size(), 40u);
  EXPECT_EQ(ds->sensor(), SensorType::Stereo);
  EXPECT_EQ(eu->timestampNs(0), 1403715273262142976LL);
  EXPECT_EQ(eu->timestampNs(39), 1403715275212143104LL);
  EXPECT_NEAR(ds->timestamp(0), 1403715273.262143, 1e-6);
  EXPECT_NEAR(ds->timestamp(39) - ds->timestamp(0), 1.95, 1e-6);  // 20 Hz
  for (size_t i = 1; i < ds->size(); i++) ASSERT_NEAR(ds->timestamp(i) - ds->timestamp(i - 1), 0.05, 1e-6);

  auto cam = ds->camera();
  ASSERT_TRUE(cam);
  EXPECT_EQ(cam->sensor, SensorType::Stereo);
  EXPECT_FALSE(cam->rectified);
  EXPECT_EQ(cam->left.width, 752);
  EXPECT_EQ(cam->left.height, 480);
  EXPECT_DOUBLE_EQ(cam->left.fx, 458.654);
  EXPECT_DOUBLE_EQ(cam->left.fy, 457.296);
  EXPECT_DOUBLE_EQ(cam->left.cx, 367.215);
  EXPECT_DOUBLE_EQ(cam->left.cy, 248.375);
  EXPECT_DOUBLE_EQ(cam->left.dist[0], -0.28340811);
  EXPECT_DOUBLE_EQ(cam->left.dist[3], 1.76187114e-05);
  EXPECT_DOUBLE_EQ(cam->left.dist[4], 0.0);
  EXPECT_DOUBLE_EQ(cam->right.fx, 457.587);
  EXPECT_DOUBLE_EQ(cam->right.cx, 379.999);
  EXPECT_DOUBLE_EQ(cam->right.dist[0], -0.28368365);
  // T_left_right = T_BS0^-1 T_BS1: the right camera ~11 cm along +x.
  const auto t = cam->T_left_right.translation();
  EXPECT_NEAR(t.x(), 0.1101, 3e-4);
  EXPECT_LT(std::abs(t.y()), 2e-3);
  EXPECT_LT(std::abs(t.z()), 2e-3);
  EXPECT_NEAR(cam->baseline, 0.1101, 3e-4);
  EXPECT_NEAR(cam->T_left_right.angle(), 0.01428, 2e-4);  // the two cameras are 0.82 deg apart
  EXPECT_NEAR(cam->T_body_cam.translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(cam->T_body_cam.translation().y(), -0.064676986768, 1e-12);
  EXPECT_DOUBLE_EQ(cam->fps, 20.0);

  const SensorFrame f = ds->read(5);
  EXPECT_EQ(f.image.type(), CV_8UC1);
  EXPECT_EQ(f.image.size(), cv::Size(752, 480));
  EXPECT_EQ(f.image_right.size(), cv::Size(752, 480));
  EXPECT_NE(f.image_path.find("cam0/data/"), std::string::npos);
  EXPECT_NE(f.image_right_path.find("cam1/data/"), std::string::npos);

  // Ground truth: groundtruth.txt (TUM, body frame), 41 poses over 2.0 s,
  // converted to left-camera poses T_wc = T_wb * T_BS.
  EXPECT_NE(eu->groundTruthFile().find("groundtruth.txt"), std::string::npos);
  const auto& gt = ds->groundTruth();
  const auto& gb = eu->groundTruthBody();
  ASSERT_EQ(gt.size(), 41u);
  ASSERT_EQ(gb.size(), 41u);
  EXPECT_NEAR(gt.stamps.back() - gt.stamps.front(), 2.0, 1e-6);
  for (size_t k = 0; k < gt.size(); k++) {
    const SE3 expect = gb.poses[k] * cam->T_body_cam;
    ASSERT_LT((gt.poses[k].translation() - expect.translation()).norm(), 1e-12);
    ASSERT_NEAR((gt.poses[k].translation() - gb.poses[k].translation()).norm(),
                cam->T_body_cam.translation().norm(), 1e-9);
  }
  EXPECT_NEAR(gb.poses[0].translation().x(), 0.878895, 1e-9);
  // The drone sits on the ground: the camera moves less than 5 mm.
  double maxd = 0;
  for (const auto& p : gt.poses) maxd = std::max(maxd, (p.translation() - gt.poses[0].translation()).norm());
  EXPECT_LT(maxd, 0.005);
  // Every frame has a pose within 20 ms.
  for (size_t i = 0; i < ds->size(); i += 13) EXPECT_TRUE(ds->read(i).gt_T_wc) << i;

  auto mono = openDataset("dslam::EurocDataset", "path: " + yq(dir) + "\nstereo: false\ngroundtruth: ''\n");
  EXPECT_EQ(mono->sensor(), SensorType::Monocular);
  EXPECT_EQ(mono->size(), 40u);
  EXPECT_TRUE(mono->groundTruth().empty());
  EXPECT_TRUE(mono->read(0).image_right.empty());
}

namespace {

std::string sensorYaml(const std::string& T, const std::string& model = "radial-tangential") {
  return "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [" + T +
         "]\nrate_hz: 20\nresolution: [16, 12]\ncamera_model: pinhole\nintrinsics: [100, 101, 8, 6] #fu, fv, cu, "
         "cv\ndistortion_model: " +
         model + "\ndistortion_coefficients: [0.1, -0.01, 0.001, 0.002]\n";
}

/** 5 left frames, cam1 lacks the 4th; body ground truth in EuRoC CSV. */
struct TinyEuroc {
  std::string dir;
  TinyEuroc() {
    dir = tempDir("euroc") + "/V0";
    for (int c = 0; c < 2; c++) {
      const std::string cd = dir + "/mav0/cam" + std::to_string(c);
      mkdirs(cd + "/data");
      std::ofstream csv(cd + "/data.csv");
      csv << "#timestamp [ns],filename\r\n";
      for (int i = 0; i < 5; i++) {
        if (c == 1 && i == 3) continue;
        const std::string ns = std::to_string(1000000000000LL + i * 50000000LL);
        writeImage(cd + "/data/" + ns + ".png", cv::Mat(12, 16, CV_8UC1, cv::Scalar(10 * i + c)));
        csv << ns << "," << ns << ".png\r\n";
      }
    }
    // cam0: rotated 90 deg about z and shifted; cam1: 0.1 m to the right of cam0.
    writeFile(dir + "/mav0/cam0/sensor.yaml", sensorYaml("0, -1, 0, 0.5,  1, 0, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1"));
    writeFile(dir + "/mav0/cam1/sensor.yaml", sensorYaml("0, -1, 0, 0.5,  1, 0, 0, 0.1,  0, 0, 1, 0,  0, 0, 0, 1"));
    mkdirs(dir + "/mav0/state_groundtruth_estimate0");
    writeFile(dir + "/mav0/state_groundtruth_estimate0/data.csv",
              "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n"
              "1000000000000,1,2,3,1,0,0,0\n"
              "1000100000000,1,2,4,1,0,0,0\n");
  }
  std::shared_ptr<DatasetSource> open(const std::string& extra = "") const {
    return openDataset("dslam::EurocDataset", "path: " + yq(dir) + "\n" + extra);
  }
};

}  // namespace

TEST(EurocDataset, PairsByTimestampAndConvertsBodyGroundTruth) {
  TinyEuroc t;
  auto ds = t.open();
  ASSERT_EQ(ds->size(), 4u);  // left frame 3 has no right image
  EXPECT_NEAR(ds->timestamp(3), 1000.2, 1e-9);
  const auto f = ds->read(3);
  EXPECT_EQ(f.image.at<uint8_t>(0, 0), 40);
  EXPECT_EQ(f.image_right.at<uint8_t>(0, 0), 41);
  const auto cam = *ds->camera();
  EXPECT_NEAR(cam.T_left_right.translation().x(), 0.1, 1e-12);
  EXPECT_NEAR(cam.baseline, 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(cam.left.dist[3], 0.002);
  // Body at (1,2,3), identity rotation; camera at body + R_BS*0 + t_BS = (1.5, 2, 3),
  // rotated 90 deg about z.
  ASSERT_EQ(ds->groundTruth().size(), 2u);
  const SE3& T = ds->groundTruth().poses[0];
  EXPECT_NEAR((T.translation() - Eigen::Vector3d(1.5, 2, 3)).norm(), 0, 1e-12);
  EXPECT_NEAR(T.angle(), M_PI / 2, 1e-9);
  ASSERT_TRUE(ds->read(0).gt_T_wc);
  EXPECT_FALSE(ds->read(1).gt_T_wc);  // 50 ms from both poses
  auto cam_frame = t.open("groundtruth_frame: camera\n");
  EXPECT_NEAR((cam_frame->groundTruth().poses[0].translation() - Eigen::Vector3d(1, 2, 3)).norm(), 0, 1e-12);
}

TEST(EurocDataset, SensorYamlParser) {
  TinyEuroc t;
  const auto info = readEurocSensorYaml(t.dir + "/mav0/cam0/sensor.yaml");
  EXPECT_DOUBLE_EQ(info.cam.fx, 100);
  EXPECT_DOUBLE_EQ(info.cam.fy, 101);
  EXPECT_EQ(info.cam.width, 16);
  EXPECT_DOUBLE_EQ(info.rate_hz, 20);
  EXPECT_NEAR(info.T_BS.translation().x(), 0.5, 1e-12);
  const auto l = readEurocImageList(t.dir + "/mav0/cam1");
  ASSERT_EQ(l.size(), 4u);
  EXPECT_EQ(l[3].stamp_ns, 1000200000000LL);
  EXPECT_EQ(l[3].file, "1000200000000.png");
  // Without data.csv the PNG names are the stamps.
  fs::remove(t.dir + "/mav0/cam1/data.csv");
  EXPECT_EQ(readEurocImageList(t.dir + "/mav0/cam1").size(), 4u);
}

TEST(EurocDataset, BadInputs) {
  std::string e = dataError([] { openDataset("dslam::EurocDataset", "path: /nonexistent/euroc\n"); });
  EXPECT_NE(e.find("/nonexistent/euroc"), std::string::npos) << e;
  EXPECT_NE(e.find("sensor.yaml"), std::string::npos) << e;
  {
    TinyEuroc t;
    fs::remove_all(t.dir + "/mav0");
    e = dataError([&] { t.open(); });
    EXPECT_NE(e.find(t.dir + "/mav0"), std::string::npos) << e;
  }
  {
    TinyEuroc t;
    fs::remove(t.dir + "/mav0/cam1/sensor.yaml");
    e = dataError([&] { t.open(); });
    EXPECT_NE(e.find("cam1/sensor.yaml"), std::string::npos) << e;
    EXPECT_EQ(t.open("stereo: false\n")->size(), 5u);
  }
  {
    TinyEuroc t;
    expectOpenError(t.dir + "/mav0/cam0/sensor.yaml", sensorYaml("1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1", "equidistant"),
                    [&] { t.open(); }, {"equidistant"});
    expectOpenError(t.dir + "/mav0/cam0/sensor.yaml", sensorYaml("1,0,0,0, 0,1,0,0, 0,0,1"), [&] { t.open(); },
                    {"T_BS", "16 values"});
    std::string y = sensorYaml("1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1");
    y.replace(y.find("[100, 101, 8, 6]"), 16, "[100, 101, 8, 60]");  // cv = 60 in a 16x12 image
    expectOpenError(t.dir + "/mav0/cam0/sensor.yaml", y, [&] { t.open(); },
                    {"sensor.yaml: 'intrinsics' principal point (8, 60) lies outside the 16x12 image"});
  }
  {
    TinyEuroc t;
    expectOpenError(t.dir + "/mav0/cam0/data.csv", "#t,f\nabc,a.png\n", [&] { t.open(); }, {"cam0/data.csv:2"});
    expectOpenError(t.dir + "/mav0/cam0/data.csv", "#t,f\n1000050000000\n", [&] { t.open(); }, {"cam0/data.csv:2"});
  }
  {
    TinyEuroc t;
    auto ds = t.open();
    const std::string p = t.dir + "/mav0/cam1/data/1000100000000.png";
    writeFile(p, "garbage");
    e = dataError([&] { ds->read(2); });
    EXPECT_NE(e.find("frame 2"), std::string::npos) << e;
    EXPECT_NE(e.find(p), std::string::npos) << e;
    writeImage(t.dir + "/mav0/cam0/data/1000000000000.png", cv::Mat(10, 16, CV_8UC1, cv::Scalar(0)));
    e = dataError([&] { ds->read(0); });
    EXPECT_NE(e.find("16x10"), std::string::npos) << e;
    EXPECT_NE(e.find("16x12"), std::string::npos) << e;
  }
}

// data.csv with a repeated and an out-of-order line, as a hand-edited or
// merged file has them: sorted by time, the last line of a time kept.
TEST(EurocDataset, ImageListWithRepeatedAndUnorderedTimes) {
  TinyEuroc t;
  writeFile(t.dir + "/mav0/cam0/data.csv",
            "#timestamp [ns],filename\n"
            "1000100000000,1000100000000.png\n"
            "1000000000000,1000050000000.png\n"
            "1000050000000,1000050000000.png\n"
            "1000000000000,1000000000000.png\n");
  testing::internal::CaptureStderr();
  const auto l = readEurocImageList(t.dir + "/mav0/cam0");
  const std::string log = testing::internal::GetCapturedStderr();
  ASSERT_EQ(l.size(), 3u);
  EXPECT_EQ(l[0].stamp_ns, 1000000000000LL);
  EXPECT_EQ(l[0].file, "1000000000000.png");  // the later of the two lines
  EXPECT_EQ(l[1].stamp_ns, 1000050000000LL);
  EXPECT_EQ(l[2].stamp_ns, 1000100000000LL);
  EXPECT_NE(log.find("cam0/data.csv: 1 repeated timestamp(s)"), std::string::npos) << log;
  EXPECT_NE(log.find("3 out-of-order line(s)"), std::string::npos) << log;
  auto ds = t.open();
  EXPECT_EQ(ds->size(), 3u);
  EXPECT_EQ(ds->read(0).image.at<uint8_t>(0, 0), 0);
}
