// dslam::eval library: golden ATE/RPE (TUM fr1_xyz, rgbdslam estimate) in all
// trajectory formats, alignment recovery, statistics, RPE pair selection in
// frames / seconds / metres with known answers, and the error cases.
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "dslam/core/error.h"
#include "dslam/eval/eval.h"
#include "dslam/trajectory/io.h"
#include "test_support.h"

using namespace dslam;
using dslam::test::tempDir;

namespace {

constexpr double kTol = 1e-6;  // reference numbers are given to 7 decimals

std::string goldenGt() { return dslam::test::shared("data/eval-golden/freiburg1_xyz-groundtruth.txt"); }
std::string goldenEst() { return dslam::test::shared("data/eval-golden/freiburg1_xyz-rgbdslam.txt"); }

void expectGoldenAte(const eval::AteResult& r) {
  EXPECT_EQ(r.stats.count, 786u);
  EXPECT_EQ(r.assoc.size(), 786u);
  EXPECT_NEAR(r.stats.rmse, 0.0134735, kTol);
  EXPECT_NEAR(r.stats.mean, 0.0120295, kTol);
  EXPECT_NEAR(r.stats.median, 0.0111758, kTol);
  EXPECT_NEAR(r.stats.std, 0.0060684, kTol);
  EXPECT_NEAR(r.stats.min, 0.0009387, kTol);
  EXPECT_NEAR(r.stats.max, 0.0347272, kTol);
}

void expectGoldenRpe(const eval::RpeResult& r) {
  EXPECT_EQ(r.pairs.size(), 785u);
  EXPECT_EQ(r.trans.count, 785u);
  EXPECT_NEAR(r.trans.rmse, 0.0057592, kTol);
  // The rotational reference is given to 5 decimals (0.35283): half a unit
  // of its last digit.
  EXPECT_NEAR(r.rot.rmse, 0.35283, 5e-6);
}

/** Pose with a yaw (about z) and a position. */
SE3 pose(double yaw, const Eigen::Vector3d& p) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())), p);
}

/** n poses at 10 Hz moving along x at `speed` m/s, shifted by `offset`. */
Trajectory along(int n, double speed, const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
  Trajectory t;
  for (int i = 0; i < n; i++) t.push_back(i * 0.1, pose(0, Eigen::Vector3d(i * 0.1 * speed, 0, 0) + offset));
  return t;
}

/** A 3-D helix with changing orientation, 30 Hz. */
Trajectory helix(size_t n) {
  Trajectory t;
  for (size_t i = 0; i < n; i++) {
    const double s = 0.05 * static_cast<double>(i);
    const Eigen::Quaterniond q = Eigen::AngleAxisd(s, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(0.3 * std::sin(s), Eigen::Vector3d::UnitX());
    t.push_back(100.0 + static_cast<double>(i) / 30.0, SE3(q, {std::cos(s), std::sin(s), 0.1 * s}));
  }
  return t;
}


}  // namespace

// ------------------------------------------------------------ golden ----

TEST(EvalGolden, AteMatchesReference) {
  const Trajectory gt = traj::read(goldenGt()), est = traj::read(goldenEst());
  const auto r = eval::computeAte(gt, est);
  expectGoldenAte(r);
  EXPECT_EQ(r.alignment.method, eval::Align::SE3);
  EXPECT_DOUBLE_EQ(r.alignment.scale, 1.0);
  EXPECT_EQ(r.aligned.size(), est.size());
  ASSERT_EQ(r.errors.size(), 786u);
  // Per-pair errors are the distances of the aligned estimate to the gt.
  const auto [i, j] = r.assoc.pairs[100];
  EXPECT_DOUBLE_EQ(r.errors[100], (gt.poses[i].translation() - r.aligned.poses[j].translation()).norm());
  std::printf("golden ATE: pairs %zu rmse %.17g mean %.17g median %.17g std %.17g min %.17g max %.17g\n",
              r.stats.count, r.stats.rmse, r.stats.mean, r.stats.median, r.stats.std, r.stats.min, r.stats.max);
}

