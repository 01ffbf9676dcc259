#pragma once
/** \file box_filter.h
 *  Crowd-SLAM's box filter: keypoints inside boxes of dynamic classes are
 *  dropped. */
#include <string>
#include <vector>

#include "dslam/core/keypoint_classifier.h"

namespace dslam {

/** Labels Dynamic (reason InDynamicBox) every keypoint inside a box of a
 *  class listed in `classes` (Crowd-SLAM, Soares et al. 2021: features inside
 *  person boxes are removed; public code Frame::RemoveOutliers). Never lowers
 *  a label set earlier in the chain. Tests use distorted pixel coordinates
 *  (Frame::keypoints), the frame the boxes are in. */
class BoxFilter : public KeypointClassifier {
  DEFINE_MRPT_OBJECT(BoxFilter, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) override;
  bool relabelsKeyFrames() const override { return true; }  ///< labels from the detection alone

 private:
  std::vector<int> classes_{1};
  float margin_ = 0.f;
  double min_score_ = 0;
  float age_margin_ = 0.03f;
};

}  // namespace dslam
