#pragma once
/** \file dnn_semantic.h
 *  Semantic segmentation through OpenCV DNN (default: ENet Cityscapes). */
#include <string>
#include <vector>

#include <opencv2/dnn/dnn.hpp>

#include "dslam/core/detector.h"

namespace dslam {

/** Runs a segmentation network whose output is [1, K, H, W] class scores,
 *  takes the per-pixel argmax, maps the K model labels to COCO ids
 *  (`class_map`, by label name; unmapped -> 255) and resizes the label
 *  image to the frame (nearest). Optionally derives one box per connected
 *  component of each thing class (`boxes`). Default model: ENet trained on
 *  Cityscapes (20 labels, 1024x512, scale 1/255, swapRB). */
class DnnSemanticSegmenter : public Detector {
  DEFINE_MRPT_OBJECT(DnnSemanticSegmenter, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  Detections detect(const SensorFrame& frame) override;
  unsigned outputs() const override { return kSemantic | (boxes_ ? kBoxes : 0u); }

  const std::vector<std::string>& labels() const { return labels_; }
  /** COCO id (or 255) of each model label. */
  const std::vector<uint8_t>& labelToCoco() const { return lut_; }

 private:
  cv::dnn::Net net_;
  std::string out_name_;
  std::vector<std::string> labels_;
  std::vector<uint8_t> lut_;
  cv::Size input_{1024, 512};
  double scale_ = 1.0 / 255.0;
  cv::Scalar mean_;
  bool swap_rb_ = true, boxes_ = true;
  int min_box_area_ = 100;
};

}  // namespace dslam