TEST(EvalGolden, RpeMatchesReference) {
  const Trajectory gt = traj::read(goldenGt()), est = traj::read(goldenEst());
  eval::RpeOptions o;
  o.delta = 1;
  o.unit = eval::DeltaUnit::Frames;
  const auto r = eval::computeRpe(gt, est, o);
  expectGoldenRpe(r);
  EXPECT_EQ(r.assoc.size(), 786u);
  for (size_t k = 0; k < r.pairs.size(); k++) {
    EXPECT_EQ(r.pairs[k].k0, k);
    EXPECT_EQ(r.pairs[k].k1, k + 1);
  }
  std::printf("golden RPE: pairs %zu trans rmse %.17g mean %.17g median %.17g std %.17g min %.17g max %.17g\n",
              r.trans.count, r.trans.rmse, r.trans.mean, r.trans.median, r.trans.std, r.trans.min, r.trans.max);
  std::printf("golden RPE: rot rmse %.17g mean %.17g median %.17g std %.17g min %.17g max %.17g deg\n", r.rot.rmse,
              r.rot.mean, r.rot.median, r.rot.std, r.rot.min, r.rot.max);

  // A rigid alignment cancels in relative poses.
  o.align = eval::Align::SE3;
  const auto r2 = eval::computeRpe(gt, est, o);
  EXPECT_NEAR(r2.trans.rmse, r.trans.rmse, 1e-12);
  EXPECT_NEAR(r2.rot.rmse, r.rot.rmse, 1e-9);
}

TEST(EvalGolden, SameResultsInKittiAndEurocFormats) {
  const Trajectory gt = traj::read(goldenGt()), est = traj::read(goldenEst());
  const auto ref = eval::computeAte(gt, est);
  const std::string d = tempDir("evalfmt");

  traj::WriteOptions k13;
  k13.format = traj::Format::Kitti;
  k13.kitti_with_times = true;
  traj::write(d + "/est_k13.txt", est, k13);

  traj::WriteOptions k12;
  k12.format = traj::Format::Kitti;
  traj::write(d + "/est_k12.txt", est, k12);
  dslam::test::writeKittiTimes(d + "/times.txt", est.stamps);

  traj::WriteOptions eu;
  eu.format = traj::Format::Euroc;
  traj::write(d + "/est.csv", est, eu);

  traj::ReadOptions with_times;
  with_times.kitti_times = d + "/times.txt";
  const std::vector<std::pair<std::string, Trajectory>> variants = {
      {"kitti 13 columns", traj::read(d + "/est_k13.txt")},
      {"kitti 12 + times", traj::read(d + "/est_k12.txt", with_times)},
      {"euroc csv", traj::read(d + "/est.csv")},
  };
  for (const auto& [name, e] : variants) {
    SCOPED_TRACE(name);
    const auto r = eval::computeAte(gt, e);
    expectGoldenAte(r);
    EXPECT_NEAR(r.stats.rmse, ref.stats.rmse, 1e-8);
    const auto p = eval::computeRpe(gt, e, {});
    expectGoldenRpe(p);
  }
}

// ------------------------------------------------------------ alignment --

