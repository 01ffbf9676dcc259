// Bundle adjustment and pose-graph optimisation: CeresBackend and
// MrptBackend on the same seeded synthetic problems (ba_synthetic.h).
#include <atomic>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>

#include "ba_synthetic.h"
#include "dslam/core/backend.h"
#include "dslam/core/timing.h"
#include "dslam/core/error.h"
#include "dslam/core/registry.h"

using namespace dslam;
using dslam::test::makeBA;
using dslam::test::makePoseGraph;
using dslam::test::SynthBA;
using dslam::test::SynthBAConfig;

namespace {

std::shared_ptr<Backend> make(const std::string& name, const std::string& yaml = "") {
  register_builtin_plugins();
  auto b = create<Backend>(name);
  EXPECT_TRUE(b) << name;
  b->configure(Params::resolve(b->paramSpecs(), yaml), PluginContext{});
  return b;
}

struct PoseErr {
  double max_t = 0, max_r_deg = 0;
};

PoseErr poseDiff(const std::vector<SE3>& a, const std::vector<SE3>& b) {
  PoseErr e;
  for (size_t i = 0; i < a.size(); i++) {
    // compare camera centres and orientations
    const SE3 A = a[i].inverse(), B = b[i].inverse();
    e.max_t = std::max(e.max_t, (A.translation() - B.translation()).norm());
    e.max_r_deg = std::max(e.max_r_deg, (A.inverse() * B).angle() * 180 / M_PI);
  }
  return e;
}

std::vector<SE3> poses(const BAProblem& p) {
  std::vector<SE3> v;
  for (const auto& k : p.keyframes) v.push_back(k.T_cw);
  return v;
}

std::vector<Eigen::Vector3d> points(const BAProblem& p) {
  std::vector<Eigen::Vector3d> v;
  for (const auto& x : p.points) v.push_back(x.X_w);
  return v;
}

/** Median distance between the points of `p` and `X`. */
double medianPointDiff(const BAProblem& p, const std::vector<Eigen::Vector3d>& X) {
  std::vector<double> d;
  for (size_t i = 0; i < X.size(); i++) d.push_back((p.points[i].X_w - X[i]).norm());
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

/** Cost of the problem with estimates replaced by the ground truth. */
double costAtTruth(const SynthBA& s, const BAOptions& o) {
  BAProblem t = s.problem;
  for (size_t i = 0; i < t.keyframes.size(); i++) t.keyframes[i].T_cw = s.true_T_cw[i];
  for (size_t i = 0; i < t.points.size(); i++) t.points[i].X_w = s.true_X[i];
  return evaluateCost(t, o);
}

bool sameBits(const SE3& a, const SE3& b) {
  return std::memcmp(a.quaternion().coeffs().data(), b.quaternion().coeffs().data(), 4 * sizeof(double)) == 0 &&
         std::memcmp(a.translation().data(), b.translation().data(), 3 * sizeof(double)) == 0;
}

BAOptions leastSquares(int iterations = 50) {
  BAOptions o;
  o.robust = false;
  o.reject_outliers = false;
  o.max_iterations = iterations;
  return o;
}

}  // namespace

TEST(Backends, RegistryCreatesAll) {
  register_builtin_plugins();
  for (const char* n : {"dslam::CeresBackend", "dslam::MrptBackend", "dslam::SchurBackend"}) {
    auto b = create<Backend>(n);
    ASSERT_TRUE(b) << n;
    EXPECT_STREQ(b->interfaceName(), "Backend");
    EXPECT_FALSE(b->description().empty());
  }
  const auto names = pluginNames(CLASS_ID(Backend));
  EXPECT_NE(std::find(names.begin(), names.end(), "dslam::CeresBackend"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "dslam::MrptBackend"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "dslam::SchurBackend"), names.end());
}

TEST(Backends, YamlParamsAreValidatedAndOverrideOptions) {
  register_builtin_plugins();
  auto b = create<Backend>("dslam::CeresBackend");
  EXPECT_THROW(Params::resolve(b->paramSpecs(), "linear_solver: cholmod"), ConfigError);
  EXPECT_THROW(Params::resolve(b->paramSpecs(), "max_iters: 3"), ConfigError);

  // max_iterations written in the YAML overrides the caller's BAOptions.
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend", "dslam::SchurBackend"}) {
    auto s = makeBA({});
    auto be = make(name, "max_iterations: 1");
    const BAResult r = be->bundleAdjust(s.problem, leastSquares(50));
    EXPECT_TRUE(r.success) << name << ": " << r.message;
    EXPECT_EQ(r.iterations, 1) << name << ": " << r.message;
    EXPECT_LT(r.final_cost, r.initial_cost) << name;
  }
  // Not written: the caller's value applies.
  auto s = makeBA({});
  const BAResult r = make("dslam::CeresBackend")->bundleAdjust(s.problem, leastSquares(3));
  EXPECT_LE(r.iterations, 3);
  EXPECT_GE(r.iterations, 2);
}

