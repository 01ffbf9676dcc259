#pragma once
// Helpers shared by the backends (internal to plugins/backends).
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dslam/core/backend.h"
#include "dslam/core/timing.h"
#include "dslam/core/params.h"

namespace dslam::backends {

/** Settings common to every backend, read from the plugin parameters.
 *  `*_given` = the parameter was written in the YAML and overrides the
 *  matching BAOptions / PoseGraphOptions field of every call. */
struct CommonSettings {
  int max_iterations = 10;
  bool max_iterations_given = false;
  int pose_graph_iterations = 20;
  bool pose_graph_iterations_given = false;
  bool verbose = false;
  bool verbose_given = false;
  int first_pass_iterations = 5;  ///< ORB-SLAM: 5 iterations before the chi2 test
  double chi2_mono = 5.991;       ///< chi2(2 dof, 95%)
  double chi2_stereo = 7.815;     ///< chi2(3 dof, 95%)

  /** `first_pass_default`: default of first_pass_iterations (ORB-SLAM: 5). */
  static std::vector<ParamSpec> specs(int first_pass_default = 5);
  void read(const Params& p);
  BAOptions apply(BAOptions o) const;
  PoseGraphOptions apply(PoseGraphOptions o) const;
};

/** Throws DataError naming the first invalid element (index out of range,
 *  non-finite value, stereo observation without bf, bad intrinsics). */
void validate(const BAProblem& p, const char* who);
void validate(const PoseGraph& g, const char* who);

/** Squared Mahalanobis norm s = information * |e|^2 of one observation at the
 *  current estimates (see backend.h); `depth_ok` = point in front of the camera. */
double observationChi2(const BAProblem& p, const BAObservation& o, bool* depth_ok = nullptr);

/** ORB-SLAM's test: flags (outlier = true) every not yet flagged observation
 *  with chi2 above the threshold of its kind or with the point behind the
 *  camera. Returns the number of observations newly flagged. */
int markOutliers(BAProblem& p, const CommonSettings& s);

/** Reprojection residual of observation `o` of the camera-frame point `Xc`,
 *  weighted by sqrt(information) (backend.h), into r[0..N): [u, v] for N =
 *  2, [u, v, u_right] for N = 3; with `Jc`, d(r)/d(Xc). The pose and point Jacobians
 *  follow from Jc: [Jc, -Jc [Xc]x] for T <- exp(delta) T, and Jc R. */
template <int N>
void reprojectionResidual(const BACamera& cam, const BAObservation& o, const Eigen::Vector3d& Xc, double* r,
                          Eigen::Matrix<double, N, 3>* Jc) {
  double z = Xc.z();
  if (std::abs(z) < 1e-12) z = z < 0 ? -1e-12 : 1e-12;  // keep finite; such points fail the depth test
  const double iz = 1.0 / z, iz2 = iz * iz;
  const double w = std::sqrt(o.information);
  const double u = cam.fx * Xc.x() * iz + cam.cx, v = cam.fy * Xc.y() * iz + cam.cy;
  r[0] = w * (u - o.uv.x());
  r[1] = w * (v - o.uv.y());
  if constexpr (N == 3) r[2] = w * (u - cam.bf * iz - o.u_right);
  if (!Jc) return;
  Jc->row(0) << cam.fx * iz, 0, -cam.fx * Xc.x() * iz2;
  Jc->row(1) << 0, cam.fy * iz, -cam.fy * Xc.y() * iz2;
  if constexpr (N == 3) Jc->row(2) << cam.fx * iz, 0, -cam.fx * Xc.x() * iz2 + cam.bf * iz2;
  *Jc *= w;
}

/** BAOptions::abort is set, or BAOptions::deadline has passed. */
inline bool abortRequested(const BAOptions& o) {
  return (o.abort && o.abort->load(std::memory_order_relaxed)) || (o.deadline > 0 && nowSeconds() >= o.deadline);
}

/** ORB-SLAM's outlier scheme around one optimisation pass
 *  `pass(iterations, robust) -> bool`: with opt.reject_outliers, a robust
 *  first pass of s.first_pass_iterations, the chi2 test, a second pass without
 *  the robust kernel and the test again (skipped when opt.abort is set or opt.deadline passed after
 *  the first); otherwise one pass. Adds the flagged
 *  observations to *num_outliers; returns whether every pass succeeded. */
template <class Pass>
bool optimizeWithOutlierRejection(BAProblem& p, const CommonSettings& s, const BAOptions& opt, Pass&& pass,
                                  int* num_outliers) {
  if (!opt.reject_outliers) return pass(opt.max_iterations, opt.robust);
  if (!pass(s.first_pass_iterations, opt.robust)) return false;
  *num_outliers += markOutliers(p, s);
  if (abortRequested(opt)) return true;  // ORB-SLAM: no second pass once stopped
  if (!pass(opt.max_iterations, false)) return false;
  *num_outliers += markOutliers(p, s);
  return true;
}

/** Fills the end of a BA result: final cost, the passes' log ("a; b; ",
 *  trailing separator dropped) and the time since `t0`. */
void finishResult(BAResult& res, const BAProblem& p, const BAOptions& opt, const std::string& log, double t0);

/** Milliseconds since `t0` (seconds from nowSeconds()). */
double elapsedMs(double t0);

}  // namespace dslam::backends