TEST(EvalAlign, Sim3RecoversKnownScaleAndTransform) {
  const Trajectory gt = helix(200);
  // est = S^-1 * gt with S = (s, R, t): p_est = R^T (p_gt - t) / s.
  const double s = 2.5;
  const Eigen::Quaterniond R(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d t(0.4, -1.2, 3.0);
  Trajectory est;
  for (size_t i = 0; i < gt.size(); i++)
    est.push_back(gt.stamps[i] + 0.004,
                  SE3(R.conjugate() * gt.poses[i].quaternion(), R.conjugate() * (gt.poses[i].translation() - t) / s));

  eval::AteOptions o;
  o.align = eval::Align::Sim3;
  const auto r = eval::computeAte(gt, est, o);
  EXPECT_EQ(r.stats.count, 200u);
  EXPECT_NEAR(r.alignment.scale, s, 1e-9);
  EXPECT_LT(r.alignment.T.quaternion().angularDistance(R), 1e-9);
  EXPECT_LT((r.alignment.T.translation() - t).norm(), 1e-9);
  EXPECT_LT(r.stats.rmse, 1e-9);
  EXPECT_LT(r.stats.max, 1e-9);
  // Aligned orientations equal the ground truth too.
  EXPECT_LT(r.aligned.poses[50].quaternion().angularDistance(gt.poses[50].quaternion()), 1e-9);
  const Eigen::Matrix4d M = r.alignment.matrix();
  EXPECT_NEAR((M.block<3, 3>(0, 0).determinant()), s * s * s, 1e-8);

  // Without scale the error cannot vanish.
  o.align = eval::Align::SE3;
  const auto r2 = eval::computeAte(gt, est, o);
  EXPECT_DOUBLE_EQ(r2.alignment.scale, 1.0);
  EXPECT_GT(r2.stats.rmse, 0.1);
}

TEST(EvalAlign, Se3RecoversRigidTransformAndNoneKeepsOffsets) {
  const Trajectory gt = helix(100);
  const SE3 T(Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d(0, 1, 1).normalized())), {2, 0, -1});
  Trajectory est;
  for (size_t i = 0; i < gt.size(); i++) est.push_back(gt.stamps[i], T.inverse() * gt.poses[i]);
  const auto r = eval::computeAte(gt, est);
  EXPECT_LT(r.stats.rmse, 1e-9);
  EXPECT_LT(r.alignment.T.quaternion().angularDistance(T.quaternion()), 1e-9);
  EXPECT_LT((r.alignment.T.translation() - T.translation()).norm(), 1e-9);

  // align none: a constant offset of 1 m shows up unchanged.
  Trajectory shifted;
  for (size_t i = 0; i < gt.size(); i++)
    shifted.push_back(gt.stamps[i], SE3(gt.poses[i].quaternion(), gt.poses[i].translation() + Eigen::Vector3d(0, 0, 1)));
  eval::AteOptions o;
  o.align = eval::Align::None;
  const auto n = eval::computeAte(gt, shifted, o);
  EXPECT_NEAR(n.stats.rmse, 1.0, 1e-12);
  EXPECT_NEAR(n.stats.min, 1.0, 1e-12);
  EXPECT_NEAR(n.stats.std, 0.0, 1e-12);
}

TEST(EvalAlign, NeedsThreePointsAndSpreadForScale) {
  std::vector<Eigen::Vector3d> a = {{0, 0, 0}, {1, 0, 0}}, b = a;
  EXPECT_NE(test::dataError([&] { eval::alignPoints(a, b, eval::Align::SE3); }).find("at least 3"), std::string::npos);
  EXPECT_NO_THROW(eval::alignPoints(a, b, eval::Align::None));
  std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d(1, 2, 3)), other = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  EXPECT_NE(test::dataError([&] { eval::alignPoints(same, other, eval::Align::Sim3); }).find("scale undefined"),
            std::string::npos);
  EXPECT_THROW(eval::alignFromString("affine"), ConfigError);
  EXPECT_EQ(eval::alignFromString("sim3"), eval::Align::Sim3);
}

// ------------------------------------------------------------ stats -----

TEST(EvalStats, NumpySemantics) {
  const auto s = eval::computeStats({4, 1, 3, 2});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);  // mean of the two middle values
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 4);
  EXPECT_DOUBLE_EQ(eval::computeStats({5, 1, 3}).median, 3);
  EXPECT_THROW(eval::computeStats({}), DataError);
}

// ------------------------------------------------------------ association

TEST(EvalAssociation, NoOverlapIsAClearError) {
  Trajectory gt, est;
  for (int i = 0; i < 10; i++) gt.push_back(i * 0.1, pose(0, {i * 0.1, 0, 0}));
  for (int i = 0; i < 10; i++) est.push_back(100 + i * 0.1, pose(0, {i * 0.1, 0, 0}));
  eval::AteOptions o;
  o.gt_name = "gt.txt";
  o.est_name = "est.txt";
  const std::string m = test::dataError([&] { eval::computeAte(gt, est, o); });
  EXPECT_NE(m.find("no ground-truth pose within max_dt 0.02 s of any of the 10 estimate poses"), std::string::npos)
      << m;
  EXPECT_NE(m.find("gt.txt"), std::string::npos) << m;
  EXPECT_NE(m.find("est.txt"), std::string::npos) << m;
  eval::RpeOptions ro;
  EXPECT_NE(test::dataError([&] { eval::computeRpe(gt, est, ro); }).find("no ground-truth pose"), std::string::npos);
  // A stamp offset just inside max_dt associates everything.
  Trajectory near;
  for (int i = 0; i < 10; i++) near.push_back(i * 0.1 + 0.019, pose(0, {i * 0.1, 0, 0}));
  EXPECT_EQ(eval::computeAte(gt, near).stats.count, 10u);
  o.max_dt = 0.01;
  EXPECT_THROW(eval::computeAte(gt, near, o), DataError);
}