TEST(Backends, InvalidProblemIsADataError) {
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend", "dslam::SchurBackend"}) {
    auto be = make(name);
    auto s = makeBA({});
    s.problem.observations[3].pt = 5000;
    try {
      be->bundleAdjust(s.problem, {});
      ADD_FAILURE() << name << ": no error";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("observation 3"), std::string::npos) << e.what();
    }
    s = makeBA({});
    s.problem.observations[0].u_right = 300;  // stereo on a camera without bf
    EXPECT_THROW(be->bundleAdjust(s.problem, {}), DataError) << name;

    // empty problems are not errors
    BAProblem empty;
    empty.camera = {500, 500, 320, 240, 0};
    const BAResult r = be->bundleAdjust(empty, {});
    EXPECT_TRUE(r.success) << name;
    EXPECT_EQ(r.final_cost, 0.0) << name;
    PoseGraph empty_graph;
    EXPECT_TRUE(be->optimizePoseGraph(empty_graph, {}).success) << name;

    auto g = makePoseGraph(10);
    g.graph.edges[3].information(0, 0) = -1;
    EXPECT_THROW(be->optimizePoseGraph(g.graph, {}), DataError) << name;
    g = makePoseGraph(10);
    g.graph.edges[2].to = 10;
    try {
      be->optimizePoseGraph(g.graph, {});
      ADD_FAILURE() << name << ": no error";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("edge 2"), std::string::npos) << e.what();
    }
  }
}

// Monocular 10 KF / 1000 points, 1 px noise, 2 fixed keyframes: plain least
// squares reaches the noise floor (at or below the cost of the ground truth)
// with both backends, and both land on the same solution.
TEST(Backends, MonoLeastSquaresBothBackendsAgree) {
  const auto s0 = makeBA({});
  const BAOptions o = leastSquares(50);
  const double truth = costAtTruth(s0, o);
  const int m = 2 * static_cast<int>(s0.problem.observations.size());
  const int n = 6 * 8 + 3 * 1000;  // free parameters
  EXPECT_NEAR(truth / m, 1.0, 0.05);  // sanity: the noise is what we asked for

  BAProblem pc = s0.problem, pm = s0.problem;
  const BAResult rc = make("dslam::CeresBackend")->bundleAdjust(pc, o);
  const BAResult rm = make("dslam::MrptBackend")->bundleAdjust(pm, o);
  ASSERT_TRUE(rc.success) << rc.message;
  ASSERT_TRUE(rm.success) << rm.message;
  for (const auto* r : {&rc, &rm}) {
    EXPECT_GT(r->initial_cost, 100 * truth);  // the perturbation is large
    EXPECT_LE(r->final_cost, truth);
    // expected residual of least squares: (m - n) sigma^2
    EXPECT_NEAR(r->final_cost / (m - n), 1.0, 0.05);
    EXPECT_EQ(r->num_outliers, 0);
  }
  EXPECT_NEAR(rc.final_cost, rm.final_cost, 1e-4 * rc.final_cost);
  const PoseErr d = poseDiff(poses(pc), poses(pm));
  EXPECT_LT(d.max_t, 1e-4);
  EXPECT_LT(d.max_r_deg, 1e-3);
  EXPECT_LT(medianPointDiff(pc, points(pm)), 1e-4);
  std::printf("mono LS: cost %.1f -> Ceres %.3f (%d it, %.0f ms) / MRPT %.3f (%d it, %.0f ms), truth %.1f; "
              "pose diff %.2g m %.2g deg\n",
              rc.initial_cost, rc.final_cost, rc.iterations, rc.time_ms, rm.final_cost, rm.iterations, rm.time_ms,
              truth, d.max_t, d.max_r_deg);
  // both close to the ground truth (noise-limited: 1 px at 3-7 m)
  for (const auto* p : {&pc, &pm}) {
    const PoseErr e = poseDiff(poses(*p), s0.true_T_cw);
    EXPECT_LT(e.max_t, 0.015);
    EXPECT_LT(e.max_r_deg, 0.1);
    EXPECT_LT(medianPointDiff(*p, s0.true_X), 0.04);
  }
}

