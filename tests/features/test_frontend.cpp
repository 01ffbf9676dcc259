// FeatureFrontend: grey conversion, undistortion, RGB-D depth / virtual
// right coordinate, monocular frames, feature count, errors, parameters.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/core/camera_presets.h"
#include "dslam/core/error.h"
#include "dslam/features/frontend.h"
#include "synth_images.h"

using namespace dslam;

namespace {

CameraModel tumFr1() { return *cameraPreset("tum_fr1"); }

CameraModel monoFr1() {
  CameraModel cam = tumFr1();
  cam.sensor = SensorType::Monocular;
  return cam;
}

/** A 640x480 textured monocular frame. */
SensorFrame texturedFrame(int index) {
  SensorFrame in;
  in.index = index;
  in.image = test::texturedScene(cv::Size(640, 480), 23);
  return in;
}

/** Depth plane z = 1 + 0.002 u + 0.003 v with an invalid (0) box and a NaN box. */
cv::Mat planeDepth(cv::Size s) {
  cv::Mat d(s, CV_32FC1);
  for (int v = 0; v < s.height; v++)
    for (int u = 0; u < s.width; u++) d.at<float>(v, u) = 1.0f + 0.002f * u + 0.003f * v;
  d(cv::Rect(100, 100, 120, 100)).setTo(0.0f);
  d(cv::Rect(400, 300, 100, 100)).setTo(std::numeric_limits<float>::quiet_NaN());
  return d;
}

}  // namespace

TEST(Frontend, GreyConversionRespectsTheChannelOrder) {
  // Pure red as cv::imread loads it from a normal (RGB) file: BGR = (0, 0, 255).
  const cv::Mat bgr(4, 4, CV_8UC3, cv::Scalar(0, 0, 255));
  EXPECT_EQ(toGray(bgr, true).at<uint8_t>(0, 0), 76);   // 0.299 * 255
  EXPECT_EQ(toGray(bgr, false).at<uint8_t>(0, 0), 29);  // read as RGB: blue, 0.114 * 255
  const cv::Mat bgra(4, 4, CV_8UC4, cv::Scalar(0, 0, 255, 255));
  EXPECT_EQ(toGray(bgra, true).at<uint8_t>(0, 0), 76);
  const cv::Mat g(4, 4, CV_8UC1, cv::Scalar(9));
  EXPECT_EQ(toGray(g, true).data, g.data);  // no copy
  EXPECT_THROW(toGray(cv::Mat(4, 4, CV_16UC1), true), DataError);
  EXPECT_THROW(toGray(cv::Mat(), true), DataError);
}

TEST(Frontend, UndistortsKeypointsWithTheCameraModel) {
  const CameraModel cam = tumFr1();
  std::vector<cv::KeyPoint> kps;
  for (int i = 0; i < 50; i++) kps.emplace_back(cv::Point2f(10.f + 12.f * i, 5.f + 9.5f * i), 31.f, 45.f, 10.f, i % 8);
  std::vector<cv::KeyPoint> un;
  undistortKeypoints(cam.left, kps, un);
  ASSERT_EQ(un.size(), kps.size());
  const cv::Matx33d K(cam.left.fx, 0, cam.left.cx, 0, cam.left.fy, cam.left.cy, 0, 0, 1);
  std::vector<cv::Point2f> pts, ref;
  for (const auto& k : kps) pts.push_back(k.pt);
  cv::undistortPoints(pts, ref, K, std::vector<double>(cam.left.dist.begin(), cam.left.dist.end()), cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 50, 0));
  double max_shift = 0;
  for (size_t i = 0; i < kps.size(); i++) {
    EXPECT_NEAR(un[i].pt.x, ref[i].x, 0.02);
    EXPECT_NEAR(un[i].pt.y, ref[i].y, 0.02);
    EXPECT_EQ(un[i].octave, kps[i].octave);
    EXPECT_EQ(un[i].angle, kps[i].angle);
    max_shift = std::max(max_shift, cv::norm(un[i].pt - kps[i].pt));
  }
  EXPECT_GT(max_shift, 5.0);  // the TUM fr1 distortion is strong near the corner
}

