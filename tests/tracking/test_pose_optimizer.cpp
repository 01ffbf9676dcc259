#include <gtest/gtest.h>

#include <algorithm>
#include <random>

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
