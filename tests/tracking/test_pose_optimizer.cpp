#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <random>

#include <Eigen/Eigenvalues>

#include "dslam/tracking/pose_optimizer.h"

using namespace dslam;

namespace {
struct Problem {
  SE3 T_true;
  std::vector<PoseObservation> obs;
  PoseOptimizerParams p;
};

Problem makeProblem(bool stereo, double noise_px, double outlier_rate, unsigned seed) {
  Problem pr;
  pr.p.fx = 535.4;
  pr.p.fy = 539.2;
  pr.p.cx = 320.1;
  pr.p.cy = 247.6;
  pr.p.bf = 40.0;
  SE3::Vec6 xi;
  xi << 0.1, -0.05, 0.2, 0.05, -0.1, 0.02;
  pr.T_true = SE3::exp(xi);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-2, 2), uz(1, 6), u01(0, 1);
  std::normal_distribution<double> n(0, noise_px);
  const SE3 T_wc = pr.T_true.inverse();
  while (pr.obs.size() < 400) {
    const Eigen::Vector3d Xc(ux(rng), ux(rng) * 0.75, uz(rng));
    const double u = pr.p.fx * Xc.x() / Xc.z() + pr.p.cx, v = pr.p.fy * Xc.y() / Xc.z() + pr.p.cy;
    if (u < 0 || v < 0 || u >= 640 || v >= 480) continue;
    PoseObservation o;
    o.Xw = T_wc * Xc;
    o.uv = {u + n(rng), v + n(rng)};
    o.u_right = stereo ? u - pr.p.bf / Xc.z() + n(rng) : -1;
    if (u01(rng) < outlier_rate) o.uv += Eigen::Vector2d(40 + 40 * u01(rng), -30);
    pr.obs.push_back(o);
  }
  return pr;
}

double transErr(const SE3& a, const SE3& b) { return (a.inverse().translation() - b.inverse().translation()).norm(); }
double rotErrDeg(const SE3& a, const SE3& b) { return (a.inverse() * b).angle() * 180 / M_PI; }
}  // namespace

TEST(PoseOptimizer, RecoversPerturbedPoseStereo) {
  Problem pr = makeProblem(true, 0.5, 0.0, 1);
  SE3::Vec6 d;
  d << 0.08, -0.05, 0.06, 0.03, 0.02, -0.04;  // ~8 cm, ~3 deg
  SE3 T = SE3::exp(d) * pr.T_true;
  ASSERT_GT(transErr(T, pr.T_true), 0.05);
  std::vector<char> out;
  const auto r = optimizePose(T, pr.obs, out, pr.p);
  EXPECT_LT(transErr(T, pr.T_true), 0.003);
  EXPECT_LT(rotErrDeg(T, pr.T_true), 0.1);
  EXPECT_GT(r.inliers, 380);
}

TEST(PoseOptimizer, RejectsOutliersMonocular) {
  Problem pr = makeProblem(false, 0.5, 0.2, 2);
  SE3::Vec6 d;
  d << 0.03, 0.02, -0.03, 0.01, -0.01, 0.02;
  SE3 T = SE3::exp(d) * pr.T_true;
  std::vector<char> out;
  const auto r = optimizePose(T, pr.obs, out, pr.p);
  EXPECT_LT(transErr(T, pr.T_true), 0.01);
  EXPECT_LT(rotErrDeg(T, pr.T_true), 0.2);
  // Gross outliers (>= 40 px) are all classified as such, inliers kept.
  int flagged_bad = 0, bad = 0, flagged_good = 0;
  for (size_t i = 0; i < pr.obs.size(); i++) {
    const Eigen::Vector3d Xc = pr.T_true * pr.obs[i].Xw;
    const Eigen::Vector2d ideal(pr.p.fx * Xc.x() / Xc.z() + pr.p.cx, pr.p.fy * Xc.y() / Xc.z() + pr.p.cy);
    const bool is_bad = (pr.obs[i].uv - ideal).norm() > 20;
    bad += is_bad;
    flagged_bad += is_bad && out[i];
    flagged_good += !is_bad && out[i];
  }
  EXPECT_EQ(flagged_bad, bad);
  EXPECT_LT(flagged_good, 0.05 * (pr.obs.size() - bad));
  EXPECT_EQ(r.inliers, static_cast<int>(pr.obs.size()) - flagged_bad - flagged_good);
}

