#pragma once
// Helpers shared by the keypoint-classifier plugins (private to
// plugins/classifiers).
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/core/camera.h"
#include "dslam/core/detection.h"
#include "dslam/core/frame.h"
#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/params.h"
#include "dslam/core/se3.h"

namespace dslam::cls {

/** Size of the image the keypoints refer to: gray, else input image, else
 *  the camera, else `fallback`. */
cv::Size imageSize(const Frame& f, const CameraModel* cam = nullptr, cv::Size fallback = {});

/** Makes sure frame.meta has one entry per keypoint (resets it otherwise). */
void ensureMeta(Frame& f);

/** Raises keypoint meta to `l` (Static < Movable < Dynamic) with reason `r`;
 *  never lowers a label. Returns true if it changed the label. */
inline bool raise(KeypointMeta& m, KpLabel l, KpReason r) {
  if (static_cast<int>(l) > static_cast<int>(m.label)) {
    m.label = l;
    m.reason = r;
    return true;
  }
  if (l == m.label && m.reason == KpReason::None) m.reason = r;
  return false;
}

inline bool contains(const std::vector<int>& v, int x) {
  for (int e : v)
    if (e == x) return true;
  return false;
}

/** Validated list of COCO ids (ConfigError naming the key otherwise). */
std::vector<int> cocoIdList(const Params& p, const std::string& key);

/** Per-class value map: keys are COCO names ("person", "dining table") or
 *  numeric COCO ids; key "default" gives the value of unlisted classes.
 *  ConfigError on unknown names or (need_default) a missing default. */
struct ClassValues {
  std::map<int, double> by_class;
  double fallback = 0;
  bool has_default = false;  ///< the map had a "default" entry (fallback is its value)
  double at(int class_id) const {
    auto it = by_class.find(class_id);
    return it == by_class.end() ? fallback : it->second;
  }
};
ClassValues classValues(const Params& p, const std::string& key, bool need_default = true);

/** A label image (semantic CV_8U or panoptic CV_32S) looked up with
 *  keypoint coordinates of an image of size `ref` (scaled if sizes differ). */
class PixelLookup {
 public:
  PixelLookup() = default;
  PixelLookup(const cv::Mat& m, cv::Size ref);
  bool valid() const { return !m_.empty(); }
  /** Pixel of `p` in the label image, or nullopt when outside. */
  std::optional<cv::Point> pixel(const cv::Point2f& p) const {
    const int x = static_cast<int>(std::floor((p.x + 0.5) * sx_));
    const int y = static_cast<int>(std::floor((p.y + 0.5) * sy_));
    if (x < 0 || y < 0 || x >= m_.cols || y >= m_.rows) return std::nullopt;
    return cv::Point(x, y);
  }
  const cv::Mat& mat() const { return m_; }

 private:
  cv::Mat m_;
  double sx_ = 1, sy_ = 1;
};

/** Segment lookup by panoptic id. */
class SegmentIndex {
 public:
  explicit SegmentIndex(const Detections& d);
  const PanopticSegment* find(int id) const {
    auto it = idx_.find(id);
    return it == idx_.end() ? nullptr : &d_->segments[it->second];
  }

