#pragma once
/** \file yolox_onnx.h
 *  YOLOX (nano/tiny/s) ONNX models through OpenCV DNN. */
#include <string>
#include <vector>

#include <opencv2/dnn/dnn.hpp>

#include "dslam/core/detector.h"

namespace dslam {

/** YOLOX ONNX as in opencv_zoo object_detection_yolox: letterbox to the
 *  input size with pad 114, BGR->RGB, no scaling; output [1, N, 85] decoded
 *  on grids of strides 8/16/32 (det::decodeYolox); score = objectness *
 *  class score; NMS. Defaults: YOLOX-nano 416x416, confidence 0.3, NMS 0.45. */
class YoloxOnnxDetector : public Detector {
  DEFINE_MRPT_OBJECT(YoloxOnnxDetector, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  Detections detect(const SensorFrame& frame) override;
  unsigned outputs() const override { return kBoxes; }

  const std::vector<int>& classIds() const { return class_ids_; }
  cv::Size inputSize() const { return input_; }

 private:
  cv::dnn::Net net_;
  std::vector<std::string> out_names_;
  std::vector<int> class_ids_;
  std::vector<int> keep_;
  std::vector<int> strides_{8, 16, 32};
  cv::Size input_{416, 416};
  float conf_ = 0.3f, nms_ = 0.45f;
  double pad_ = 114;
  bool swap_rb_ = true, per_class_ = true;
};

}  // namespace dslam