TEST(Frontend, RgbdDepthAndVirtualRightCoordinate) {
  const CameraModel cam = tumFr1();
  const cv::Mat depth = planeDepth(cv::Size(640, 480));
  std::vector<cv::KeyPoint> kps{cv::KeyPoint(50.7f, 60.2f, 31), cv::KeyPoint(150.f, 150.f, 31),
                                cv::KeyPoint(450.5f, 350.5f, 31), cv::KeyPoint(639.9f, 479.9f, 31),
                                cv::KeyPoint(320.f, 20.9f, 31)};
  std::vector<cv::KeyPoint> un;
  undistortKeypoints(cam.left, kps, un);
  std::vector<float> d, ur;
  computeRgbdDepth(kps, un, depth, cam.bf(), d, ur);
  ASSERT_EQ(d.size(), kps.size());
  // Depth at the nearest pixel of the distorted keypoint (clamped to the last
  // row/column); u_right from the undistorted x.
  const int expect_uv[5][2] = {{51, 60}, {0, 0}, {0, 0}, {639, 479}, {320, 21}};
  for (size_t i : {0u, 3u, 4u}) {
    const int u = expect_uv[i][0], v = expect_uv[i][1];
    const float z = 1.0f + 0.002f * u + 0.003f * v;
    EXPECT_FLOAT_EQ(d[i], z) << i;
    EXPECT_NEAR(ur[i], un[i].pt.x - 40.0 / z, 1e-4) << i;  // bf = 40 for TUM
  }
  EXPECT_EQ(d[1], -1.0f);  // zero depth
  EXPECT_EQ(ur[1], -1.0f);
  EXPECT_EQ(d[2], -1.0f);  // NaN depth
  EXPECT_EQ(ur[2], -1.0f);

  // Raw 16-bit depth (TUM: 5000 units per metre).
  cv::Mat raw;
  depth.convertTo(raw, CV_16U, 5000.0);
  computeRgbdDepth(kps, un, raw, cam.bf(), d, ur, 5000.0);
  EXPECT_NEAR(d[0], 1.0f + 0.002f * 51 + 0.003f * 60, 2e-4);
  EXPECT_EQ(d[1], -1.0f);
  EXPECT_THROW(computeRgbdDepth(kps, un, cv::Mat(480, 640, CV_8UC1), cam.bf(), d, ur), DataError);
}

TEST(Frontend, RgbdFrame) {
  const CameraModel cam = tumFr1();
  FeatureFrontend fe(cam);
  SensorFrame in;
  in.index = 7;
  cv::Mat gray = test::texturedScene(cv::Size(640, 480), 17);
  cv::cvtColor(gray, in.image, cv::COLOR_GRAY2BGR);
  in.depth = planeDepth(gray.size());
  const Frame f = fe.process(in);
  EXPECT_EQ(f.index(), 7);
  EXPECT_EQ(f.requested_features, 1000);
  EXPECT_EQ(f.gray.type(), CV_8UC1);
  EXPECT_GE(f.size(), 950u);
  ASSERT_EQ(f.keypoints_un.size(), f.size());
  ASSERT_EQ(f.depth.size(), f.size());
  ASSERT_EQ(f.u_right.size(), f.size());
  ASSERT_EQ(f.meta.size(), f.size());
  ASSERT_EQ(f.descriptors.rows, static_cast<int>(f.size()));
  int valid = 0;
  for (size_t i = 0; i < f.size(); i++) {
    const int u = std::min(cvRound(f.keypoints[i].pt.x), 639), v = std::min(cvRound(f.keypoints[i].pt.y), 479);
    const float z = in.depth.at<float>(v, u);
    if (z > 0) {
      valid++;
      EXPECT_FLOAT_EQ(f.depth[i], z);
      EXPECT_NEAR(f.u_right[i], f.keypoints_un[i].pt.x - cam.bf() / z, 1e-3);
    } else {
      EXPECT_EQ(f.depth[i], -1.0f);
      EXPECT_EQ(f.u_right[i], -1.0f);
    }
    EXPECT_EQ(f.meta[i].label, KpLabel::Static);
  }
  EXPECT_GT(valid, 800);

  // Missing depth: keypoints kept with unknown depth (tracking goes on
  // monocularly); mismatched depth -> DataError naming the frame.
  SensorFrame bad = in;
  bad.depth = cv::Mat();
  const Frame nodepth = fe.process(bad);
  EXPECT_EQ(nodepth.keypoints.size(), f.keypoints.size());
  for (size_t i = 0; i < nodepth.size(); i++) {
    EXPECT_LT(nodepth.depth[i], 0);
    EXPECT_LT(nodepth.u_right[i], 0);
  }
  bad.depth = cv::Mat(240, 320, CV_32FC1, cv::Scalar(1));
  try {
    fe.process(bad);
    FAIL() << "no error";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 7"), std::string::npos) << e.what();
  }
  bad = in;
  bad.image = cv::Mat(480, 752, CV_8UC3, cv::Scalar::all(0));
  EXPECT_THROW(fe.process(bad), DataError);
}

TEST(Frontend, MonocularFrameFeatureCountAndMask) {
  const CameraModel cam = monoFr1();
  FeatureFrontend fe(cam);
  const SensorFrame in = texturedFrame(0);
  fe.setFeatureCount(600);
  EXPECT_EQ(fe.featureCount(), 600);
  cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(0, 0, 640, 240)).setTo(0);
  const Frame f = fe.process(in, mask);
  EXPECT_EQ(f.requested_features, 600);
  EXPECT_LE(f.size(), 600u);
  EXPECT_GE(f.size(), 400u);
  for (size_t i = 0; i < f.size(); i++) {
    EXPECT_EQ(f.depth[i], -1.0f);
    EXPECT_EQ(f.u_right[i], -1.0f);
    EXPECT_GE(f.keypoints[i].pt.y, 239.5f);
  }
  // Undistorted with the fr1 model.
  std::vector<cv::KeyPoint> un;
  undistortKeypoints(cam.left, f.keypoints, un);
  for (size_t i = 0; i < f.size(); i++) EXPECT_EQ(un[i].pt, f.keypoints_un[i].pt);
  EXPECT_TRUE(fe.imageBounds().valid());
  EXPECT_NE(fe.imageBounds().min_x, 0.0f);  // distorted camera
}