// Huber kernel, no outlier rejection: MRPT minimises a pseudo-Huber cost,
// Ceres the Huber cost of the convention; evaluated with evaluateCost() both
// results agree within 1 %.
TEST(Backends, MonoRobustBothBackendsAgree) {
  const auto s0 = makeBA({});
  BAOptions o;
  o.reject_outliers = false;
  o.max_iterations = 50;
  BAProblem pc = s0.problem, pm = s0.problem;
  const BAResult rc = make("dslam::CeresBackend")->bundleAdjust(pc, o);
  const BAResult rm = make("dslam::MrptBackend")->bundleAdjust(pm, o);
  ASSERT_TRUE(rc.success) << rc.message;
  ASSERT_TRUE(rm.success) << rm.message;
  EXPECT_LE(rc.final_cost, costAtTruth(s0, o));
  EXPECT_NEAR(rc.final_cost, rm.final_cost, 0.01 * rc.final_cost);
  EXPECT_LE(rc.final_cost, rm.final_cost * 1.0001);  // Ceres minimises exactly this cost
  const PoseErr d = poseDiff(poses(pc), poses(pm));
  EXPECT_LT(d.max_t, 1e-3);
  std::printf("mono Huber: Ceres %.2f / MRPT %.2f; pose diff %.2g m %.2g deg\n", rc.final_cost, rm.final_cost,
              d.max_t, d.max_r_deg);
}

// Default options (Huber, ORB-SLAM outlier scheme). The chi2 tests flag
// slightly different borderline observations, so the costs (which exclude
// flagged observations) differ by a few percent; the poses agree.
TEST(Backends, MonoDefaultOptionsBothBackendsAgree) {
  const auto s0 = makeBA({});
  const BAOptions o;  // robust, reject_outliers, 10 iterations per pass
  const double truth = costAtTruth(s0, o);
  BAProblem pc = s0.problem, pm = s0.problem;
  const BAResult rc = make("dslam::CeresBackend")->bundleAdjust(pc, o);
  const BAResult rm = make("dslam::MrptBackend")->bundleAdjust(pm, o);
  ASSERT_TRUE(rc.success) << rc.message;
  ASSERT_TRUE(rm.success) << rm.message;
  const int nobs = static_cast<int>(s0.problem.observations.size());
  for (const auto* r : {&rc, &rm}) {
    EXPECT_LT(r->final_cost, truth);  // chi2 outliers are excluded from the final cost
    // pure Gaussian noise: the chi2 test (95 %) flags a few percent
    EXPECT_GT(r->num_outliers, 0.01 * nobs);
    EXPECT_LT(r->num_outliers, 0.08 * nobs);
  }
  EXPECT_NEAR(rc.final_cost, rm.final_cost, 0.05 * rc.final_cost);
  const PoseErr d = poseDiff(poses(pc), poses(pm));
  EXPECT_LT(d.max_t, 2e-3);
  EXPECT_LT(d.max_r_deg, 0.02);
  std::printf("mono ORB-SLAM scheme: Ceres %.1f (%d outliers, %.0f ms) / MRPT %.1f (%d outliers, %.0f ms); "
              "pose diff %.2g m %.2g deg\n",
              rc.final_cost, rc.num_outliers, rc.time_ms, rm.final_cost, rm.num_outliers, rm.time_ms, d.max_t,
              d.max_r_deg);
  for (const auto* p : {&pc, &pm}) EXPECT_LT(poseDiff(poses(*p), s0.true_T_cw).max_t, 0.015);
}

