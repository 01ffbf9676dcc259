#pragma once
/** \file matcher.h
 *  Descriptor matching guided by geometry (ORB-SLAM2 ORBmatcher): search by
 *  projection, matching against a keyframe, triangulation candidates along
 *  epipolar lines, fusion of duplicated map points. Keypoints marked
 *  dynamic by a classifier are never matched. */
#include <set>
#include <vector>

#include <Eigen/Core>

#include "dslam/map/keyframe.h"
#include "dslam/map/map_point.h"
#include "dslam/tracking/tracked_frame.h"

namespace dslam {

struct MatcherParams {
  int th_high = 100;      ///< ORB-SLAM TH_HIGH
  int th_low = 50;        ///< ORB-SLAM TH_LOW
  float nn_ratio = 0.8f;  ///< best / second best
  bool check_orientation = true;
  int histo_length = 30;
};

class Matcher {
 public:
  explicit Matcher(const MatcherParams& p = {}) : p_(p) {}
  Matcher(float nn_ratio, bool check_orientation) {
    p_.nn_ratio = nn_ratio;
    p_.check_orientation = check_orientation;
  }

  /** Local-map points (with track_* fields filled by the tracker) into F. */
  int searchByProjection(TrackedFrame& F, const std::vector<MapPointPtr>& points, float th) const;
  /** Points of the last frame projected with the current pose estimate (motion model). */
  int searchByProjection(TrackedFrame& cur, const TrackedFrame& last, float th, bool stereo) const;
  /** Points of a keyframe not yet found, projected with F's pose (relocalisation). */
  int searchByProjection(TrackedFrame& F, KeyFrame* kf, const std::set<const MapPoint*>& found, float th,
                         int orb_dist) const;
  /** Brute-force descriptor matching of kf's map points into F with the NN ratio
   *  and orientation checks (ORB-SLAM SearchByBoW without the vocabulary). */
  int searchByDescriptors(KeyFrame* kf, TrackedFrame& F) const;
  /** Keyframe map points matched to F's keypoints within the same vocabulary
   *  node (ORB-SLAM SearchByBoW); brute force when either side has no
   *  feature vector. */
  int searchByBoW(KeyFrame* kf, TrackedFrame& F) const;
  /** Map points of kf1 matched to map points of kf2 (loop candidates):
   *  matches12[i] = point of kf2 matched to kf1's keypoint i. */
  int searchByBoW(KeyFrame* kf1, KeyFrame* kf2, std::vector<MapPointPtr>& matches12) const;
  /** More kf1<->kf2 point matches by projecting with T12 (kf2 camera -> kf1
   *  camera) both ways, keeping mutual matches (ORB-SLAM SearchBySim3). */
  int searchBySE3(KeyFrame* kf1, KeyFrame* kf2, std::vector<MapPointPtr>& matches12, const SE3& T12, float th) const;
  /** Points projected into kf with pose T_cw (the corrected pose of a loop):
   *  fills matched[i] for keypoints without a match yet (ORB-SLAM
   *  SearchByProjection with Scw). */
  int searchByProjection(KeyFrame* kf, const SE3& T_cw, const std::vector<MapPointPtr>& points,
                         std::vector<MapPointPtr>& matched, float th) const;
  /** Fuses `points` into kf projected with T_cw; where kf already has a
   *  point, replace[i] gets it (the caller replaces it by points[i]). */
  int fuse(KeyFrame* kf, const SE3& T_cw, const std::vector<MapPointPtr>& points, float th,
           std::vector<MapPointPtr>& replace) const;

  /** Candidate pairs (i1, i2) of keypoints without map points satisfying the
   *  epipolar constraint x1^T F12 x2 = 0 (ORB-SLAM SearchForTriangulation). */
  int searchForTriangulation(const KeyFrame* kf1, const KeyFrame* kf2, const Eigen::Matrix3d& F12,
                             std::vector<std::pair<int, int>>& pairs, bool only_stereo) const;
  /** Projects points into kf and fuses duplicates (ORB-SLAM Fuse). Returns fusions. */
  int fuse(KeyFrame* kf, const std::vector<MapPointPtr>& points, float th = 3.0f) const;

  static float radiusByViewingCos(float view_cos) { return view_cos > 0.998f ? 2.5f : 4.0f; }
  const MatcherParams& params() const { return p_; }

 private:
  /** Keeps the matches of the three main rotation-histogram bins. */
  void orientationFilter(const std::vector<float>& rot_diff, std::vector<int>& match_ids,
                         std::vector<bool>& keep) const;
  /** orientationFilter, then resets points[ids[k]] of every rejected match; returns how many. */
  template <class ForEachPair>
  int matchKeyFrameToFrame(KeyFrame* kf, TrackedFrame& F, ForEachPair&& for_each_pair) const;
  int dropByOrientation(const std::vector<float>& rot_diff, std::vector<int>& ids, std::vector<MapPointPtr>& points) const;
  MatcherParams p_;
};

/** Fundamental matrix F12 with x1^T F12 x2 = 0 between two keyframes. */
Eigen::Matrix3d fundamental12(const KeyFrame* kf1, const KeyFrame* kf2);

}  // namespace dslam