TEST(EvalAssociation, OnlyOverlappingPosesCount) {
  Trajectory gt, est;
  for (int i = 0; i < 20; i++) gt.push_back(i * 0.1, pose(0, {i * 0.1, 0, 0}));
  for (int i = 10; i < 30; i++) est.push_back(i * 0.1 + 0.001, pose(0, {i * 0.1, 0, 0}));
  const auto r = eval::computeAte(gt, est);
  EXPECT_EQ(r.stats.count, 10u);
  EXPECT_EQ(r.assoc.pairs.front(), (std::pair<size_t, size_t>{10, 0}));
  EXPECT_LT(r.stats.rmse, 1e-12);
}

// ------------------------------------------------------------ RPE -------

TEST(EvalRpe, SecondsOnConstantScaleDrift) {
  // gt moves 1 m/s along x at 10 Hz, the estimate 1.1 m/s: every pair 0.5 s
  // apart has a translational error of exactly 0.05 m and no rotation error.
  const Trajectory gt = along(40, 1.0), est = along(40, 1.1);
  eval::RpeOptions o;
  o.delta = 0.5;
  o.unit = eval::DeltaUnit::Seconds;
  const auto r = eval::computeRpe(gt, est, o);
  ASSERT_EQ(r.pairs.size(), 35u);
  for (const auto& p : r.pairs) EXPECT_EQ(p.k1, p.k0 + 5);
  EXPECT_NEAR(r.trans.rmse, 0.05, 1e-12);
  EXPECT_NEAR(r.trans.min, 0.05, 1e-12);
  EXPECT_NEAR(r.trans.max, 0.05, 1e-12);
  EXPECT_NEAR(r.rot.max, 0.0, 1e-9);

  // Sim3 removes the scale drift (scale 1/1.1).
  o.align = eval::Align::Sim3;
  const auto s = eval::computeRpe(gt, est, o);
  EXPECT_NEAR(s.alignment.scale, 1 / 1.1, 1e-12);
  EXPECT_LT(s.trans.max, 1e-12);

  // Frames: delta 5 gives the same pairs.
  o.align = eval::Align::None;
  o.unit = eval::DeltaUnit::Frames;
  o.delta = 5;
  const auto f = eval::computeRpe(gt, est, o);
  EXPECT_EQ(f.pairs.size(), 35u);
  EXPECT_NEAR(f.trans.rmse, 0.05, 1e-12);
}

TEST(EvalRpe, RotationErrorInDegrees) {
  // Static camera; the estimate yaws 1 degree per frame: 5 degrees per 0.5 s.
  Trajectory gt, est;
  for (int i = 0; i < 20; i++) {
    gt.push_back(i * 0.1, pose(0, {1, 2, 3}));
    est.push_back(i * 0.1, pose(i * M_PI / 180, {1, 2, 3}));
  }
  eval::RpeOptions o;
  o.delta = 0.5;
  o.unit = eval::DeltaUnit::Seconds;
  const auto r = eval::computeRpe(gt, est, o);
  ASSERT_EQ(r.pairs.size(), 15u);
  EXPECT_NEAR(r.rot.rmse, 5.0, 1e-9);
  EXPECT_NEAR(r.rot.min, 5.0, 1e-9);
  EXPECT_NEAR(r.trans.max, 0.0, 1e-12);
}