// SchurBackend minimises the same cost as CeresBackend with another solver:
// plain least squares reaches the same minimum; with the ORB-SLAM scheme on
// a local-BA-like stereo problem (20 keyframes, 3000 points, 2 % outliers)
// the same observations are flagged, up to a few borderline ones, and the
// poses agree to noise level.
TEST(Backends, SchurAndCeresReachTheSameMinimum) {
  {
    const auto s0 = makeBA({});
    const BAOptions o = leastSquares(50);
    BAProblem pc = s0.problem, ps = s0.problem;
    const BAResult rc = make("dslam::CeresBackend")->bundleAdjust(pc, o);
    const BAResult rs = make("dslam::SchurBackend")->bundleAdjust(ps, o);
    ASSERT_TRUE(rc.success) << rc.message;
    ASSERT_TRUE(rs.success) << rs.message;
    EXPECT_NE(rs.message.find("schur 8 kf"), std::string::npos) << rs.message;
    // both stop at Ceres' function tolerance (1e-6 relative): the same minimum to that precision
    EXPECT_NEAR(rs.final_cost, rc.final_cost, 1e-6 * rc.final_cost);
    const PoseErr d = poseDiff(poses(pc), poses(ps));
    EXPECT_LT(d.max_t, 1e-4);
    EXPECT_LT(d.max_r_deg, 1e-3);
    EXPECT_LT(medianPointDiff(pc, points(ps)), 1e-4);
    std::printf("mono LS: Ceres %.4f (%d it, %.1f ms) / Schur %.4f (%d it, %.1f ms); pose diff %.2g m\n",
                rc.final_cost, rc.iterations, rc.time_ms, rs.final_cost, rs.iterations, rs.time_ms, d.max_t);
  }
  const auto s0 = makeBA(dslam::test::localBAConfig());
  BAProblem pc = s0.problem, ps = s0.problem;
  const BAResult rc = make("dslam::CeresBackend")->bundleAdjust(pc, BAOptions{});
  const BAResult rs = make("dslam::SchurBackend")->bundleAdjust(ps, BAOptions{});
  ASSERT_TRUE(rc.success) << rc.message;
  ASSERT_TRUE(rs.success) << rs.message;
  int differ = 0;
  for (size_t i = 0; i < pc.observations.size(); i++) differ += pc.observations[i].outlier != ps.observations[i].outlier;
  EXPECT_LT(differ, 0.002 * pc.observations.size());
  EXPECT_NEAR(rs.final_cost, rc.final_cost, 0.01 * rc.final_cost);
  const PoseErr d = poseDiff(poses(pc), poses(ps));
  EXPECT_LT(d.max_t, 1e-3);
  EXPECT_LT(d.max_r_deg, 0.01);
  EXPECT_LT(poseDiff(poses(ps), s0.true_T_cw).max_t, 1.2 * poseDiff(poses(pc), s0.true_T_cw).max_t + 1e-3);
  std::printf("stereo local BA, ORB-SLAM scheme: Ceres %.1f (%d outliers, %d it, %.0f ms) / Schur %.1f (%d "
              "outliers, %d it, %.0f ms); %d flags differ; pose diff %.2g m %.2g deg\n",
              rc.final_cost, rc.num_outliers, rc.iterations, rc.time_ms, rs.final_cost, rs.num_outliers,
              rs.iterations, rs.time_ms, differ, d.max_t, d.max_r_deg);
}