 private:
  const Detections* d_;
  std::unordered_map<int, size_t> idx_;
};

/** Panoptic region of a keypoint. */
enum class Region : uint8_t { None = 0, Thing, Stuff, Unknown };

/** Region, category and segment id of each keypoint from the panoptic
 *  image (Region::None for all when there is none). Void (id 0) and
 *  segments of kind Unknown or missing from the list are Region::Unknown. */
struct KeypointRegions {
  std::vector<Region> region;
  std::vector<int> segment;   ///< panoptic id, 0 = void / none
  std::vector<int> category;  ///< COCO id, -1 = none
};
KeypointRegions panopticRegions(const std::vector<cv::KeyPoint>& kps, const Detections& d, cv::Size ref);

/** True if `p` lies in box `b` grown by `margin` pixels (half-open). */
inline bool inBox(const cv::Point2f& p, const cv::Rect2f& b, float margin = 0.f) {
  return p.x >= b.x - margin && p.y >= b.y - margin && p.x < b.x + b.width + margin &&
         p.y < b.y + b.height + margin;
}

/** Undistorted pixel of keypoint i: keypoints_un if available, else the
 *  camera's undistortion of keypoints[i] (identity without a camera). */
cv::Point2f undistorted(const Frame& f, size_t i, const CameraModel* cam);
/** Undistorts one raw pixel with the left camera (identity if none). */
cv::Point2f undistortPixel(const cv::Point2f& p, const CameraModel* cam);

/** ORB-SLAM-style descriptor matching (ORBmatcher::FeatureMatching of
 *  Panoptic-SLAM): brute force over the candidate set, best distance <=
 *  max_distance and < nn_ratio x second best, one-to-one (a previous
 *  keypoint keeps its closest current keypoint), then the rotation
 *  histogram check (30 bins, the three main modes kept). */
struct MatchParams {
  int max_distance = 50;       ///< ORBmatcher::TH_LOW
  double nn_ratio = 0.9;       ///< ORBmatcher(0.9, true)
  bool check_orientation = true;
  bool finest_level_only = false;  ///< Panoptic-SLAM matches octave-0 keypoints only
  double radius = 0;           ///< pixels; 0 = whole image
};
/** Returns, for each entry of `cur`, the matched index (into `pk`) or -1. */
std::vector<int> matchDescriptors(const std::vector<cv::KeyPoint>& ck, const cv::Mat& cd, const std::vector<int>& cur,
                                  const std::vector<cv::KeyPoint>& pk, const cv::Mat& pd, const std::vector<int>& prev,
                                  const MatchParams& mp);
MatchParams matchParams(const Params& p);
std::vector<ParamSpec> matchParamSpecs();

/** Fundamental matrix from previous -> current correspondences
 *  (cv::findFundamentalMat with FM_RANSAC, or USAC_FM_8PTS; both are
 *  deterministic: OpenCV's RANSAC seeds its RNG with a constant on every
 *  call, USAC with UsacParams' fixed default state). */
struct FundamentalFit {
  bool ok = false;
  cv::Matx33d F;
  int matches = 0;
  int inliers = 0;
};
struct RansacParams {
  double threshold = 0.1;   ///< inlier distance (px)
  double confidence = 0.99;
  int max_iterations = 1000;  ///< OpenCV's default
  int min_matches = 41;
  int max_points = 0;       ///< evenly subsample larger sets to this many (0 = all)
  bool usac = false;        ///< cv::USAC_FM_8PTS instead of cv::FM_RANSAC
  bool motion_prior = false;  ///< use the motion model's prediction (MotionPrior) when there is one
  double prior_gate = 2.0;    ///< with a prior: fit only on correspondences within this distance (px) of its epipolar lines
  int prior_iterations = 50;  ///< with a prior: RANSAC iteration cap on the gated correspondences
};

/** The motion model's prediction of how the camera moved from the previous
 *  frame to this one (ClassifierContext::previous_T_wc and predicted_T_wc),
 *  as the relative pose and the fundamental matrix of undistorted pixels
 *  (cur^T F prev = 0). `ok` = both poses are known and the camera moved. */
struct MotionPrior {
  bool ok = false;
  SE3 T_cur_prev;  ///< X_cur = T_cur_prev * X_prev
  cv::Matx33d F;
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< undistorted pinhole
  /** Predicted undistorted pixel in the previous image of undistorted pixel
   *  `un` of this frame at depth `z` (> 0), or without depth (z <= 0) at the
   *  scene depth `z_far`. */
  cv::Point2f previousPixel(const cv::Point2f& un, double z, double z_far) const;
};
MotionPrior motionPrior(const ClassifierContext& ctx);

/** Fundamental matrix of the correspondences. With rp.motion_prior and a
 *  prior (`prior` not null, ok): RANSAC (rp.prior_iterations) on the
 *  correspondences within rp.prior_gate px of the predicted epipolar lines;
 *  it falls back to the plain fit when fewer than rp.min_matches pass. */
FundamentalFit fitFundamental(const std::vector<cv::Point2f>& prev, const std::vector<cv::Point2f>& cur,
                              const RansacParams& rp, const MotionPrior* prior = nullptr);
RansacParams ransacParams(const Params& p);
/** At most `n` entries of `v`, evenly spaced (all if n <= 0 or v is smaller). */
std::vector<int> evenSubset(const std::vector<int>& v, int n);
/** ransac_threshold, ransac_confidence, ransac_max_iterations,
 *  min_fit_matches, max_fit_points, ransac_method (defaults of the papers'
 *  code) and motion_prior, prior_gate, prior_iterations (off by default). */
std::vector<ParamSpec> ransacParamSpecs(double default_threshold, const std::string& source);

/** Distance (pixels) of `cur` to the epipolar line F * prev. */
inline double epipolarDistance(const cv::Matx33d& F, const cv::Point2f& prev, const cv::Point2f& cur) {
  const double a = F(0, 0) * prev.x + F(0, 1) * prev.y + F(0, 2);
  const double b = F(1, 0) * prev.x + F(1, 1) * prev.y + F(1, 2);
  const double c = F(2, 0) * prev.x + F(2, 1) * prev.y + F(2, 2);
  const double n = std::sqrt(a * a + b * b);
  return n > 0 ? std::abs(a * cur.x + b * cur.y + c) / n : 0.0;
}

}  // namespace dslam::cls