TEST(PoseOptimizer, TooFewObservations) {
  Problem pr = makeProblem(true, 0.0, 0.0, 3);
  pr.obs.resize(2);
  SE3 T = pr.T_true;
  std::vector<char> out;
  EXPECT_EQ(optimizePose(T, pr.obs, out, pr.p).inliers, 0);
}

// A walking person mapped moments ago: 150 young observations of points
// that have since moved 12 cm together, against 80 older background points.
// optimizePose follows the majority (the person); the older-first path
// keeps the background's pose and flags every moved point.
TEST(PoseOptimizer, OlderPointsFirstKeepAYoungMoverOut) {
  Problem pr = makeProblem(true, 0.5, 0.0, 4);
  pr.obs.resize(230);
  std::vector<char> young(pr.obs.size(), 0);
  const SE3 T_wc = pr.T_true.inverse();
  for (size_t i = 80; i < pr.obs.size(); i++) {
    young[i] = 1;
    // Seen where the point is now; the map still has it 12 cm away.
    pr.obs[i].Xw += T_wc.rotation() * Eigen::Vector3d(0.12, 0.0, 0.0);
  }
  SE3::Vec6 d;
  d << 0.01, -0.01, 0.01, 0.005, 0.0, -0.005;
  const SE3 start = SE3::exp(d) * pr.T_true;

  SE3 plain = start;
  std::vector<char> out;
  optimizePose(plain, pr.obs, out, pr.p);
  EXPECT_GT(transErr(plain, pr.T_true), 0.08);  // carried with the person

  SE3 T = start;
  bool checked = false;
  const auto r = optimizePoseOlderFirst(T, pr.obs, young, 50, out, pr.p, &checked);
  EXPECT_TRUE(checked);
  EXPECT_LT(transErr(T, pr.T_true), 0.003);
  EXPECT_LT(rotErrDeg(T, pr.T_true), 0.1);
  int young_kept = 0, older_out = 0;
  for (size_t i = 0; i < pr.obs.size(); i++) (young[i] ? young_kept : older_out) += young[i] ? !out[i] : out[i];
  EXPECT_EQ(young_kept, 0);
  EXPECT_LE(older_out, 4);
  EXPECT_EQ(r.inliers, 80 - older_out);

  // Young points that fit the older ones' pose are kept.
  Problem still = makeProblem(true, 0.5, 0.0, 4);
  still.obs.resize(230);
  SE3 T2 = start;
  optimizePoseOlderFirst(T2, still.obs, young, 50, out, still.p);
  EXPECT_LT(transErr(T2, still.T_true), 0.003);
  EXPECT_LE(std::count(out.begin(), out.end(), 1), 10);

  // Fewer older points than min_older: exactly optimizePose.
  SE3 T3 = start, T4 = start;
  std::vector<char> out3, out4;
  optimizePoseOlderFirst(T3, pr.obs, young, 81, out3, pr.p, &checked);
  EXPECT_FALSE(checked);
  optimizePose(T4, pr.obs, out4, pr.p);
  EXPECT_EQ(out3, out4);
  EXPECT_NEAR(transErr(T3, T4), 0.0, 1e-12);
}

