#pragma once
/** \file keyframe.h
 *  A keyframe (ORB-SLAM KeyFrame): immutable features of the frame it was
 *  made from, plus pose, map-point associations and graph links, mutated
 *  under the owning Map's `update_mutex`. */
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/core/frame.h"
#include "dslam/core/se3.h"
#include "dslam/features/feature_grid.h"
#include "dslam/map/map_point.h"
#include "dslam/place_recognition/bow_vector.h"

namespace dslam {

/** Pyramid scale tables shared by frames and keyframes (ORB-SLAM mvScaleFactors...). */
struct ScaleLevels {
  int n_levels = 8;
  float scale_factor = 1.2f;
  float log_scale_factor = 0.f;
  std::vector<float> scale, inv_scale, sigma2, inv_sigma2;
  static ScaleLevels make(int n_levels, float scale_factor);
};

/** Intrinsics of the (undistorted / rectified) camera of the keypoints_un. */
struct CameraIntrinsics {
  float fx = 0, fy = 0, cx = 0, cy = 0, invfx = 0, invfy = 0;
  float bf = 0;          ///< baseline * fx; 0 for monocular
  float close_depth = 0; ///< ORB-SLAM mThDepth in metres
  ImageBounds bounds;
};

/** Camera-frame point of undistorted pixel `p` at depth z (z = 1: the
 *  normalised ray), in the keypoints' float arithmetic. */
inline Eigen::Vector3d backProject(const CameraIntrinsics& cam, const cv::Point2f& p, float z) {
  return Eigen::Vector3d((p.x - cam.cx) * z * cam.invfx, (p.y - cam.cy) * z * cam.invfy, z);
}

class KeyFrame {
 public:
  KeyFrame(int64_t id, const Frame& f, const SE3& T_cw, const CameraIntrinsics& cam,
           std::shared_ptr<const ScaleLevels> scale, Map* map);

  const int64_t id;
  const int frame_index;
  const double timestamp;
  Map* map;

  // Immutable features.
  const std::vector<cv::KeyPoint> keys_un;
  const cv::Mat descriptors;
  const std::vector<float> depth, u_right;
  /** Classifier labels. Fixed once local mapping has taken the keyframe;
   *  before that the late detection of its own image may relabel it
   *  (System::relabelKeyFrame, under the map's update_mutex). */
  std::vector<KeypointMeta> meta;
  const CameraIntrinsics cam;
  const std::shared_ptr<const ScaleLevels> scale;
  FeatureGrid grid;
  /** Bag of words and direct index (empty without a vocabulary). */
  BowVector bow;
  FeatureVector feat;

  size_t size() const { return keys_un.size(); }
  bool usable(size_t i) const { return meta.empty() || meta[i].label != KpLabel::Dynamic; }

  // Pose.
  const SE3& T_cw() const { return T_cw_; }
  const SE3& T_wc() const { return T_wc_; }
  Eigen::Vector3d center() const { return T_wc_.translation(); }
  void setPose(const SE3& T_cw) {
    T_cw_ = T_cw;
    T_wc_ = T_cw.inverse();
  }

  // Map points (one slot per keypoint, nullptr = none).
  std::vector<MapPointPtr> points;
  void addPoint(const MapPointPtr& p, int idx) { points[idx] = p; }
  void erasePoint(int idx) { points[idx].reset(); }
  void erasePoint(const MapPoint* p);
  /** Points that are not bad (ORB-SLAM GetMapPointMatches + bad filter). */
  std::vector<MapPointPtr> validPoints() const;
  /** Number of points observed by at least min_obs keyframes. */
  int trackedPoints(int min_obs) const;
  /** World position of keypoint i from its depth into `Xw`; false (Xw untouched) if it has no depth. */
  bool unprojectStereo(size_t i, Eigen::Vector3d& Xw) const;
  /** Median depth of the points in this keyframe (ORB-SLAM ComputeSceneMedianDepth). */
  float sceneMedianDepth() const;
  std::vector<size_t> featuresInArea(float x, float y, float r) const { return grid.featuresInArea(x, y, r); }

  // Covisibility graph.
  /** Recomputes covisibility edges from shared map points (threshold 15, ORB-SLAM). */
  void updateConnections();
  void addConnection(KeyFrame* kf, int weight);
  void eraseConnection(KeyFrame* kf);
  std::vector<KeyFrame*> bestCovisibles(size_t n) const;
  const std::vector<KeyFrame*>& covisibles() const { return ordered_conn_; }
  std::vector<KeyFrame*> covisiblesByWeight(int w) const;
  int weight(const KeyFrame* kf) const;
  const std::map<int64_t, std::pair<KeyFrame*, int>>& connections() const { return conn_; }

  // Spanning tree and loop edges.
  KeyFrame* parent = nullptr;
  std::map<int64_t, KeyFrame*> children;
  std::map<int64_t, KeyFrame*> loop_edges;
  void changeParent(KeyFrame* p);

  bool bad = false;
  bool not_erase = false;   ///< protected from culling (loop candidate)
  SE3 T_cp;                 ///< pose relative to the parent, kept when erased

  /** Removes the keyframe from the graph and the map (ORB-SLAM SetBadFlag). */
  void setBad();

  // Local mapping / loop closing scratch.
  int64_t ba_local_for_kf = -1, ba_fixed_for_kf = -1, fuse_target_for_kf = -1;
  int64_t track_reference_for_frame = -1;

 private:
  void updateBestCovisibles();
  SE3 T_cw_, T_wc_;
  std::map<int64_t, std::pair<KeyFrame*, int>> conn_;
  std::vector<KeyFrame*> ordered_conn_;
  std::vector<int> ordered_weights_;
  bool first_connection_ = true;
};

using KeyFramePtr = std::shared_ptr<KeyFrame>;

}  // namespace dslam
