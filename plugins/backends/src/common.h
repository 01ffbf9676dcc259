#pragma once
// Helpers shared by the backends (internal to plugins/backends).
#include <string>
#include <vector>

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