TEST(EvalRpe, SecondsPairsAreTheFirstAtLeastDeltaApart) {
  const std::vector<double> t = {0.0, 0.1, 0.25, 0.3, 0.7};
  Trajectory gt;
  for (double s : t) gt.push_back(s, pose(0, {s, 0, 0}));
  eval::RpeOptions o;
  o.delta = 0.2;
  o.unit = eval::DeltaUnit::Seconds;
  const auto r = eval::computeRpe(gt, gt, o);
  const std::vector<std::pair<size_t, size_t>> want = {{0, 2}, {1, 3}, {2, 4}, {3, 4}};
  ASSERT_EQ(r.pairs.size(), want.size());
  for (size_t k = 0; k < want.size(); k++) {
    EXPECT_EQ(r.pairs[k].k0, want[k].first) << k;
    EXPECT_EQ(r.pairs[k].k1, want[k].second) << k;
  }
  EXPECT_DOUBLE_EQ(r.pairs[1].t0, 0.1);
  EXPECT_DOUBLE_EQ(r.pairs[1].t1, 0.3);
  EXPECT_LT(r.trans.max, 1e-12);
}

TEST(EvalRpe, MetresFollowTheWholeGroundTruthPath) {
  // gt: half circle of radius 1 at 10 Hz over 2 s (path 20 * 2 sin(pi/40) = 3.13836 m); the
  // estimate has poses only at t = 0, 1, 2 (chords 2 * 1.414 = 2.83 m).
  Trajectory gt, est;
  for (int i = 0; i <= 20; i++) {
    const double a = M_PI * i / 20.0;
    gt.push_back(i * 0.1, pose(a, {std::cos(a), std::sin(a), 0}));
  }
  for (int i : {0, 10, 20}) est.push_back(gt.stamps[i], gt.poses[i]);
  eval::RpeOptions o;
  o.unit = eval::DeltaUnit::Meters;
  o.delta = 3.0;  // reached along the gt path, not along the chords
  const auto r = eval::computeRpe(gt, est, o);
  ASSERT_EQ(r.pairs.size(), 1u);
  EXPECT_EQ(r.pairs[0].k0, 0u);
  EXPECT_EQ(r.pairs[0].k1, 2u);
  EXPECT_LT(r.trans.max, 1e-12);

  o.delta = 1.5;  // each quarter arc is 1.56918 m along the gt
  const auto q = eval::computeRpe(gt, est, o);
  ASSERT_EQ(q.pairs.size(), 2u);
  EXPECT_EQ(q.pairs[0].k1, 1u);
  EXPECT_EQ(q.pairs[1].k1, 2u);

  o.delta = 3.2;
  const std::string m = test::dataError([&] { eval::computeRpe(gt, est, o); });
  EXPECT_NE(m.find("no pose pair 3.2 m apart"), std::string::npos) << m;
  EXPECT_NE(m.find("span 3.13836 m of ground-truth path"), std::string::npos) << m;
}

TEST(EvalRpe, MetresWithKnownErrors) {
  // gt along x with varying speed; est = gt with a 2x scale: error of a pair
  // = its gt displacement.
  const std::vector<double> x = {0, 0.1, 0.3, 0.6, 1.0, 1.5};
  Trajectory gt, est;
  for (size_t i = 0; i < x.size(); i++) {
    gt.push_back(static_cast<double>(i), pose(0, {x[i], 0, 0}));
    est.push_back(static_cast<double>(i), pose(0, {2 * x[i], 0, 0}));
  }
  eval::RpeOptions o;
  o.unit = eval::DeltaUnit::Meters;
  o.delta = 0.5;
  const auto r = eval::computeRpe(gt, est, o);
  const std::vector<std::pair<size_t, size_t>> want = {{0, 3}, {1, 3}, {2, 4}, {3, 5}, {4, 5}};
  ASSERT_EQ(r.pairs.size(), want.size());
  for (size_t k = 0; k < want.size(); k++) {
    EXPECT_EQ(r.pairs[k].k0, want[k].first) << k;
    EXPECT_EQ(r.pairs[k].k1, want[k].second) << k;
    EXPECT_NEAR(r.pairs[k].trans, x[want[k].second] - x[want[k].first], 1e-12) << k;
  }
  EXPECT_NEAR(r.trans.max, 0.9, 1e-12);
  EXPECT_NEAR(r.trans.min, 0.5, 1e-12);
}

