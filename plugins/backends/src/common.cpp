#include "common.h"

#include <cmath>

#include <Eigen/Cholesky>

#include "dslam/core/error.h"
#include "dslam/core/timing.h"

namespace dslam::backends {

std::vector<ParamSpec> CommonSettings::specs(int first_pass_default) {
  return {
      P_int("max_iterations", 10,
            "iterations per optimisation pass; if written here, overrides the caller's BAOptions::max_iterations",
            1, 10000),
      P_int("pose_graph_iterations", 20,
            "pose-graph iterations; if written here, overrides the caller's PoseGraphOptions::max_iterations", 1,
            10000),
      P_bool("verbose", false, "print the optimiser's progress; if written here, overrides the caller's option"),
      P_int("first_pass_iterations", first_pass_default,
            "iterations of the robust first pass before the chi2 outlier test (ORB-SLAM: 5)", 1, 1000),
      P_double("chi2_mono", 5.991, "chi2 threshold of monocular observations (2 dof, 95%; ORB-SLAM)", 0.0),
      P_double("chi2_stereo", 7.815, "chi2 threshold of stereo / RGB-D observations (3 dof, 95%; ORB-SLAM)", 0.0),
  };
}

void CommonSettings::read(const Params& p) {
  max_iterations = static_cast<int>(p.getInt("max_iterations"));
  max_iterations_given = p.isGiven("max_iterations");
  pose_graph_iterations = static_cast<int>(p.getInt("pose_graph_iterations"));
  pose_graph_iterations_given = p.isGiven("pose_graph_iterations");
  verbose = p.getBool("verbose");
  verbose_given = p.isGiven("verbose");
  first_pass_iterations = static_cast<int>(p.getInt("first_pass_iterations"));
  chi2_mono = p.getDouble("chi2_mono");
  chi2_stereo = p.getDouble("chi2_stereo");
}

BAOptions CommonSettings::apply(BAOptions o) const {
  if (max_iterations_given) o.max_iterations = max_iterations;
  if (verbose_given) o.verbose = verbose;
  return o;
}

PoseGraphOptions CommonSettings::apply(PoseGraphOptions o) const {
  if (pose_graph_iterations_given) o.max_iterations = pose_graph_iterations;
  if (verbose_given) o.verbose = verbose;
  return o;
}

static bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }
static bool finite(const SE3& T) { return T.translation().allFinite() && T.quaternion().coeffs().allFinite(); }

void validate(const BAProblem& p, const char* who) {
  const std::string w = std::string(who) + ": ";
  const auto& c = p.camera;
  if (!(c.fx > 0) || !(c.fy > 0) || !std::isfinite(c.cx) || !std::isfinite(c.cy) || !std::isfinite(c.bf))
    throw DataError(w + "invalid BA camera (fx=" + std::to_string(c.fx) + ", fy=" + std::to_string(c.fy) +
                    "): fx, fy must be > 0 and every intrinsic finite");
  for (size_t i = 0; i < p.keyframes.size(); i++)
    if (!finite(p.keyframes[i].T_cw))
      throw DataError(w + "keyframe " + std::to_string(i) + " (id " + std::to_string(p.keyframes[i].id) +
                      ") has a non-finite pose");
  for (size_t i = 0; i < p.points.size(); i++)
    if (!finite(p.points[i].X_w))
      throw DataError(w + "point " + std::to_string(i) + " (id " + std::to_string(p.points[i].id) +
                      ") has a non-finite position");
  const int nk = static_cast<int>(p.keyframes.size()), np = static_cast<int>(p.points.size());
  for (size_t i = 0; i < p.observations.size(); i++) {
    const auto& o = p.observations[i];
    const std::string oi = w + "observation " + std::to_string(i);
    if (o.kf < 0 || o.kf >= nk)
      throw DataError(oi + ": keyframe index " + std::to_string(o.kf) + " out of range [0, " +
                      std::to_string(nk) + ")");
    if (o.pt < 0 || o.pt >= np)
      throw DataError(oi + ": point index " + std::to_string(o.pt) + " out of range [0, " + std::to_string(np) +
                      ")");
    if (!o.uv.allFinite() || !std::isfinite(o.u_right))
      throw DataError(oi + ": non-finite pixel coordinates");
    if (!(o.information > 0) || !std::isfinite(o.information))
      throw DataError(oi + ": information must be finite and > 0, got " + std::to_string(o.information));
    if (o.u_right >= 0 && !(c.bf > 0))
      throw DataError(oi + ": stereo observation (u_right >= 0) but the camera has no baseline (bf = 0)");
  }
}

