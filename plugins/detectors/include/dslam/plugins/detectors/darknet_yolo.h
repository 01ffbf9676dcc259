#pragma once
/** \file darknet_yolo.h
 *  Darknet YOLO models (Yolo-Fastest, YOLOv3/v4-tiny, Crowd-SLAM's CYTI)
 *  through OpenCV DNN. */
#include <string>
#include <vector>

#include <opencv2/dnn/dnn.hpp>

#include "dslam/core/detector.h"

namespace dslam {

/** Darknet cfg + weights via cv::dnn::readNetFromDarknet. The image is
 *  resized (not letterboxed) to the network input, every unconnected output
 *  layer is decoded as YOLO rows [cx, cy, w, h, objectness, class scores]
 *  (det::decodeYoloRegion), then NMS. Model classes map to COCO ids through
 *  the class-names file (80 names = YOLO COCO order; other names by COCO
 *  name, "body"/"pedestrian"/"human" = person) or `class_ids`. Defaults
 *  (Crowd-SLAM): Yolo-Fastest body 320x320, confidence 0.2, NMS 0.1. */
class DarknetYoloDetector : public Detector {
  DEFINE_MRPT_OBJECT(DarknetYoloDetector, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  Detections detect(const SensorFrame& frame) override;
  unsigned outputs() const override { return kBoxes; }

  /** COCO id of each model class (index = model class). */
  const std::vector<int>& classIds() const { return class_ids_; }
  const std::vector<std::string>& outputLayers() const { return out_names_; }
  cv::Size inputSize() const { return input_; }

 private:
  cv::dnn::Net net_;
  std::vector<std::string> out_names_;
  std::vector<int> class_ids_;
  std::vector<int> keep_;  ///< COCO ids to keep (empty = all)
  cv::Size input_{320, 320};
  float conf_ = 0.2f, nms_ = 0.1f, scale_ = 1.f / 255.f;
  bool swap_rb_ = true, per_class_ = true, mult_ = false;
};

}  // namespace dslam
