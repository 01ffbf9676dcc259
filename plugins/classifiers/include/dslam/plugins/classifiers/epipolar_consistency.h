#pragma once
/** \file epipolar_consistency.h
 *  Moving-consistency check against the epipolar geometry of the static
 *  scene (DS-SLAM / STDyn-SLAM / DeepLabV3+ SLAM / Panoptic-SLAM). */
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/keypoint_classifier.h"

namespace dslam {

/** Correspondences from the previous frame (pyramidal Lucas-Kanade flow of
 *  the current keypoints back into the previous grey image, or ORB
 *  descriptor matching against the previous keypoints), a fundamental
 *  matrix by RANSAC from correspondences outside dynamic regions, then
 *  keypoints of the chosen regions farther than `threshold` pixels from
 *  their epipolar line are labelled Dynamic (EpipolarOutlier).
 *
 *  Defaults follow DS-SLAM's moving consistency check, which STDyn-SLAM
 *  and the DeepLabV3+ SLAM of Mahmoud et al. reuse (public code
 *  Frame::ProcessMovingObject): LK window 22, 5 pyramid levels, 3x3 patch
 *  check 2120, image-edge margin 5 px, findFundamentalMat(FM_RANSAC, 0.1,
 *  0.99), outlier beyond 1 px.
 *
 *  Fit set: keypoints not already Dynamic, not inside boxes / masks of
 *  `exclude_classes`, and not in the tested region (unless `apply_to:
 *  all`). Tested region (`apply_to`): `things` (panoptic thing segments;
 *  else semantic thing classes; else inside any box), `unknown` (panoptic
 *  void / unknown segments; else semantic 255), `boxes` (inside any box),
 *  `all`. `drop_unmatched_unknown` also drops unknown-region keypoints
 *  without a correspondence (Panoptic-SLAM). Never lowers a label.
 *  Geometry uses undistorted coordinates; region tests use raw pixels. */
class EpipolarConsistency : public KeypointClassifier {
  DEFINE_MRPT_OBJECT(EpipolarConsistency, dslam)
 public:
  struct Stats {
    bool fitted = false;  ///< a fundamental matrix was estimated
    int fit_matches = 0, fit_inliers = 0;
    int tested = 0, matched = 0, outliers = 0, unmatched_dropped = 0;
  };

  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) override;
  void reset() override;

  const Stats& lastStats() const { return stats_; }
  /** Fundamental matrix of the last frame (previous -> current pixels,
   *  x_cur^T F x_prev = 0); meaningful when lastStats().fitted. */
  const cv::Matx33d& lastFundamental() const { return F_; }

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
  Stats stats_;
  cv::Matx33d F_ = cv::Matx33d::zeros();
};

}  // namespace dslam