void validate(const PoseGraph& g, const char* who) {
  const std::string w = std::string(who) + ": ";
  for (size_t i = 0; i < g.nodes.size(); i++)
    if (!finite(g.nodes[i].T_wc))
      throw DataError(w + "pose-graph node " + std::to_string(i) + " (id " + std::to_string(g.nodes[i].id) +
                      ") has a non-finite pose");
  const int n = static_cast<int>(g.nodes.size());
  for (size_t i = 0; i < g.edges.size(); i++) {
    const auto& e = g.edges[i];
    const std::string ei = w + "pose-graph edge " + std::to_string(i);
    if (e.from < 0 || e.from >= n || e.to < 0 || e.to >= n)
      throw DataError(ei + ": node index (" + std::to_string(e.from) + " -> " + std::to_string(e.to) +
                      ") out of range [0, " + std::to_string(n) + ")");
    if (e.from == e.to) throw DataError(ei + ": connects node " + std::to_string(e.from) + " to itself");
    if (!finite(e.T_from_to) || !e.information.allFinite())
      throw DataError(ei + ": non-finite measurement or information");
    const Eigen::Matrix<double, 6, 6> S = 0.5 * (e.information + e.information.transpose());
    if ((e.information - S).norm() > 1e-9 * (1 + S.norm()) || S.llt().info() != Eigen::Success)
      throw DataError(ei + ": information matrix must be symmetric positive definite");
  }
}

double observationChi2(const BAProblem& p, const BAObservation& o, bool* depth_ok) {
  const Eigen::Vector3d Xc = p.keyframes[o.kf].T_cw * p.points[o.pt].X_w;
  if (depth_ok) *depth_ok = Xc.z() > 0;
  const double iz = 1.0 / Xc.z();
  const double u = p.camera.fx * Xc.x() * iz + p.camera.cx;
  const double v = p.camera.fy * Xc.y() * iz + p.camera.cy;
  double s = (u - o.uv.x()) * (u - o.uv.x()) + (v - o.uv.y()) * (v - o.uv.y());
  if (o.u_right >= 0) {
    const double ur = u - p.camera.bf * iz;
    s += (ur - o.u_right) * (ur - o.u_right);
  }
  return o.information * s;
}

int markOutliers(BAProblem& p, const CommonSettings& s) {
  int n = 0;
  for (auto& o : p.observations) {
    if (o.outlier) continue;
    bool depth_ok = true;
    const double chi2 = observationChi2(p, o, &depth_ok);
    const double thr = o.u_right >= 0 ? s.chi2_stereo : s.chi2_mono;
    if (!(chi2 <= thr) || !depth_ok) {
      o.outlier = true;
      n++;
    }
  }
  return n;
}

double elapsedMs(double t0) { return (nowSeconds() - t0) * 1e3; }

void finishResult(BAResult& res, const BAProblem& p, const BAOptions& opt, const std::string& log, double t0) {
  res.final_cost = evaluateCost(p, opt);
  res.aborted = abortRequested(opt);
  res.message = log;
  if (res.message.size() >= 2) res.message.resize(res.message.size() - 2);
  res.time_ms = elapsedMs(t0);
}

}  // namespace dslam::backends
