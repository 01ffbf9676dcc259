#include "dslam/plugins/detectors/hog_people.h"

#include <opencv2/imgproc.hpp>

#include <cmath>

#include "common.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"

IMPLEMENTS_MRPT_OBJECT(HogPeopleDetector, Detector, dslam)

namespace dslam {

std::string HogPeopleDetector::description() const {
  return "OpenCV HOG + linear SVM people detector (Dalal-Triggs, no model file): person boxes";
}

std::vector<ParamSpec> HogPeopleDetector::paramSpecs() const {
  return {
      P_double("hit_threshold", 0, "SVM margin threshold of a window (OpenCV default 0)"),
      P_int("win_stride", 8, "window stride, pixels (multiple of 8)", 8, 256),
      P_int("padding", 0, "padding around the image, pixels", 0, 256),
      P_double("scale", 1.05, "pyramid scale step", 1.001, 4),
      P_int("group_threshold", 2, "minimum overlapping windows to keep a group", 0, 100),
      P_double("min_score", 0, "minimum score (logistic of the SVM margin)", 0, 1),
      P_int("max_width", 0, "downscale wider frames to this width first (0 = never)", 0, 100000),
      P_bool("shrink_boxes", true, "shrink boxes to the body as OpenCV's peopledetect sample (x 0.8)"),
  };
}

void HogPeopleDetector::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  hit_threshold_ = p.getDouble("hit_threshold");
  win_stride_ = int(p.getInt("win_stride"));
  if (win_stride_ % 8) throw ConfigError("HogPeopleDetector: win_stride must be a multiple of 8 (block stride)");
  padding_ = int(p.getInt("padding"));
  scale_ = p.getDouble("scale");
  group_threshold_ = int(p.getInt("group_threshold"));
  min_score_ = p.getDouble("min_score");
  max_width_ = int(p.getInt("max_width"));
  shrink_ = p.getBool("shrink_boxes");
  hog_ = cv::HOGDescriptor();
  hog_.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
}

Detections HogPeopleDetector::detect(const SensorFrame& frame) {
  Detections d = det::emptyDetections(frame);
  cv::Mat img = det::toBgr8(frame);
  double f = 1.0;
  if (max_width_ > 0 && img.cols > max_width_) {
    f = double(max_width_) / img.cols;
    cv::resize(img, img, cv::Size(), f, f, cv::INTER_AREA);
  }
  // No person fits an image smaller than the 64 x 128 detection window (and
  // OpenCV's HOG reads out of bounds on such images): nothing to report.
  if (img.cols < hog_.winSize.width || img.rows < hog_.winSize.height) return d;
  std::vector<cv::Rect> found;
  std::vector<double> weights;
  hog_.detectMultiScale(img, found, weights, hit_threshold_, cv::Size(win_stride_, win_stride_),
                        cv::Size(padding_, padding_), scale_, group_threshold_, false);
  const cv::Size full = frame.image.size();
  for (size_t i = 0; i < found.size(); i++) {
    cv::Rect2f r(found[i]);
    if (shrink_) {  // as samples/cpp/peopledetect.cpp
      r.x += r.width * 0.1f;
      r.width *= 0.8f;
      r.y += r.height * 0.07f;
      r.height *= 0.8f;
    }
    r = cv::Rect2f(float(r.x / f), float(r.y / f), float(r.width / f), float(r.height / f));
    BoundingBox b;
    b.box = det::clipBox(r, full);
    b.class_id = coco::kPerson;
    b.score = i < weights.size() ? float(1.0 / (1.0 + std::exp(-weights[i]))) : 1.f;
    if (b.box.area() <= 0 || b.score < min_score_) continue;
    d.boxes.push_back(b);
  }
  return d;
}

}  // namespace dslam