// More free keyframes than dense_max_keyframes: CeresBackend solves it.
TEST(Backends, SchurHandsLargeProblemsToCeres) {
  auto s = makeBA({});
  const BAResult r = make("dslam::SchurBackend", "dense_max_keyframes: 5")->bundleAdjust(s.problem, leastSquares(30));
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.message.find("schur"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("SCHUR"), std::string::npos) << r.message;  // Ceres' solver name
  auto t = makeBA({});
  const BAResult rs = make("dslam::SchurBackend", "dense_max_keyframes: 8")->bundleAdjust(t.problem, leastSquares(30));
  EXPECT_NE(rs.message.find("schur 8 kf"), std::string::npos) << rs.message;
  EXPECT_NEAR(rs.final_cost, r.final_cost, 1e-6 * r.final_cost);
}

// Stereo / RGB-D observations (Ceres and Schur): exact observations -> the
// ground truth is recovered; with pyramid-level noise -> the noise floor.
TEST(Backends, StereoRecoversPosesAndPoints) {
  for (const char* name : {"dslam::CeresBackend", "dslam::SchurBackend"}) {
    SCOPED_TRACE(name);
    SynthBAConfig c;
    c.stereo = true;
    c.fixed_keyframes = 1;
    c.pixel_sigma = 0;
    auto s = makeBA(c);
    BAResult r = make(name)->bundleAdjust(s.problem, leastSquares(30));
    ASSERT_TRUE(r.success) << r.message;
    EXPECT_GT(r.initial_cost, 1e5);
    EXPECT_LT(r.final_cost, 1e-6);
    PoseErr e = poseDiff(poses(s.problem), s.true_T_cw);
    EXPECT_LT(e.max_t, 1e-6);
    EXPECT_LT(e.max_r_deg, 1e-6);
    EXPECT_LT(medianPointDiff(s.problem, s.true_X), 1e-6);
    std::printf("%s stereo exact: cost %.3g -> %.3g in %d it, pose err %.2g m %.2g deg\n", name, r.initial_cost,
                r.final_cost, r.iterations, e.max_t, e.max_r_deg);

    c.pixel_sigma = 1;
    c.levels = 4;  // sigma 1.2^level, information 1 / sigma^2
    s = makeBA(c);
    const BAOptions o = leastSquares(30);
    const double truth = costAtTruth(s, o);
    r = make(name)->bundleAdjust(s.problem, o);
    ASSERT_TRUE(r.success) << r.message;
    const int m = 3 * static_cast<int>(s.problem.observations.size()), n = 6 * 9 + 3 * 1000;
    EXPECT_LE(r.final_cost, truth);
    EXPECT_NEAR(r.final_cost / (m - n), 1.0, 0.05);
    e = poseDiff(poses(s.problem), s.true_T_cw);
    EXPECT_LT(e.max_t, 0.02);
    EXPECT_LT(e.max_r_deg, 0.15);
    // depth from an 8 cm baseline at 3-7 m: a few cm
    EXPECT_LT(medianPointDiff(s.problem, s.true_X), 0.04);
    std::printf("%s stereo noisy: cost %.1f -> %.1f (truth %.1f) in %d it, %.1f ms, pose err %.2g m %.2g deg\n",
                name, r.initial_cost, r.final_cost, truth, r.iterations, r.time_ms, e.max_t, e.max_r_deg);
  }
}

