#pragma once
/** \file semantic_filter.h
 *  A-priori removal of keypoints on pixels of dynamic classes (semantic or
 *  panoptic labels). */
#include <string>
#include <vector>

#include "dslam/core/keypoint_classifier.h"

namespace dslam {

/** Keypoints whose pixel (optionally within `dilation` pixels) carries a
 *  class of `classes` are labelled Dynamic, reason SemanticDynamic
 *  (DeepLabV3+ SLAM and STDyn-SLAM remove people a priori from the
 *  segmentation) or GroundTruth when `ground_truth: true` (use with
 *  dslam::GroundTruthDetector for "people masked by ground-truth labels").
 *  Reads Detections::semantic (COCO id per pixel, 255 = none) or, with
 *  `source: panoptic` / no semantic image, the panoptic segments' category.
 *  Sets class_id of every keypoint that lies on a labelled pixel, and
 *  object_id from panoptic thing instances. */
class SemanticFilter : public KeypointClassifier {
  DEFINE_MRPT_OBJECT(SemanticFilter, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) override;
  bool relabelsKeyFrames() const override { return true; }  ///< labels from the detection alone

 private:
  std::vector<int> classes_{1};
  int dilation_ = 0;
  std::string source_ = "auto";
  bool ground_truth_ = false;
};

}  // namespace dslam
