// toString() of the small enums of the core data model.
#include "dslam/core/detection.h"
#include "dslam/core/frame.h"

namespace dslam {

const char* toString(SegmentKind k) {
  switch (k) {
    case SegmentKind::Thing: return "thing";
    case SegmentKind::Stuff: return "stuff";
    case SegmentKind::Unknown: return "unknown";
  }
  return "?";
}

const char* toString(KpLabel l) {
  switch (l) {
    case KpLabel::Static: return "static";
    case KpLabel::Movable: return "movable";
    case KpLabel::Dynamic: return "dynamic";
  }
  return "?";
}

const char* toString(KpReason r) {
  switch (r) {
    case KpReason::None: return "none";
    case KpReason::InDynamicBox: return "in_dynamic_box";
    case KpReason::BoxBackground: return "box_background";
    case KpReason::Occluded: return "occluded";
    case KpReason::OnObject: return "on_object";
    case KpReason::SemanticDynamic: return "semantic_dynamic";
    case KpReason::EpipolarOutlier: return "epipolar_outlier";
    case KpReason::UnmatchedUnknown: return "unmatched_unknown";
    case KpReason::PersonPrior: return "person_prior";
    case KpReason::ObjectMoving: return "object_moving";
    case KpReason::NewObject: return "new_object";
    case KpReason::GroundTruth: return "ground_truth";
  }
  return "?";
}

}  // namespace dslam