// 5% gross outliers (20-60 px): the ORB-SLAM scheme flags them and the
// result stays as accurate as without the outliers (same problem, same
// inlier noise, same scheme).
TEST(Backends, GrossOutliersAreRejected) {
  for (const char* name : {"dslam::CeresBackend", "dslam::SchurBackend"}) {
    SCOPED_TRACE(name);
    for (bool stereo : {false, true}) {
      SynthBAConfig c;
      c.stereo = stereo;
      c.fixed_keyframes = stereo ? 1 : 2;
      auto clean = makeBA(c);
      ASSERT_TRUE(make(name)->bundleAdjust(clean.problem, BAOptions{}).success);
      const PoseErr clean_err = poseDiff(poses(clean.problem), clean.true_T_cw);
      c.outlier_ratio = 0.05;
      auto s = makeBA(c);
      const BAResult r = make(name)->bundleAdjust(s.problem, BAOptions{});
      ASSERT_TRUE(r.success) << r.message;
      int injected = 0, caught = 0, false_pos = 0;
      for (size_t i = 0; i < s.is_outlier.size(); i++) {
        injected += s.is_outlier[i];
        caught += s.is_outlier[i] && s.problem.observations[i].outlier;
        false_pos += !s.is_outlier[i] && s.problem.observations[i].outlier;
      }
      ASSERT_GT(injected, 300);
      EXPECT_GE(caught, 0.9 * injected) << "stereo=" << stereo;
      EXPECT_LT(false_pos, 0.08 * (s.is_outlier.size() - injected)) << "stereo=" << stereo;
      EXPECT_EQ(r.num_outliers, caught + false_pos);
      const PoseErr d = poseDiff(poses(s.problem), poses(clean.problem));
      const PoseErr err = poseDiff(poses(s.problem), s.true_T_cw);
      // the chi2 test also drops a few different borderline inliers: noise-level differences
      EXPECT_LT(d.max_t, 4e-3) << "stereo=" << stereo;
      EXPECT_LT(d.max_r_deg, 0.03) << "stereo=" << stereo;
      EXPECT_LT(err.max_t, 1.2 * clean_err.max_t + 1e-3) << "stereo=" << stereo;
      std::printf("%s %s, 5%% outliers: %d injected, %d caught, %d inliers flagged; pose diff to the clean run %.2g m "
                  "%.2g deg; max error to truth %.2g m (clean run %.2g m)\n",
                  name, stereo ? "stereo" : "mono", injected, caught, false_pos, d.max_t, d.max_r_deg, err.max_t,
                  clean_err.max_t);
    }
  }
}

// Without outlier rejection, the same outliers pull the estimate away from
// the clean solution: the rejection test above is not trivially satisfied.
TEST(Backends, OutliersHurtWithoutRejection) {
  SynthBAConfig c;
  c.stereo = true;
  c.fixed_keyframes = 1;
  auto clean = makeBA(c);
  ASSERT_TRUE(make("dslam::CeresBackend")->bundleAdjust(clean.problem, leastSquares(30)).success);
  c.outlier_ratio = 0.05;
  auto s = makeBA(c);
  const BAResult r = make("dslam::CeresBackend")->bundleAdjust(s.problem, leastSquares(30));
  ASSERT_TRUE(r.success);
  EXPECT_EQ(r.num_outliers, 0);
  EXPECT_GT(poseDiff(poses(s.problem), poses(clean.problem)).max_t, 5e-3);
}

TEST(Backends, FixedKeyframesAndPointsStayBitIdentical) {
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend", "dslam::SchurBackend"}) {
    SynthBAConfig c;
    c.fixed_keyframes = 3;
    c.fixed_points = 50;
    c.outlier_ratio = 0.02;
    auto s = makeBA(c);
    // fixed ones that are not among the first ones
    s.problem.keyframes[5].fixed = true;
    s.problem.points[500].fixed = true;
    const BAProblem before = s.problem;
    const BAResult r = make(name)->bundleAdjust(s.problem, BAOptions{});
    ASSERT_TRUE(r.success) << name << ": " << r.message;
    EXPECT_LT(r.final_cost, 0.1 * r.initial_cost) << name;
    int changed_free = 0;
    for (size_t i = 0; i < before.keyframes.size(); i++) {
      if (before.keyframes[i].fixed)
        EXPECT_TRUE(sameBits(before.keyframes[i].T_cw, s.problem.keyframes[i].T_cw)) << name << " kf " << i;
      else
        changed_free += !sameBits(before.keyframes[i].T_cw, s.problem.keyframes[i].T_cw);
    }
    EXPECT_EQ(changed_free, 6) << name;
    for (size_t i = 0; i < before.points.size(); i++) {
      if (before.points[i].fixed) {
        EXPECT_EQ(std::memcmp(before.points[i].X_w.data(), s.problem.points[i].X_w.data(), 3 * sizeof(double)), 0)
            << name << " point " << i;
      }
    }
    EXPECT_NE(before.points[600].X_w, s.problem.points[600].X_w) << name;
  }
}

