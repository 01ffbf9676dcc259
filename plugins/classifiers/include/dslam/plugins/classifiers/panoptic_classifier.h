#pragma once
/** \file panoptic_classifier.h
 *  Panoptic-SLAM's keypoint classification from panoptic segments. */
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/keypoint_classifier.h"

namespace dslam {

/** Panoptic-SLAM (Abati et al. 2024; public code Tracking.cc,
 *  PanopticNet::ShortTerm_DA):
 *  - keypoints on things of `prior_classes` (people) are dropped a priori
 *    (Dynamic, PersonPrior);
 *  - things are associated to the previous frame's things of the same
 *    category by mask IoU (> `association_iou`); the best match gives the
 *    object id, unmatched things are new objects, dropped (Dynamic,
 *    NewObject) when there is a previous frame;
 *  - a fundamental matrix is fitted by RANSAC to descriptor matches of
 *    stuff keypoints with the previous frame's stuff keypoints;
 *  - thing keypoints are matched with the previous keypoints of the same
 *    object: farther than `threshold` from the epipolar line -> Dynamic
 *    (EpipolarOutlier), otherwise Movable (OnObject) with the object id;
 *    `thing_decision: object` drops the whole thing when the outlier share
 *    of its matches reaches `moving_ratio`;
 *  - unknown (void) keypoints: matched and checked the same way, unmatched
 *    ones dropped (Dynamic, UnmatchedUnknown);
 *  - stuff keypoints keep their label (Static unless set earlier).
 *  class_id is set from the segment category for every keypoint on a
 *  segment. Never lowers a label. Without a panoptic image it does
 *  nothing. */
class PanopticClassifier : public KeypointClassifier {
  DEFINE_MRPT_OBJECT(PanopticClassifier, dslam)
 public:
  struct Stats {
    bool fitted = false;
    int stuff_matches = 0, fit_inliers = 0;
    int things = 0, new_things = 0, thing_outliers = 0, unknown_outliers = 0, unknown_unmatched = 0;
  };

  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) override;
  void reset() override;

  const Stats& lastStats() const { return stats_; }
  /** Panoptic segment id -> object (tracking) id for the things of the last
   *  classified frame. */
  const std::map<int, int>& objectIds() const { return seg_track_; }

 private:
  std::vector<int> prior_classes_{1};
  double association_iou_ = 0.15, threshold_ = 0.1, moving_ratio_ = 0.5;
  bool drop_new_ = true, drop_unmatched_ = true, object_mode_ = false;
  struct MatchCfg;
  std::shared_ptr<MatchCfg> match_;
  Stats stats_;
  // State carried to the next frame.
  int frame_index_ = -1;
  std::map<int, int> seg_track_;
  struct SegStat {
    int area = 0;
    cv::Rect bbox;
    int category = 0;
  };
  std::map<int, SegStat> seg_stats_;
  int next_track_ = 1;

  struct Work;  ///< one frame's intermediate results (panoptic_classifier.cpp)
  /** Area and bbox of the current thing segments. */
  static std::map<int, SegStat> thingStats(const Detections& det);
  /** Short-term data association of the things with the previous frame's
   *  (mask IoU): current segment -> track id, and which tracks are new. */
  void associate(Work& w, const Detections& det) const;
  /** class ids, object ids and the person prior; keypoint sets per region. */
  void labelAndGroup(Frame& frame, Work& w) const;
  /** The previous frame's stuff / unknown / thing keypoints. */
  void groupPrevious(const Frame& frame, Work& w) const;
  /** Fundamental matrix from stuff matches. */
  void fitStuff(const Frame& frame, Work& w);
  void classifyThings(Frame& frame, Work& w);
  void classifyUnknown(Frame& frame, Work& w);
};

}  // namespace dslam
