#pragma once
/** \file schur_backend.h
 *  dslam::SchurBackend: bundle adjustment by Levenberg-Marquardt on the
 *  Schur complement with fixed-size blocks (Eigen, as g2o does), pose graph
 *  by CeresBackend. */
#include <memory>
#include <string>
#include <vector>

#include "dslam/plugins/backends/ceres_backend.h"

namespace dslam {

/** Bundle adjustment for local mapping's problem sizes.
 *
 *  The same model as CeresBackend (backend.h: residual [u, v] or [u, v,
 *  u_right] weighted by sqrt(information), Huber kernel, poses T_cw updated
 *  on the left by exp(delta)) and the same ORB-SLAM outlier scheme; only the
 *  solver differs. Each Levenberg-Marquardt iteration linearises every
 *  observation once (2x6 / 3x6 pose and 2x3 / 3x3 point Jacobians, the
 *  Huber kernel as iteratively reweighted least squares, as Ceres does for
 *  it), eliminates the points with 3x3 blocks and solves the reduced camera
 *  system densely (Cholesky of 6 x free keyframes rows). Ceres' generic
 *  Schur eliminator handles the mix of 2- and 3-row residuals with
 *  dynamic-size blocks; the fixed sizes here make an iteration several
 *  times cheaper (docs/backends.md).
 *
 *  Damping: diag(H) scaled by lambda (Marquardt), lambda starting at
 *  `initial_lambda`, updated with Nielsen's rule on the gain ratio; a step
 *  counts as one iteration whether accepted or not (as in Ceres). Stops at
 *  the iteration limit, when an accepted step lowers the cost by less than
 *  `function_tolerance` relative, or on BAOptions::abort / deadline.
 *  Deterministic (one thread, fixed order).
 *
 *  Problems with more than `dense_max_keyframes` free keyframes (global BA
 *  of a large map) go to CeresBackend's sparse Schur solver. The pose graph
 *  is CeresBackend's. */
class SchurBackend : public CeresBackend {
  DEFINE_MRPT_OBJECT(SchurBackend, dslam)
 public:
  SchurBackend();
  ~SchurBackend() override;
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;

  BAResult bundleAdjust(BAProblem& problem, const BAOptions& opt) override;

  struct SchurSettings;

 private:
  std::shared_ptr<const SchurSettings> ss_;  // immutable once configured; shared by clones
};

}  // namespace dslam