// No fixed keyframe at all: every keyframe is optimised (MRPT gets a dummy
// fixed frame); the cost still drops to the noise floor.
TEST(Backends, NoFixedKeyframe) {
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend", "dslam::SchurBackend"}) {
    SynthBAConfig c;
    c.fixed_keyframes = 0;
    c.stereo = true;
    auto s = makeBA(c);
    const BAOptions o = leastSquares(30);
    const double truth = costAtTruth(s, o);
    const SE3 kf0 = s.problem.keyframes[0].T_cw;
    const BAResult r = make(name)->bundleAdjust(s.problem, o);
    ASSERT_TRUE(r.success) << name << ": " << r.message;
    EXPECT_LT(r.final_cost, 1.05 * truth) << name;
    EXPECT_FALSE(sameBits(kf0, s.problem.keyframes[0].T_cw)) << name;
  }
}

TEST(Backends, ObservationsFlaggedOnInputAreIgnored) {
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend", "dslam::SchurBackend"}) {
    SynthBAConfig c;
    c.outlier_ratio = 0.05;
    auto s = makeBA(c);
    for (size_t i = 0; i < s.is_outlier.size(); i++) s.problem.observations[i].outlier = s.is_outlier[i];
    const BAResult r = make(name)->bundleAdjust(s.problem, leastSquares(30));
    ASSERT_TRUE(r.success) << name;
    for (size_t i = 0; i < s.is_outlier.size(); i++) {
      if (s.is_outlier[i]) {
        ASSERT_TRUE(s.problem.observations[i].outlier);
      }
    }
    EXPECT_LT(poseDiff(poses(s.problem), s.true_T_cw).max_t, 0.01) << name;
  }
}

// Loop of 30 poses, odometry drift, one loop closure: both backends reduce
// the cost and the error to the ground truth; node 0 (fixed) does not move.
TEST(Backends, PoseGraphLoopClosure) {
  const auto s0 = makePoseGraph(30);
  auto meanErr = [&](const PoseGraph& g) {
    double m = 0;
    for (size_t i = 0; i < g.nodes.size(); i++)
      m += (g.nodes[i].T_wc.translation() - s0.true_T_wc[i].translation()).norm();
    return m / g.nodes.size();
  };
  const double err0 = meanErr(s0.graph);
  ASSERT_GT(err0, 0.1);  // the odometry drifted
  std::vector<PoseGraph> out;
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend"}) {
    PoseGraph g = s0.graph;
    const PoseGraphResult r = make(name)->optimizePoseGraph(g, PoseGraphOptions{});
    ASSERT_TRUE(r.success) << name << ": " << r.message;
    EXPECT_NEAR(r.initial_cost, evaluateCost(s0.graph), 1e-9 * r.initial_cost);
    EXPECT_LT(r.final_cost, 0.05 * r.initial_cost) << name;
    // 30 edges x 6 dof, 29 x 6 free: chi2 with 6 dof expected; far below the start
    EXPECT_LT(r.final_cost, 30.0) << name;
    EXPECT_GT(r.iterations, 0);
    EXPECT_LT(meanErr(g), 0.5 * err0) << name;
    std::printf("%s pose graph: cost %.1f -> %.3f in %d it, mean position error %.3f -> %.3f m\n", name,
                r.initial_cost, r.final_cost, r.iterations, err0, meanErr(g));
    EXPECT_TRUE(sameBits(g.nodes[0].T_wc, s0.graph.nodes[0].T_wc)) << name;
    out.push_back(g);
  }
  // both reach nearly the same solution (MRPT's residual is a pseudo-log and
  // its stop criteria differ; the single loop leaves flat directions)
  EXPECT_NEAR(evaluateCost(out[0]), evaluateCost(out[1]), 0.01 * evaluateCost(out[0]));
  for (size_t i = 0; i < out[0].nodes.size(); i++)
    EXPECT_LT((out[0].nodes[i].T_wc.translation() - out[1].nodes[i].T_wc.translation()).norm(), 0.02) << i;
}

