#pragma once
/** \file depth_repopulation.h
 *  Changing-SLAM's depth-based repopulation of keypoints inside boxes. */
#include <map>
#include <string>
#include <vector>

#include "dslam/core/keypoint_classifier.h"

namespace dslam {

/** Depth statistics of one box (valid depths > 0 of Frame::input.depth,
 *  or of the keypoint depths when the frame has no depth image). */
struct BoxDepthStats {
  int box = -1;          ///< index in Detections::boxes
  int class_id = -1;
  int samples = 0;       ///< valid depth samples used
  /** valid depth samples of the box's own (outside other boxes; with
   *  exclude_overlap smaller than `samples` when the overlap fallback took
   *  the shared pixels back) */
  int own_samples = 0;
  float min = 0, max = 0, mean = 0, median = 0, stddev = 0;
  float object_depth = 0;  ///< min (or the `min_percentile` percentile)
  float center_depth = 0;  ///< median over the central window (0 = no valid sample)
  float center_std = 0;    ///< std over the central window
  float margin = 0;        ///< class depth margin used
  /** Extent of the near layer (depth <= object depth + margin) as a fraction
   *  of the box width / height (computed when the centre test fired). */
  float near_span_x = 0, near_span_y = 0;
  bool occluded = false;   ///< unlabelled occluder detected: keypoints unusable
  /** side_occluder_span: depth of the occluder at one side of the box (its
   *  nearest surface), the object depth then being the centre's surface
   *  (0 = no side occluder). */
  float occluder_depth = 0;
  int object_points = 0;   ///< keypoints labelled on the box's object (by this box)
  int support_points = 0;  ///< support_check: keypoints taken off the object, on a surface continuing out of the box
};

/** Keypoints inside boxes are split by depth (Changing-SLAM, Sec. 4.1):
 *  deeper than the object depth (the minimum valid depth in the box) plus
 *  a per-class margin -> background, kept (Static, BoxBackground); the rest
 *  lie on the object: Dynamic (InDynamicBox) for `dynamic_classes`
 *  (person), Movable (OnObject) for other detected classes. Pixels shared
 *  by overlapping boxes are left out of the statistics.
 *
 *  Unlabelled occluder (the box's keypoints become Dynamic, Occluded):
 *  the depth at the box centre (median of the central window) is deeper
 *  than object depth + margin, i.e. the nearest surface in the box is not
 *  the detected object, or the central window's depth std exceeds
 *  `max_center_std` (no single surface at the box centre); unless the near
 *  layer (depths within the margin of the object depth) spans the box
 *  (`occlusion_span` of its width and of its height): then the nearest
 *  surface is the detected object itself, one that is seen through (a
 *  chair, a table), not something in front of it; for `see_through_classes`
 *  (off by default; tables: [67]) spanning the width is enough: the top is a
 *  band across the box, the legs too thin to count. The test applies to every
 *  box by default; `occlusion_check: dynamic` limits it to boxes of
 *  `dynamic_classes`.
 *
 *  Support surfaces (`support_check`, off by default; `no_statistics`: in
 *  boxes without depth statistics of their own only): a keypoint put on a
 *  box's object (not of `dynamic_classes`) whose surface continues as one
 *  plane out of the box, along its row or column, is on what the object
 *  stands on or against (the floor at its foot, a wall, a table top), not
 *  on the object: Static (BoxBackground).
 *
 *  Re-labelling: this classifier decides keypoints inside its boxes, also
 *  returning to Static keypoints an earlier BoxFilter dropped (reason
 *  InDynamicBox or None). Keypoints dropped for any other reason (epipolar
 *  outlier, semantic mask, ...) are never lowered. */
class DepthRepopulation : public KeypointClassifier {
  DEFINE_MRPT_OBJECT(DepthRepopulation, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) override;

  /** Statistics of the boxes of the last classified frame. */
  const std::vector<BoxDepthStats>& lastStats() const { return stats_; }

 private:
  cv::Rect2f centerWindow(const cv::Rect2f& box) const;
  BoxDepthStats boxStats(const Frame& frame, const BoundingBox& bb, int b, const cv::Rect2f& box,
                         const std::vector<cv::Rect2f>& shared, int own_samples);

  std::vector<int> classes_, dynamic_classes_{1}, see_through_classes_;
  double min_score_ = 0, min_percentile_ = 0, center_fraction_ = 0.2, max_center_std_ = 0.3, occlusion_span_ = 0.8,
         side_span_ = 0,
         overlap_dilation_ = 0.1;
  int stride_ = 2, min_samples_ = 10;
  enum class Support { Off, NoStatistics, All } support_ = Support::Off;  ///< support_check
  double support_extension_ = 0.25, support_tolerance_ = 0.004;
  int support_min_samples_ = 4;
  bool exclude_overlap_ = true, overlap_fallback_ = false, fallback_skip_others_ = false;
  bool overlap_front_ = true;  ///< overlap_class: front
  double front_margin_ = 0.1;
  enum class Occlusion { Dynamic, All, None } occlusion_ = Occlusion::All;
  std::map<int, double> margin_, percentile_;
  double margin_default_ = 0.5;
  std::vector<BoxDepthStats> stats_;
  std::vector<float> buf_, cbuf_, xs_, ys_;
  std::vector<cv::Vec2d> walk_;  ///< support_check samples
};

}  // namespace dslam
