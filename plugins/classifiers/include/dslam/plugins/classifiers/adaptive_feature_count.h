#pragma once
/** \file adaptive_feature_count.h
 *  Crowd-SLAM's adaptive ORB feature count. */
#include <string>
#include <vector>

#include "dslam/core/keypoint_classifier.h"

namespace dslam {

/** Raises the ORB feature count of the next frame with the image area
 *  filtered out by boxes of dynamic classes (Crowd-SLAM, Soares et al.
 *  2021; public code Tracking::FeatureNumberUpdate). Labels nothing.
 *
 *  Filtered area = union (or, `area: sum`, the plain sum as in the public
 *  code) of the boxes of `classes`, clipped to the image, as a fraction of
 *  the image. The increment is the entry of the largest threshold <= area
 *  (none when the area is 0):
 *  - `mode: paper`: +300 at 30 %, +500 at 60 %, +700 at 90 %, +1200 at 95 %
 *    and above (paper values);
 *  - `mode: percent`: the public code's table, a percentage of the base
 *    count: +30 % for any area > 0, +50 % from 30 %, +70 % from 60 %,
 *    +90 % from 90 %, +120 % from 95 %.
 *  requestedFeatureCount() = ctx.base_feature_count + increment, or 0 (no
 *  request) when the increment is 0. */
class AdaptiveFeatureCount : public KeypointClassifier {
  DEFINE_MRPT_OBJECT(AdaptiveFeatureCount, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) override;
  int requestedFeatureCount() const override { return increment_ > 0 ? base_ + increment_ : 0; }
  bool labelsKeypoints() const override { return false; }  ///< feature count only
  void reset() override;

  /** Filtered area fraction of the last classified frame. */
  double lastArea() const { return area_; }
  /** Feature-count increment for the next frame (0 = none). */
  int increment() const { return increment_; }
  /** Increment for a filtered-area fraction and base count (the table). */
  int incrementFor(double area, int base) const;

 private:
  bool percent_ = false, sum_ = false;
  std::vector<int> classes_{1};
  double min_score_ = 0;
  std::vector<double> thresholds_, values_;
  double area_ = 0;
  int base_ = 1000, increment_ = 0;
};

/** Area (pixels) of the union of boxes clipped to `image` (exact, by
 *  coordinate compression). */
double boxUnionArea(const std::vector<cv::Rect2f>& boxes, cv::Size image);

}  // namespace dslam
