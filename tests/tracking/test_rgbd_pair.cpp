// Real RGB-D sanity check: two real TUM freiburg2 frames. The tracker's
// relative pose must agree with an independent OpenCV PnP-RANSAC estimate
// computed on the same 3D-2D matches (<= 1 cm, <= 0.5 deg).
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dslam/core/registry.h"
#include "dslam/map/map.h"
#include "dslam/slam/system.h"
#include "plugin_util.h"
#include "test_support.h"

using namespace dslam;

namespace {
SensorFrame load(const std::string& dir, int i, double t, double factor) {
  SensorFrame f;
  f.index = i - 1;
  f.timestamp = t;
  f.image = cv::imread(dir + "/" + std::to_string(i) + ".png", cv::IMREAD_COLOR);
  cv::Mat d = cv::imread(dir + "/" + std::to_string(i) + "_depth.png", cv::IMREAD_ANYDEPTH);
  d.convertTo(f.depth, CV_32F, 1.0 / factor);
  return f;
}

}  // namespace

TEST(RgbdPair, TrackerAgreesWithPnpRansacOnTheSameMatches) {
  const std::string dir = test::shared("data/tum-frames/rgbd-pair");
  if (dir.empty()) return;
  CameraModel cam;
  cam.name = "slambook_fr2";
  cam.sensor = SensorType::RGBD;
  cam.left = {640, 480, 520.9, 521.0, 325.1, 249.7, {0, 0, 0, 0, 0}};
  cam.baseline = 40.0 / cam.left.fx;
  cam.depth_factor = 5000;
  SlamParams sp;
  sp.tracker.init_min_points = 300;
  System sys(cam, sp, test::defaultBackend());
  const auto r1 = sys.track(load(dir, 1, 0.0, 5000));
  ASSERT_TRUE(r1.track.initialized);
  const auto r2 = sys.track(load(dir, 2, 1.0 / 30, 5000));
  ASSERT_EQ(r2.track.state, TrackState::Ok);
  ASSERT_TRUE(r2.track.T_cw);
  const SE3 T_ours = *r2.track.T_cw;  // frame 1 is the world frame

  // The same matches: tracked frame 2's keypoints and their map points made
  // from frame 1 (not the points frame 2 itself created as a keyframe).
  const TrackedFrame& f2 = sys.tracker().lastFrame();
  const KeyFramePtr kf1 = sys.map()->origin();
  std::vector<cv::Point3f> X;
  std::vector<cv::Point2f> x;
  for (size_t i = 0; i < f2.size(); i++)
    if (f2.points[i] && !f2.outlier[i] && f2.points[i]->first_kf_id == kf1->id) {
      const auto& p = f2.points[i]->pos;
      X.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
      x.push_back(f2.f.keypoints_un[i].pt);
    }
  ASSERT_GE(X.size(), 100u) << "matches";
  const cv::Mat K = (cv::Mat_<double>(3, 3) << cam.left.fx, 0, cam.left.cx, 0, cam.left.fy, cam.left.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> inl;
  ASSERT_TRUE(cv::solvePnPRansac(X, x, K, cv::noArray(), rvec, tvec, false, 500, 2.0f, 0.999, inl, cv::SOLVEPNP_ITERATIVE));
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) Re(r, c) = R.at<double>(r, c);
  const SE3 T_pnp(Re, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  const double dt = (T_ours.inverse().translation() - T_pnp.inverse().translation()).norm();
  const double dr = (T_ours.inverse() * T_pnp).angle() * 180.0 / M_PI;
  RecordProperty("matches", static_cast<int>(X.size()));
  std::cout << "rgbd-pair: " << X.size() << " matches, " << inl.size() << " PnP inliers, motion "
            << T_ours.inverse().translation().norm() << " m / " << T_ours.angle() * 180 / M_PI << " deg; |dt| = " << dt
            << " m, |dR| = " << dr << " deg\n";
  EXPECT_LE(dt, 0.01);
  EXPECT_LE(dr, 0.5);
  EXPECT_GT(T_ours.inverse().translation().norm(), 0.01);  // the frames are not identical
}
