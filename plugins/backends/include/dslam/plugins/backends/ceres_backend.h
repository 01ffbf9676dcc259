#pragma once
/** \file ceres_backend.h
 *  dslam::CeresBackend: bundle adjustment and SE3 pose-graph optimisation
 *  with Ceres Solver (the default backend). Ceres stays out of this header. */
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/backend.h"

namespace dslam {

/** Ceres Solver backend.
 *
 *  Bundle adjustment: keyframe poses T_cw (quaternion + translation, updated
 *  on the left by exp(delta), delta = [rho; phi] in se(3)) and 3D points,
 *  analytic Jacobians; monocular residual [u, v], stereo / RGB-D residual
 *  [u, v, u_right] weighted by sqrt(information); Huber loss; Schur
 *  complement (dense for few keyframes, sparse with SuiteSparse otherwise).
 *  With BAOptions::reject_outliers it follows ORB-SLAM2's local BA: a robust
 *  first pass of `first_pass_iterations`, the chi2 test (chi2_mono /
 *  chi2_stereo, point in front of the camera), a second pass of
 *  max_iterations without the flagged observations and without robust
 *  kernel, then the chi2 test again. Observations flagged as outliers on
 *  input are ignored and stay flagged.
 *
 *  Pose graph: residual r = log(T_ij_meas^-1 T_i^-1 T_j) (se(3), [rho; phi]),
 *  weighted by the Cholesky factor of the edge information, automatic
 *  differentiation, fixed nodes held constant. */
class CeresBackend : public Backend {
  DEFINE_MRPT_OBJECT(CeresBackend, dslam)
 public:
  CeresBackend();
  ~CeresBackend() override;
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;

  BAResult bundleAdjust(BAProblem& problem, const BAOptions& opt) override;
  PoseGraphResult optimizePoseGraph(PoseGraph& graph, const PoseGraphOptions& opt) override;

  struct Settings;  ///< parsed parameters (defined in the .cpp)

 private:
  std::shared_ptr<const Settings> s_;  // immutable once configured; shared by clones
};

}  // namespace dslam
