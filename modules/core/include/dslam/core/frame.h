#pragma once
/** \file frame.h
 *  Sensor input and per-frame feature data shared by all modules. */
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/core/se3.h"

namespace dslam {

/** One frame as delivered by a DatasetSource. Images are as loaded (8-bit
 *  grey or BGR); `depth` is CV_32F metres with 0 = invalid. */
struct SensorFrame {
  int index = -1;           ///< 0-based position in the sequence
  double timestamp = 0;     ///< seconds
  cv::Mat image;            ///< left / RGB image
  cv::Mat image_right;      ///< stereo right image (rectified or raw)
  cv::Mat depth;            ///< CV_32F metres, 0 = invalid (RGB-D only)
  std::string image_path, image_right_path, depth_path;
  std::optional<SE3> gt_T_wc;  ///< ground-truth camera pose if the dataset has one
  bool has_depth() const { return !depth.empty(); }
};

/** Per-keypoint motion class (Changing-SLAM vocabulary). */
enum class KpLabel : uint8_t {
  Static = 0,   ///< background: used for tracking and mapping
  Movable = 1,  ///< on an object that may move (chair): used, flagged in the map
  Dynamic = 2,  ///< moving now: never used for tracking or mapping
};
const char* toString(KpLabel l);

/** Why a classifier assigned a label; kept for analysis and ablations. */
enum class KpReason : uint8_t {
  None = 0,
  InDynamicBox,        ///< BoxFilter: inside a box of a dynamic class
  BoxBackground,       ///< DepthRepopulation: inside a box but behind the object
  Occluded,            ///< DepthRepopulation: unlabelled occluder in the box
  OnObject,            ///< on a detected object (movable)
  SemanticDynamic,     ///< semantic label of a dynamic class
  EpipolarOutlier,     ///< farther than the threshold from its epipolar line
  UnmatchedUnknown,    ///< unknown region keypoint without a match (Panoptic-SLAM)
  PersonPrior,         ///< people removed a priori (Panoptic-SLAM)
  ObjectMoving,        ///< EKF velocity above the class threshold
  NewObject,           ///< EKF: new object, dynamic until proven static
  GroundTruth,         ///< synthetic ground-truth mask
};
const char* toString(KpReason r);

struct KeypointMeta {
  KpLabel label = KpLabel::Static;
  KpReason reason = KpReason::None;
  int16_t class_id = -1;   ///< COCO id of the region the keypoint lies in, -1 = none
  int32_t object_id = -1;  ///< object/instance id, -1 = none
};

/** A frame after feature extraction. Keypoint vectors are parallel:
 *  keypoints[i], keypoints_un[i], descriptors.row(i), depth[i], u_right[i],
 *  meta[i]. */
struct Frame {
  SensorFrame input;
  cv::Mat gray;                         ///< 8-bit grey left image
  cv::Mat gray_right;                   ///< 8-bit grey right image (stereo)
  std::vector<cv::KeyPoint> keypoints;  ///< as detected (distorted pixels)
  std::vector<cv::KeyPoint> keypoints_un;  ///< undistorted
  cv::Mat descriptors;                  ///< CV_8U, one 32-byte ORB row per keypoint
  std::vector<float> depth;             ///< metres per keypoint, <= 0 unknown
  std::vector<float> u_right;           ///< stereo / virtual right x, < 0 unknown
  std::vector<KeypointMeta> meta;
  int requested_features = 0;           ///< feature count used for this frame

  int index() const { return input.index; }
  double timestamp() const { return input.timestamp; }
  size_t size() const { return keypoints.size(); }
  /** True unless a classifier marked keypoint i dynamic. */
  bool usable(size_t i) const { return meta.empty() || meta[i].label != KpLabel::Dynamic; }
  void resetMeta() { meta.assign(keypoints.size(), KeypointMeta{}); }
  size_t countLabel(KpLabel l) const {
    size_t n = 0;
    for (const auto& m : meta) n += (m.label == l);
    return n;
  }
};

}  // namespace dslam