namespace {
/** 120 stereo observations, without noise, of points at depths [z0, z1]
 *  seen by the camera at T_true. */
Problem depthBand(double z0, double z1, unsigned seed) {
  Problem pr = makeProblem(true, 0.0, 0.0, 1);
  pr.obs.clear();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-1, 1), uz(z0, z1);
  const SE3 T_wc = pr.T_true.inverse();
  while (pr.obs.size() < 120) {
    const double z = uz(rng);
    const Eigen::Vector3d Xc(ux(rng) * 0.55 * z, ux(rng) * 0.42 * z, z);
    PoseObservation o;
    o.Xw = T_wc * Xc;
    const double u = pr.p.fx * Xc.x() / z + pr.p.cx, v = pr.p.fy * Xc.y() / z + pr.p.cy;
    o.uv = {u, v};
    o.u_right = u - pr.p.bf / z;
    pr.obs.push_back(o);
  }
  return pr;
}
}  // namespace

// poseCovariance is the Cramer-Rao bound of optimizePose: over 300 noisy
// draws of the same far scene (4-5 m, as shift_dark's shelf at the merge),
// the camera positions' spread along the predicted weakest axis and along
// the optical axis is the predicted one.
TEST(PoseOptimizer, PoseCovariancePredictsTheSpreadOfTheEstimate) {
  const Problem ref = depthBand(4, 5, 3);
  const Eigen::Matrix<double, 6, 6> C = poseCovariance(ref.T_true, ref.obs, {}, ref.p);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C.topLeftCorner<3, 3>());
  const Eigen::Vector3d weak = es.eigenvectors().col(2);
  const double sigma_weak = std::sqrt(es.eigenvalues()(2)), sigma_z = std::sqrt(C(2, 2));
  std::vector<double> dw, dz;
  for (unsigned s = 0; s < 300; s++) {
    Problem pr = ref;  // the same points, new noise
    std::mt19937 rng(100 + s);
    std::normal_distribution<double> n(0, 1.0);
    for (size_t i = 0; i < pr.obs.size(); i++) {
      const Eigen::Vector3d Xc = ref.T_true * ref.obs[i].Xw;
      const double u = pr.p.fx * Xc.x() / Xc.z() + pr.p.cx, v = pr.p.fy * Xc.y() / Xc.z() + pr.p.cy;
      pr.obs[i].uv = {u + n(rng), v + n(rng)};
      pr.obs[i].u_right = u - pr.p.bf / Xc.z() + n(rng);
    }
    SE3 T = pr.T_true;
    std::vector<char> out;
    optimizePose(T, pr.obs, out, pr.p);
    // Camera position error in the true camera's axes.
    const Eigen::Vector3d d = pr.T_true.rotation() * (T.inverse().translation() - pr.T_true.inverse().translation());
    dw.push_back(weak.dot(d));
    dz.push_back(d.z());
  }
  auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return std::sqrt(s / static_cast<double>(v.size()));
  };
  std::cout << "far scene: predicted sigma " << sigma_weak << " m (weakest axis), " << sigma_z << " m (optical axis); "
            << "measured " << rms(dw) << " m, " << rms(dz) << " m\n";
  EXPECT_GT(sigma_weak, 3 * sigma_z);  // one depth: height/pitch and side/yaw trade against each other
  EXPECT_NEAR(rms(dw) / sigma_weak, 1.0, 0.25);
  EXPECT_NEAR(rms(dz) / sigma_z, 1.0, 0.25);
  EXPECT_LT(std::abs(weak.z()), 0.5);  // the weak axis lies across the view, not along it

  // Points spread over 1-5 m pin the pose down several times better.
  const Problem near = depthBand(1, 5, 3);
  const Eigen::Matrix3d Cn = poseCovariance(near.T_true, near.obs, {}, near.p).topLeftCorner<3, 3>();
  const double sigma_near = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(Cn).eigenvalues()(2));
  std::cout << "1-5 m: predicted sigma " << sigma_near << " m\n";
  EXPECT_LT(sigma_near, sigma_weak / 3);
  // Fewer than three observations: no covariance.
  std::vector<PoseObservation> two(ref.obs.begin(), ref.obs.begin() + 2);
  EXPECT_EQ(poseCovariance(ref.T_true, two, {}, ref.p).norm(), 0.0);
}
