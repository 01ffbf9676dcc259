#pragma once
/** \file pose_optimizer.h
 *  Pose-only optimisation of a frame against its matched map points
 *  (ORB-SLAM2 Optimizer::PoseOptimization): Gauss-Newton with a Huber
 *  kernel on [u, v] (monocular) or [u, v, u_right] (stereo / RGB-D)
 *  residuals weighted by the keypoint level's 1/sigma^2; four rounds of
 *  optimisation with chi2 outlier classification (5.991 / 7.815), the
 *  robust kernel dropped in the last rounds. Hand-written: ~0.2 ms for
 *  500 matches, far below a general solver's overhead. */
#include <vector>

#include <Eigen/Core>

#include "dslam/core/se3.h"

namespace dslam {

struct PoseObservation {
  Eigen::Vector3d Xw;       ///< map point (world)
  Eigen::Vector2d uv;       ///< undistorted keypoint
  double u_right = -1;      ///< < 0: monocular
  double information = 1;   ///< 1 / sigma^2 of the keypoint's level
};

struct PoseOptimizerParams {
  double fx = 0, fy = 0, cx = 0, cy = 0, bf = 0;
  double chi2_mono = 5.991, chi2_stereo = 7.815;
  int rounds = 4;
  int iterations = 10;
};

struct PoseOptimizerResult {
  int inliers = 0;
  double final_chi2 = 0;  ///< sum over inliers
};

/** Optimises T_cw in place; `outlier` (same size as obs) receives the
 *  classification of the last round. */
PoseOptimizerResult optimizePose(SE3& T_cw, const std::vector<PoseObservation>& obs, std::vector<char>& outlier,
                                 const PoseOptimizerParams& p);

/** Covariance of a pose estimated from `obs` (the ones not flagged in
 *  `outlier`, which may be empty): the inverse of the Gauss-Newton
 *  information sum_i J_i^T w_i J_i at T_cw, for keypoint noise of one pixel
 *  at level 0 (w_i = obs[i].information). Order [rho; phi] of the left
 *  perturbation exp(delta) * T_cw, so the top-left 3x3 block is the
 *  covariance of the camera position in the camera's axes. Zero when the
 *  information is singular (fewer than 3 observations in front). */
Eigen::Matrix<double, 6, 6> poseCovariance(const SE3& T_cw, const std::vector<PoseObservation>& obs,
                                           const std::vector<char>& outlier, const PoseOptimizerParams& p);

/** optimizePose, with the observations flagged `young` (map points made
 *  moments ago) checked against the others first: when at least
 *  `min_older` older observations remain inliers of a pose optimised on
 *  them alone, the young ones that do not fit that pose (chi2 test) are
 *  outliers, and the pose is optimised again on the older ones and the
 *  young ones that fit. Otherwise (too few older ones) it is
 *  optimizePose(). Points of a mover that a keyframe mapped (a box that
 *  lagged behind a walking person) are young, and where they outnumber the
 *  background they would otherwise carry the pose with them. `checked`
 *  (optional) tells whether the older-first path was taken. */
PoseOptimizerResult optimizePoseOlderFirst(SE3& T_cw, const std::vector<PoseObservation>& obs,
                                          const std::vector<char>& young, int min_older, std::vector<char>& outlier,
                                          const PoseOptimizerParams& p, bool* checked = nullptr);

}  // namespace dslam
