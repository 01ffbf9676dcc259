#pragma once
/** \file map_point.h
 *  A 3D landmark (ORB-SLAM MapPoint). All mutable state is protected by the
 *  owning Map's `update_mutex` (see map.h); tracking-only scratch fields are
 *  touched by the tracking thread alone. */
#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "dslam/core/frame.h"

namespace dslam {

class KeyFrame;
class Map;

using Descriptor = std::array<uint8_t, 32>;

class MapPoint {
 public:
  MapPoint(int64_t id, const Eigen::Vector3d& pos, KeyFrame* ref_kf, Map* map);

  const int64_t id;
  const int64_t first_kf_id;
  Map* map;

  Eigen::Vector3d pos;                    ///< world position
  Eigen::Vector3d normal{0, 0, 1};        ///< mean viewing direction (unit)
  Descriptor desc{};                      ///< most distinctive descriptor of the observations
  KeyFrame* ref_kf = nullptr;
  float min_dist = 0, max_dist = 0;       ///< scale-invariance distance range
  bool bad = false;
  std::shared_ptr<MapPoint> replaced;     ///< set when fused into another point

  // Semantics carried from the keypoints that created the point.
  int16_t class_id = -1;
  int32_t object_id = -1;
  KpLabel label = KpLabel::Static;
  bool active = true;                     ///< persistence: inactive points take no part in tracking/loops
  int64_t map_object = -1;                ///< MapObject it belongs to (long-term data association), -1 = none

  /** kf id -> (kf, keypoint index), ordered by id (deterministic). */
  const std::map<int64_t, std::pair<KeyFrame*, int>>& observations() const { return obs_; }
  int numObservations() const { return n_obs_; }  ///< stereo observations count 2 (ORB-SLAM nObs)
  void addObservation(KeyFrame* kf, int idx);
  /** Removes the observation; marks the point bad when <= 2 observations remain. */
  void eraseObservation(KeyFrame* kf);
  int indexIn(const KeyFrame* kf) const;
  bool isIn(const KeyFrame* kf) const { return indexIn(kf) >= 0; }

  /** Recomputes `desc` as the observation descriptor with least median distance to the others. */
  void computeDistinctiveDescriptor();
  /** Its distinctive descriptor, then those of up to `max_views` of its
   *  observations (oldest keyframe first): how it looked from each view.
   *  The pointers live as long as the keyframes (hold the map's lock). */
  std::vector<const uint8_t*> descriptorViews(size_t max_views) const;
  /** Recomputes normal and min/max distance from the observations. */
  void updateNormalAndDepth();
  /** Whether distance `dist` is within its scale-invariance range, 0.8 x
   *  min_dist to 1.2 x max_dist (ORB-SLAM isInFrustum): beyond it the point's
   *  descriptor is not expected to match. */
  bool inScaleRange(float dist) const { return !(dist < 0.8f * min_dist || dist > 1.2f * max_dist); }
  /** Pyramid level at which the point should be seen from distance `dist`. */
  int predictScale(float dist, float log_scale_factor, int n_levels) const;

  /** Marks bad and removes it from every keyframe and the map. */
  void setBad();
  /** Moves every observation to `other` (fusion) and marks this point bad. */
  void replaceWith(const std::shared_ptr<MapPoint>& other);
  /** Follows `replaced` links to the surviving point. */
  static std::shared_ptr<MapPoint> resolve(std::shared_ptr<MapPoint> p);

  // Tracking statistics (atomics: tracking and mapping threads update them).
  std::atomic<int> n_visible{1}, n_found{1};
  float foundRatio() const { return static_cast<float>(n_found) / static_cast<float>(n_visible); }

  // Tracking-thread scratch (ORB-SLAM mTrack* fields).
  bool track_in_view = false;
  float track_proj_x = 0, track_proj_y = 0, track_proj_xr = 0, track_view_cos = 0;
  int track_scale_level = 0;
  int64_t track_reference_for_frame = -1, last_frame_seen = -1;
  // Local-mapping / loop-closing scratch.
  int64_t ba_local_for_kf = -1, fuse_candidate_for_kf = -1, loop_point_for_kf = -1, corrected_by_kf = -1;

 private:
  std::map<int64_t, std::pair<KeyFrame*, int>> obs_;
  int n_obs_ = 0;
};

using MapPointPtr = std::shared_ptr<MapPoint>;

}  // namespace dslam
