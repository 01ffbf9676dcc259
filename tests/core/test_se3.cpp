#include <gtest/gtest.h>

#include "dslam/core/se3.h"

using dslam::SE3;

TEST(SE3, ExpLogRoundTrip) {
  SE3::Vec6 xi;
  xi << 0.3, -0.2, 1.5, 0.4, -0.7, 0.2;
  const SE3 T = SE3::exp(xi);
  EXPECT_LT((T.log() - xi).norm(), 1e-12);
  // Small angles take the series branch.
  SE3::Vec6 small;
  small << 1e-3, 2e-3, -1e-3, 1e-12, -2e-12, 5e-13;
  EXPECT_LT((SE3::exp(small).log() - small).norm(), 1e-12);
}

TEST(SE3, ComposeInverseAndAct) {
  SE3::Vec6 a, b;
  a << 1, 2, 3, 0.1, 0.2, 0.3;
  b << -0.5, 0.1, 0.2, -0.3, 0.05, 0.9;
  const SE3 A = SE3::exp(a), B = SE3::exp(b);
  const Eigen::Vector3d p(0.3, -1.2, 4.0);
  EXPECT_LT(((A * B) * p - A * (B * p)).norm(), 1e-12);
  EXPECT_LT(((A * A.inverse()).matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  EXPECT_LT(((A * B).matrix() - A.matrix() * B.matrix()).norm(), 1e-12);
}

TEST(SE3, AngleMatchesAxisAngle) {
  const SE3 R(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())), Eigen::Vector3d::Zero());
  EXPECT_NEAR(R.angle(), 0.7, 1e-12);
  EXPECT_NEAR(SE3(Eigen::Matrix4d(R.matrix())).angle(), 0.7, 1e-12);
}
