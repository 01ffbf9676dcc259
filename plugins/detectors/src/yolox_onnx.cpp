#include "dslam/plugins/detectors/yolox_onnx.h"

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"

IMPLEMENTS_MRPT_OBJECT(YoloxOnnxDetector, Detector, dslam)

namespace dslam {

std::string YoloxOnnxDetector::description() const {
  return "YOLOX ONNX (default YOLOX-nano, 80 COCO classes) through OpenCV DNN: boxes with COCO ids";
}

std::vector<ParamSpec> YoloxOnnxDetector::paramSpecs() const {
  return {
      P_path("model", "", "ONNX file ('' = ${DSLAM_SHARED_DIR}/models/yolox-nano/yolox_nano.onnx)"),
      P_path("names", "", "class-names file ('' = ${DSLAM_SHARED_DIR}/models/yolox-nano/coco.names)"),
      P_list("class_ids", ParamType::IntList, "[]",
             "COCO id of each model class, in model order (overrides the names mapping)"),
      P_int("input_size", 416, "square network input size (the ONNX model's; YOLOX-nano: 416)", 32, 4096),
      P_double("confidence", 0.3, "minimum objectness x class score", 0, 1),
      P_double("nms", 0.45, "NMS IoU threshold", 0, 1),
      P_bool("nms_per_class", true, "NMS within each class (false: across classes)"),
      P_list("classes", ParamType::IntList, "[]", "COCO ids to keep (empty = all)"),
      P_double("pad_value", 114, "letterbox padding value", 0, 255),
      P_bool("swap_rb", true, "feed RGB (opencv_zoo YOLOX converts BGR->RGB)"),
  };
}

void YoloxOnnxDetector::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  const std::string model = det::modelFile(p.getString("model"), "models/yolox-nano/yolox_nano.onnx", "YOLOX ONNX model");
  const std::string names_file = det::modelFile(p.getString("names"), "models/yolox-nano/coco.names", "class-names file");
  const auto names = det::readNames(names_file);
  class_ids_ = det::cocoIdsForNames(names, p.getIntList("class_ids"), names_file);
  keep_ = det::classFilter(p);
  const int s = int(p.getInt("input_size"));
  if (s % 32) throw ConfigError("YoloxOnnxDetector: input_size must be a multiple of 32, got " + std::to_string(s));
  input_ = cv::Size(s, s);
  conf_ = float(p.getDouble("confidence"));
  nms_ = float(p.getDouble("nms"));
  per_class_ = p.getBool("nms_per_class");
  pad_ = p.getDouble("pad_value");
  swap_rb_ = p.getBool("swap_rb");
  net_ = det::loadNet("YOLOX ONNX model", model, "", "onnx");
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  out_names_ = net_.getUnconnectedOutLayersNames();
  if (out_names_.size() != 1)
    throw DataError(model + ": a YOLOX model has one output, this one has " + std::to_string(out_names_.size()));
}

Detections YoloxOnnxDetector::detect(const SensorFrame& frame) {
  Detections d = det::emptyDetections(frame);
  const cv::Mat img = det::toBgr8(frame);
  float ratio = 1.f;
  cv::Mat lb = det::letterbox(img, input_, pad_, ratio);
  cv::Mat blob = cv::dnn::blobFromImage(lb, 1.0, input_, cv::Scalar(), swap_rb_, false, CV_32F);
  net_.setInput(blob);
  const auto outs = det::forward(net_, out_names_, "YOLOX", frame.index);
  std::vector<det::RawBox> raw;
  det::decodeYolox(outs.at(0), out_names_[0], input_, strides_, ratio, int(class_ids_.size()), conf_, raw);
  det::filterRaw(raw, class_ids_, keep_);
  d.boxes = det::toBoxes(det::nms(raw, conf_, nms_, per_class_), class_ids_, keep_, img.size());
  return d;
}

}  // namespace dslam
