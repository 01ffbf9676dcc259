#pragma once
/** \file backend.h
 *  Optimisation backends: bundle adjustment and pose-graph optimisation.
 *
 *  Cost convention shared by every backend (so results compare): for each
 *  observation the residual e is the reprojection error in pixels, [u, v]
 *  for monocular observations and [u, v, u_right] for stereo / RGB-D ones
 *  (u_right = u - bf / z); its squared Mahalanobis norm is
 *  s = information * |e|^2 and the total cost is sum rho(s) with the Huber
 *  kernel on s (rho(s) = s if s <= d^2, else 2 d sqrt(s) - d^2), d =
 *  huber_mono or huber_stereo. This equals g2o's chi2 and twice Ceres'
 *  HuberLoss cost. evaluateCost() computes it. */
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dslam/core/plugin.h"
#include "dslam/core/se3.h"

namespace dslam {

struct BACamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double bf = 0;  ///< baseline * fx (stereo / RGB-D), 0 if monocular
};

struct BAKeyframe {
  int64_t id = -1;
  SE3 T_cw;  ///< world-to-camera
  bool fixed = false;
};

struct BAPoint {
  int64_t id = -1;
  Eigen::Vector3d X_w = Eigen::Vector3d::Zero();
  bool fixed = false;
};

struct BAObservation {
  int kf = -1;             ///< index into BAProblem::keyframes
  int pt = -1;             ///< index into BAProblem::points
  Eigen::Vector2d uv{0, 0};  ///< undistorted pixel
  double u_right = -1;     ///< right-image x (stereo / RGB-D), < 0 = monocular
  double information = 1;  ///< 1 / sigma^2 of the keypoint's pyramid level
  bool outlier = false;    ///< output: rejected by the chi2 test
};

struct BAProblem {
  BACamera camera;
  std::vector<BAKeyframe> keyframes;
  std::vector<BAPoint> points;
  std::vector<BAObservation> observations;
};

struct BAOptions {
  int max_iterations = 10;          ///< per pass
  bool robust = true;               ///< Huber kernel
  double huber_mono = 2.447651936;  ///< sqrt(5.991), chi2 95% with 2 dof
  double huber_stereo = 2.795084972;///< sqrt(7.815), chi2 95% with 3 dof
  bool reject_outliers = true;      ///< ORB-SLAM: optimise 5 it, drop chi2 outliers, optimise again
  int num_threads = 1;
  bool verbose = false;
  /** Stop request, read between solver iterations (parallel local mapping
   *  sets it when a new keyframe arrives, as ORB-SLAM's mbAbortBA): the pass
   *  running ends with its best estimate so far and no further pass starts.
   *  nullptr = never stops early (sequential mode: results do not depend on
   *  timing). */
  const std::atomic<bool>* abort = nullptr;
  /** Wall-clock deadline (dslam::nowSeconds()), read like `abort`: a pass
   *  running then ends with its best estimate and no further pass starts.
   *  0 = none (sequential mode: results do not depend on timing). */
  double deadline = 0;
};

struct BAResult {
  bool success = false;
  double initial_cost = 0, final_cost = 0;  ///< evaluateCost() before / after
  int iterations = 0;
  int num_outliers = 0;
  bool aborted = false;  ///< stopped early by BAOptions::abort
  double time_ms = 0;
  std::string message;
};

struct PoseGraphNode {
  int64_t id = -1;
  SE3 T_wc;  ///< camera-to-world
  bool fixed = false;
};

struct PoseGraphEdge {
  int from = -1, to = -1;  ///< node indices
  SE3 T_from_to;           ///< measured T_wc(from)^-1 * T_wc(to)
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

struct PoseGraph {
  std::vector<PoseGraphNode> nodes;
  std::vector<PoseGraphEdge> edges;
};

struct PoseGraphOptions {
  int max_iterations = 20;
  bool verbose = false;
};

struct PoseGraphResult {
  bool success = false;
  double initial_cost = 0, final_cost = 0;  ///< sum of r^T I r, r = log(T_ij_meas^-1 T_i^-1 T_j)
  int iterations = 0;
  double time_ms = 0;
  std::string message;
};

class Backend : public Plugin {
  DEFINE_VIRTUAL_MRPT_OBJECT(Backend)
 public:
  const char* interfaceName() const override { return "Backend"; }
  /** Optimises non-fixed keyframe poses and points in place; marks outlier
   *  observations. */
  virtual BAResult bundleAdjust(BAProblem& problem, const BAOptions& opt) = 0;
  /** Optimises non-fixed node poses in place. */
  virtual PoseGraphResult optimizePoseGraph(PoseGraph& graph, const PoseGraphOptions& opt) = 0;
};

/** rho(s) of the cost convention above: the Huber kernel on the squared
 *  norm s with threshold d. */
double huberCost(double s, double d);
/** Cost of a BA problem under the convention above (outlier-flagged
 *  observations excluded). */
double evaluateCost(const BAProblem& p, const BAOptions& opt);
/** Pose-graph cost as defined in PoseGraphResult. */
double evaluateCost(const PoseGraph& g);

}  // namespace dslam
