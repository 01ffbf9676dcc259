#pragma once
/** \file detection_carry.h
 *  Carrying detections to a later frame. When a detector runs
 *  asynchronously (tracking does not wait for it) or on every N-th frame
 *  only, its last result describes an older image; classifiers get it moved
 *  to where the objects are now. Each region (box, panoptic segment,
 *  connected region of a semantic class) is moved by the median optical
 *  flow of corners inside it (pyramidal Lucas-Kanade, forward-backward
 *  checked), boxes also scaled by the median change of the corners'
 *  spread. A region without enough trackable corners stays where it was. */
#include <opencv2/core.hpp>

#include <vector>

#include "dslam/core/detection.h"

namespace dslam {

struct CarryParams {
  int max_corners = 30;          ///< corners tracked per region
  double inner_fraction = 0.6;   ///< boxes: corners from the central part (less background)
  int min_points = 4;            ///< fewer tracked corners: the region is not moved
  int lk_levels = 4;             ///< pyramid levels of the flow (motions up to ~80 px)
  int lk_window = 15;            ///< window side, pixels (21: 1.6x the time, same boxes on the walking scenes)
  double max_fb_error = 1.0;     ///< forward-backward error above which a corner is dropped, pixels
};

/** How one region moved from one image to the next. */
struct RegionMotion {
  cv::Point2f shift{0, 0};
  float scale = 1.f;
  int points = 0;  ///< corners that passed the forward-backward check
};

/** The motion of the region `mask` (CV_8U, non-zero = inside; or empty =
 *  the whole `roi`) inside `roi` from grey image `from` to `to`. */
RegionMotion regionMotion(const cv::Mat& from, const cv::Mat& to, const cv::Rect& roi, const cv::Mat& mask,
                          const CarryParams& p = {});

/** `d` (made on grey image `from`) moved to grey image `to`; age_frames is
 *  set to `age`. Boxes, panoptic segments (ids and their bounding boxes) and
 *  semantic regions are moved; pixels a moved region leaves become void
 *  (panoptic 0, semantic 255). */
Detections carryDetections(const Detections& d, const cv::Mat& from, const cv::Mat& to, int age,
                           const CarryParams& p = {});

/** When a new detection replaces a box that `hold` keeps. */
struct HoldParams {
  float min_iou = 0.1f;  ///< a new box of the class overlapping a held one this much replaces it...
  /// ...unless it is a fragment of it: at most this fraction of its area and
  /// at least `fragment_inside` of the new box inside it. Then both are kept:
  /// Yolo-Fastest reports only the legs of a walking person on some frames
  /// (walking_rpy frame 202: 132 x 179 px inside the 153 x 294 px person).
  float fragment_area = 0.7f;
  float fragment_inside = 0.8f;
};

/** `hold:` of a detector, which keeps boxes it stops reporting for a few
 *  frames (small detectors flicker). `prev` describes image `prev_img`;
 *  prev_seen[j] is the frame at which the detector last reported box j.
 *  Each box of `prev` that was reported at most `hold` frames before
 *  `frame` and that no box of `cur` of the same class replaces (HoldParams;
 *  `cur` describing image `img`) is moved to `img` (optical flow when
 *  `flow`, else left in place) and appended to `cur`. Returns the
 *  last-reported frame of each box of the result: `cur_seen` for cur's own
 *  boxes, prev_seen for the held ones. */
std::vector<int> holdMissedBoxes(const Detections& prev, const cv::Mat& prev_img, const std::vector<int>& prev_seen,
                                 Detections& cur, const cv::Mat& img, int frame, int cur_seen, int hold, bool flow,
                                 const HoldParams& hp = {}, const CarryParams& p = {});

/** Removes the boxes of `d` last reported more than `hold` frames before
 *  `frame` (seen[j], kept aligned with d.boxes). */
void dropExpiredBoxes(Detections& d, std::vector<int>& seen, int frame, int hold);

/** Fraction of an image of size `size` that the union of the boxes of `d`
 *  covers (clipped to the image; 0 for detections without boxes). The
 *  `wait_coverage:` of an asynchronous detector compares it. */
double boxCoverage(const Detections& d, cv::Size size);

}  // namespace dslam