TEST(Backends, PoseGraphExtraFixedNodes) {
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend"}) {
    auto s = makePoseGraph(20);
    s.graph.nodes[10].fixed = true;
    s.graph.nodes[10].T_wc = s.true_T_wc[10];
    const PoseGraph before = s.graph;
    const PoseGraphResult r = make(name)->optimizePoseGraph(s.graph, PoseGraphOptions{});
    ASSERT_TRUE(r.success) << name;
    EXPECT_LT(r.final_cost, r.initial_cost) << name;
    EXPECT_TRUE(sameBits(s.graph.nodes[10].T_wc, before.nodes[10].T_wc)) << name;
    EXPECT_TRUE(sameBits(s.graph.nodes[0].T_wc, before.nodes[0].T_wc)) << name;
    EXPECT_FALSE(sameBits(s.graph.nodes[5].T_wc, before.nodes[5].T_wc)) << name;
  }
}

// BAOptions::abort (parallel local mapping: a new keyframe arrived) and
// BAOptions::deadline (its ba_max_ms): the pass running stops at its next
// iteration with its best estimate so far, no second pass runs, and the
// result says it was aborted. A flag never set and a deadline far ahead
// change nothing (same iterations and result as without). Both backends.
TEST(Backends, AbortFlagOrPassedDeadlineStopsTheOptimisationEarly) {
  SynthBAConfig c;
  c.stereo = true;
  c.fixed_keyframes = 1;
  c.pixel_sigma = 1;
  for (const char* name : {"dslam::CeresBackend", "dslam::MrptBackend", "dslam::SchurBackend"}) {
    SCOPED_TRACE(name);
    auto plain = makeBA(c), full = plain;
    const BAResult rp = make(name)->bundleAdjust(plain.problem, BAOptions{});  // ORB-SLAM scheme: 2 passes
    ASSERT_TRUE(rp.success) << rp.message;
    BAOptions o;
    std::atomic<bool> never{false}, now{true};
    o.abort = &never;
    o.deadline = nowSeconds() + 3600;
    const BAResult rf = make(name)->bundleAdjust(full.problem, o);
    ASSERT_TRUE(rf.success) << rf.message;
    EXPECT_FALSE(rf.aborted);
    EXPECT_EQ(rf.iterations, rp.iterations);
    EXPECT_TRUE(sameBits(full.problem.keyframes[3].T_cw, plain.problem.keyframes[3].T_cw));
    for (const bool by_deadline : {false, true}) {
      SCOPED_TRACE(by_deadline ? "deadline" : "abort flag");
      auto stopped = makeBA(c);
      BAOptions so;
      if (by_deadline)
        so.deadline = nowSeconds() - 1;
      else
        so.abort = &now;
      const BAResult ra = make(name)->bundleAdjust(stopped.problem, so);
      ASSERT_TRUE(ra.success) << ra.message;
      EXPECT_TRUE(ra.aborted);
      EXPECT_LT(ra.iterations, rf.iterations);
      if (std::string(name) != "dslam::MrptBackend") {
        EXPECT_LE(ra.iterations, 1);  // stops after its first iteration
      }
      EXPECT_LT(ra.final_cost, ra.initial_cost);  // what it did is kept, and is an improvement
    }
  }
}
