#include "dslam/plugins/classifiers/box_filter.h"

#include <algorithm>
#include <vector>

#include "common.h"

IMPLEMENTS_MRPT_OBJECT(BoxFilter, KeypointClassifier, dslam)

namespace dslam {

std::string BoxFilter::description() const {
  return "Crowd-SLAM box filter: keypoints inside boxes of dynamic classes (person) are dynamic";
}

std::vector<ParamSpec> BoxFilter::paramSpecs() const {
  return {
      P_list("classes", ParamType::IntList, "[1]", "COCO ids of dynamic classes (Crowd-SLAM: person = 1)"),
      P_double("margin", 0, "grow boxes by this many pixels (paper: 0; Crowd-SLAM's public code uses 5)", 0, 10000),
      P_double("min_score", 0, "ignore boxes with a lower score (the detector's threshold applies first)", 0, 1),
      P_double("age_margin", 0.03,
               "a detection carried from an older frame (asynchronous detection, every: N) grows by this fraction of "
               "its width and height per frame of age on each side: limbs swing away from where the flow carried "
               "the box (ours; fresh detections are unchanged)",
               0, 1),
  };
}

void BoxFilter::configure(const Params& p, const PluginContext& ctx) {
  KeypointClassifier::configure(p, ctx);
  classes_ = cls::cocoIdList(p, "classes");
  margin_ = static_cast<float>(p.getDouble("margin"));
  min_score_ = p.getDouble("min_score");
  age_margin_ = static_cast<float>(p.getDouble("age_margin"));
}

void BoxFilter::classify(Frame& frame, const Detections& det, const ClassifierContext&) {
  cls::ensureMeta(frame);
  if (!det.valid) return;
  std::vector<const BoundingBox*> boxes;
  for (const auto& b : det.boxes)
    if (b.score >= min_score_ && cls::contains(classes_, b.class_id)) boxes.push_back(&b);
  if (boxes.empty()) return;
  // Older detections (carried to this frame) are less certain: grown with their age.
  std::vector<cv::Rect2f> grown;
  const float g = age_margin_ * static_cast<float>(std::max(0, det.age_frames));
  for (const BoundingBox* b : boxes)
    grown.emplace_back(b->box.x - g * b->box.width, b->box.y - g * b->box.height, b->box.width * (1 + 2 * g),
                       b->box.height * (1 + 2 * g));
  for (size_t i = 0; i < frame.size(); i++) {
    const cv::Point2f& pt = frame.keypoints[i].pt;
    for (size_t k = 0; k < boxes.size(); k++) {
      const BoundingBox* b = boxes[k];
      if (!cls::inBox(pt, grown[k], margin_)) continue;
      KeypointMeta& m = frame.meta[i];
      cls::raise(m, KpLabel::Dynamic, KpReason::InDynamicBox);
      if (m.class_id < 0) m.class_id = static_cast<int16_t>(b->class_id);
      if (m.object_id < 0 && b->instance_id >= 0) m.object_id = b->instance_id;
      break;
    }
  }
}

}  // namespace dslam