TEST(EvalRpe, BadDeltas) {
  Trajectory gt;
  for (int i = 0; i < 5; i++) gt.push_back(i * 0.1, pose(0, {i * 0.1, 0, 0}));
  eval::RpeOptions o;
  o.delta = 1.5;
  EXPECT_THROW(eval::computeRpe(gt, gt, o), ConfigError);  // frames must be integer
  o.delta = 0;
  EXPECT_THROW(eval::computeRpe(gt, gt, o), ConfigError);
  o.delta = 5;  // 5 poses: no pair 5 frames apart
  const std::string m = test::dataError([&] { eval::computeRpe(gt, gt, o); });
  EXPECT_NE(m.find("no pose pair 5 frames apart (5 associated poses"), std::string::npos) << m;
  o.delta = 1;
  Trajectory one;
  one.push_back(0, SE3());
  EXPECT_NE(test::dataError([&] { eval::computeRpe(one, one, o); }).find("at least 2 associated poses"),
            std::string::npos);
  EXPECT_THROW(eval::deltaUnitFromString("deg"), ConfigError);
}

TEST(EvalRpe, RelativeErrorDefinitionAndSmallAngles) {
  const SE3 Q0 = pose(0.1, {1, 0, 0}), Q1 = pose(0.3, {2, 1, 0});
  // Estimate with the same relative motion from a different start: zero error.
  const SE3 P0 = pose(-1, {5, 5, 5});
  const SE3 P1 = P0 * (Q0.inverse() * Q1);
  EXPECT_LT(eval::relativeError(Q0, Q1, P0, P1).translation().norm(), 1e-12);
  EXPECT_LT(eval::rotationAngle(eval::relativeError(Q0, Q1, P0, P1)), 1e-12);
  // Extra 0.2 m forward motion expressed in the first camera frame.
  const SE3 P1b = P0 * (Q0.inverse() * Q1) * SE3(Eigen::Quaterniond::Identity(), {0.2, 0, 0});
  EXPECT_NEAR(eval::relativeError(Q0, Q1, P0, P1b).translation().norm(), 0.2, 1e-12);
  // atan2 form stays accurate for tiny angles.
  EXPECT_NEAR(eval::rotationAngle(pose(1e-9, {0, 0, 0})), 1e-9, 1e-18);
  EXPECT_NEAR(eval::rotationAngle(pose(3.0, {0, 0, 0})), 3.0, 1e-12);
}

// ------------------------------------------------------------ reports ---

TEST(EvalReport, JsonAndTextCarryTheNumbers) {
  const Trajectory gt = along(10, 1.0), est = along(10, 1.0, {0, 0, 0.25});
  eval::AteOptions o;
  o.align = eval::Align::None;
  const auto r = eval::computeAte(gt, est, o);
  const auto j = nlohmann::ordered_json::parse(eval::toJson(r));
  EXPECT_EQ(j.at("metric"), "ate");
  EXPECT_EQ(j.at("pairs"), 10);
  EXPECT_DOUBLE_EQ(j.at("max_dt").get<double>(), 0.02);
  EXPECT_EQ(j.at("align"), "none");
  EXPECT_NEAR(j.at("rmse").get<double>(), 0.25, 1e-12);
  EXPECT_EQ(j.begin().key(), "metric");  // key order kept
  const std::string t = eval::toText(r);
  EXPECT_NE(t.find("max_dt 0.02 s, alignment none, 10 pose pairs"), std::string::npos) << t;
  EXPECT_NE(t.find("rmse   0.2500000 m"), std::string::npos) << t;

  eval::RpeOptions ro;
  ro.delta = 2;
  const auto rj = nlohmann::json::parse(eval::toJson(eval::computeRpe(gt, est, ro)));
  EXPECT_EQ(rj.at("metric"), "rpe");
  EXPECT_EQ(rj.at("pairs"), 8);
  EXPECT_EQ(rj.at("associated"), 10);
  EXPECT_EQ(rj.at("delta"), 2);
  EXPECT_EQ(rj.at("delta_unit"), "frames");
  EXPECT_NEAR(rj.at("trans").at("rmse").get<double>(), 0, 1e-12);
  EXPECT_NEAR(rj.at("rot").at("rmse").get<double>(), 0, 1e-12);
}
