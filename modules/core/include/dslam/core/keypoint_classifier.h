#pragma once
/** \file keypoint_classifier.h
 *  Interface of keypoint classifiers: each labels the keypoints of a frame
 *  static / movable / dynamic with a reason. Classifiers are chained in the
 *  order of the pipeline's `modules:` list. */
#include <optional>

#include "dslam/core/camera.h"
#include "dslam/core/detection.h"
#include "dslam/core/frame.h"
#include "dslam/core/plugin.h"

namespace dslam {

struct ClassifierContext {
  const CameraModel* camera = nullptr;
  const Frame* previous = nullptr;                 ///< previous frame, nullptr on the first
  const Detections* previous_detections = nullptr;
  std::optional<SE3> predicted_T_wc;               ///< motion-model prediction if tracking is OK
  std::optional<SE3> previous_T_wc;                ///< estimated pose of the previous frame
  int base_feature_count = 1000;                   ///< configured ORB feature count
};

class KeypointClassifier : public Plugin {
  DEFINE_VIRTUAL_MRPT_OBJECT(KeypointClassifier)
 public:
  const char* interfaceName() const override { return "KeypointClassifier"; }
  /** Labels frame.meta (already sized to the keypoints, possibly labelled by
   *  earlier classifiers in the chain). */
  virtual void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) = 0;
  /** Called after tracking with the frame's estimated pose (nullopt if
   *  tracking was lost). Filters (EKF) update here. */
  virtual void afterTracking(const Frame& frame, const Detections& det, const std::optional<SE3>& T_wc) {
    (void)frame;
    (void)det;
    (void)T_wc;
  }
  /** True when classify() depends on the frame's keypoints and the
   *  detection alone (no context, no state, no side effect) and may run in
   *  another thread concurrently with the tracking thread's calls. With
   *  asynchronous detection, System then labels each keyframe whose
   *  detection was carried from an older image again when the detection of
   *  its own image arrives (before local mapping uses the keyframe). */
  virtual bool relabelsKeyFrames() const { return false; }
  /** False for classifiers that never change labels (AdaptiveFeatureCount
   *  only asks for a feature count): when all the others relabel keyframes,
   *  a keyframe's labels from its own detection replace the carried ones. */
  virtual bool labelsKeypoints() const { return true; }
  /** Feature count wanted for the next frame; 0 = no request. */
  virtual int requestedFeatureCount() const { return 0; }
  /** Clears internal state (new sequence). */
  virtual void reset() {}
};

}  // namespace dslam
