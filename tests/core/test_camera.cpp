// PinholeCamera: distortion model (core).
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "dslam/core/camera_presets.h"

using namespace dslam;

TEST(Camera, UndistortInvertsDistortAndMatchesOpenCV) {
  const PinholeCamera c = cameraPreset("tum_fr1")->left;
  ASSERT_TRUE(c.hasDistortion());
  for (double u : {5.0, 100.0, 320.0, 600.0})
    for (double v : {7.0, 240.0, 470.0}) {
      const Eigen::Vector2d d = c.distort(u, v);
      const Eigen::Vector2d back = c.undistort(d.x(), d.y());
      EXPECT_NEAR(back.x(), u, 1e-3);
      EXPECT_NEAR(back.y(), v, 1e-3);
      // OpenCV's projectPoints applies the same model.
      cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
      cv::Mat D(1, 5, CV_64F, const_cast<double*>(c.dist.data()));
      std::vector<cv::Point3d> X = {{(u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0}};
      std::vector<cv::Point2d> px;
      cv::projectPoints(X, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, px);
      EXPECT_NEAR(px[0].x, d.x(), 1e-6);
      EXPECT_NEAR(px[0].y, d.y(), 1e-6);
    }
}