// on_gray gets the frame's grey image once, before feature extraction (the
// asynchronous detection carry starts from it on another thread).
TEST(Frontend, GreyImageCallbackComesBeforeTheKeypoints) {
  const CameraModel cam = monoFr1();
  FeatureFrontend fe(cam);
  const SensorFrame in = texturedFrame(3);
  int calls = 0;
  cv::Mat seen;
  const Frame f = fe.process(in, cv::Mat(), [&](const cv::Mat& g) {
    calls++;
    seen = g;
    EXPECT_EQ(fe.lastTimings().extract_ms, 0.0);  // not extracted yet
  });
  EXPECT_EQ(calls, 1);
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.data, f.gray.data);
  EXPECT_EQ(cv::norm(seen, toGray(in.image, cam.rgb_order), cv::NORM_INF), 0.0);
  EXPECT_GT(f.size(), 100u);
}

TEST(Frontend, SyntheticRectifiedStereoFrame) {
  CameraModel cam = *cameraPreset("kitti_00_02");
  cam.left.width = cam.right.width = 640;
  cam.left.height = cam.right.height = 480;
  cam.left.cx = cam.right.cx = 320;
  cam.left.cy = cam.right.cy = 240;
  // right(x) = left(x + 16): a plane at bf / 16 m.
  const cv::Mat tex = test::texturedScene(cv::Size(656, 480), 31, cv::Rect(0, 0, 0, 0));
  SensorFrame in;
  in.index = 3;
  in.image = tex(cv::Rect(0, 0, 640, 480)).clone();
  in.image_right = tex(cv::Rect(16, 0, 640, 480)).clone();
  for (bool parallel : {false, true}) {
    FrontendParams p;
    p.parallel_stereo = parallel;
    FeatureFrontend fe(cam, p);
    EXPECT_EQ(fe.rectification(), nullptr);
    const Frame f = fe.process(in);
    ASSERT_EQ(f.depth.size(), f.size());
    int n = 0, close = 0;
    for (size_t i = 0; i < f.size(); i++) {
      if (f.depth[i] <= 0) continue;
      n++;
      const double disp = f.keypoints[i].pt.x - f.u_right[i];
      close += std::abs(disp - 16.0) < 0.25;
      EXPECT_NEAR(f.depth[i], cam.bf() / disp, 1e-3 * f.depth[i]);
    }
    EXPECT_GT(n, 500) << "parallel=" << parallel;
    EXPECT_GE(close, 0.95 * n) << "parallel=" << parallel;
    EXPECT_EQ(n, fe.lastStereoStats().matched);
    EXPECT_FALSE(f.gray_right.empty());
  }
  SensorFrame bad = in;
  bad.image_right = cv::Mat();
  FeatureFrontend fe(cam);
  EXPECT_THROW(fe.process(bad), DataError);
}

TEST(Frontend, ParametersFromYaml) {
  const Params p = Params::resolve(FrontendParams::specs(), "n_features: 1500\nini_th_fast: 25\nparallel_stereo: false\n");
  const FrontendParams f = FrontendParams::fromParams(p);
  EXPECT_EQ(f.orb.n_features, 1500);
  EXPECT_EQ(f.orb.ini_th_fast, 25);
  EXPECT_EQ(f.orb.min_th_fast, 7);
  EXPECT_FLOAT_EQ(f.orb.scale_factor, 1.2f);
  EXPECT_FALSE(f.parallel_stereo);
  EXPECT_EQ(f.stereo.th_high, 100);
  EXPECT_EQ(f.stereo.subpixel, StereoSubpixel::Equiangular);
  const FrontendParams o = FrontendParams::fromParams(
      Params::resolve(FrontendParams::specs(), "stereo_subpixel: parabola\nstereo_offset: center\n"));
  EXPECT_EQ(o.stereo.subpixel, StereoSubpixel::Parabola);
  EXPECT_EQ(o.stereo.offset, StereoOffset::Center);
  EXPECT_THROW(Params::resolve(FrontendParams::specs(), "stereo_subpixel: cubic\n"), ConfigError);
  EXPECT_THROW(FrontendParams::fromParams(Params::resolve(FrontendParams::specs(), "min_th_fast: 30\n")),
               ConfigError);
  EXPECT_THROW(Params::resolve(FrontendParams::specs(), "n_feature: 10\n"), ConfigError);
}

TEST(Frontend, RejectsInvalidCameras) {
  CameraModel c = tumFr1();
  c.left.fx = 0;
  EXPECT_THROW(FeatureFrontend{c}, ConfigError);
  c = tumFr1();
  c.baseline = 0;
  EXPECT_THROW(FeatureFrontend{c}, ConfigError);
  c = *cameraPreset("kitti_00_02");
  c.baseline = 0;
  EXPECT_THROW(FeatureFrontend{c}, ConfigError);
}
