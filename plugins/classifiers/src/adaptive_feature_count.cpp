#include "dslam/plugins/classifiers/adaptive_feature_count.h"

#include <algorithm>
#include <cmath>

#include "common.h"
#include "dslam/core/error.h"

IMPLEMENTS_MRPT_OBJECT(AdaptiveFeatureCount, KeypointClassifier, dslam)

namespace dslam {

double boxUnionArea(const std::vector<cv::Rect2f>& boxes, cv::Size image) {
  std::vector<cv::Rect2d> r;
  const cv::Rect2d img(0, 0, image.width, image.height);
  for (const auto& b : boxes) {
    const cv::Rect2d c = cv::Rect2d(b.x, b.y, b.width, b.height) & img;
    if (c.width > 0 && c.height > 0) r.push_back(c);
  }
  if (r.empty()) return 0;
  std::vector<double> xs, ys;
  for (const auto& b : r) {
    xs.push_back(b.x), xs.push_back(b.x + b.width);
    ys.push_back(b.y), ys.push_back(b.y + b.height);
  }
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  std::sort(ys.begin(), ys.end());
  ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
  double area = 0;
  for (size_t i = 0; i + 1 < xs.size(); i++) {
    const double cx = 0.5 * (xs[i] + xs[i + 1]);
    for (size_t j = 0; j + 1 < ys.size(); j++) {
      const double cy = 0.5 * (ys[j] + ys[j + 1]);
      for (const auto& b : r)
        if (cx > b.x && cx < b.x + b.width && cy > b.y && cy < b.y + b.height) {
          area += (xs[i + 1] - xs[i]) * (ys[j + 1] - ys[j]);
          break;
        }
    }
  }
  return area;
}

std::string AdaptiveFeatureCount::description() const {
  return "Crowd-SLAM adaptive ORB feature count from the image area covered by dynamic-class boxes";
}

std::vector<ParamSpec> AdaptiveFeatureCount::paramSpecs() const {
  return {
      P_enum("mode", "paper", {"paper", "percent"},
             "paper: absolute increments (Crowd-SLAM paper); percent: % of the base count (Crowd-SLAM public code)"),
      P_enum("area", "union", {"union", "sum"},
             "filtered area: union of the boxes (paper) or plain sum of box areas (public code)"),
      P_list("classes", ParamType::IntList, "[1]", "COCO ids of the filtered (dynamic) classes (person = 1)"),
      P_double("min_score", 0, "ignore boxes with a lower score", 0, 1),
      P_list("paper_thresholds", ParamType::DoubleList, "[0.3, 0.6, 0.9, 0.95]",
             "mode paper: filtered-area fractions (Crowd-SLAM paper: 30, 60, 90, 95 %)"),
      P_list("paper_increments", ParamType::DoubleList, "[300, 500, 700, 1200]",
             "mode paper: features added from each threshold on (Crowd-SLAM paper: 300, 500, 700, 1200)"),
      P_list("percent_thresholds", ParamType::DoubleList, "[0, 0.3, 0.6, 0.9, 0.95]",
             "mode percent: filtered-area fractions (public code FeatureNumberUpdate; 0 = any area > 0)"),
      P_list("percent_increments", ParamType::DoubleList, "[30, 50, 70, 90, 120]",
             "mode percent: % of the base count added from each threshold on (public code)"),
  };
}

void AdaptiveFeatureCount::configure(const Params& p, const PluginContext& ctx) {
  KeypointClassifier::configure(p, ctx);
  percent_ = p.getString("mode") == "percent";
  sum_ = p.getString("area") == "sum";
  classes_ = cls::cocoIdList(p, "classes");
  min_score_ = p.getDouble("min_score");
  const std::string tk = percent_ ? "percent_thresholds" : "paper_thresholds";
  const std::string vk = percent_ ? "percent_increments" : "paper_increments";
  thresholds_ = p.getDoubleList(tk);
  values_ = p.getDoubleList(vk);
  if (thresholds_.size() != values_.size())
    p.fail(tk, "must have as many entries as '" + vk + "' (" + std::to_string(thresholds_.size()) + " vs " +
                   std::to_string(values_.size()) + ")");
  for (size_t i = 0; i < thresholds_.size(); i++) {
    if (thresholds_[i] < 0 || thresholds_[i] > 1)
      p.fail(tk, std::to_string(thresholds_[i]) + " is not an area fraction in [0, 1]");
    if (i > 0 && thresholds_[i] <= thresholds_[i - 1])
      p.fail(tk, "thresholds must increase");
    if (values_[i] < 0) p.fail(vk, "increments must be >= 0");
  }
  reset();
}

void AdaptiveFeatureCount::reset() {
  area_ = 0;
  increment_ = 0;
}

int AdaptiveFeatureCount::incrementFor(double area, int base) const {
  if (area <= 0) return 0;
  double v = 0;
  for (size_t i = 0; i < thresholds_.size(); i++)
    if (area >= thresholds_[i] - 1e-9) v = values_[i];
  return static_cast<int>(std::lround(percent_ ? v * 0.01 * base : v));
}

void AdaptiveFeatureCount::classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) {
  cls::ensureMeta(frame);
  base_ = ctx.base_feature_count;
  if (!det.valid) return;  // no new detections: keep the last request
  const cv::Size img = cls::imageSize(frame, ctx.camera);
  if (img.area() <= 0) throw DataError("frame " + std::to_string(frame.index()) + ": image size unknown");
  std::vector<cv::Rect2f> boxes;
  double sum = 0;
  const cv::Rect2f full(0, 0, static_cast<float>(img.width), static_cast<float>(img.height));
  for (const auto& b : det.boxes)
    if (b.score >= min_score_ && cls::contains(classes_, b.class_id)) {
      boxes.push_back(b.box);
      const cv::Rect2f c = b.box & full;
      sum += static_cast<double>(c.width) * c.height;
    }
  const double px = sum_ ? sum : boxUnionArea(boxes, img);
  area_ = px / (static_cast<double>(img.width) * img.height);
  increment_ = incrementFor(area_, base_);
}

}  // namespace dslam
