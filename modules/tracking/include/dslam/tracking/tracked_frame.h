#pragma once
/** \file tracked_frame.h
 *  The frame being tracked: features plus map-point matches and pose
 *  (ORB-SLAM Frame's tracking fields). */
#include <memory>
#include <optional>
#include <vector>

#include "dslam/core/frame.h"
#include "dslam/features/feature_grid.h"
#include "dslam/map/keyframe.h"
#include "dslam/map/map_point.h"

namespace dslam {

struct TrackedFrame {
  Frame f;
  FeatureGrid grid;
  CameraIntrinsics cam;
  std::shared_ptr<const ScaleLevels> scale;
  std::vector<MapPointPtr> points;  ///< match per keypoint (nullptr = none)
  std::vector<char> outlier;        ///< set by pose optimisation
  std::optional<SE3> T_cw;          ///< estimated pose (nullopt until tracked)
  KeyFrame* ref_kf = nullptr;
  BowVector bow;        ///< computed on demand (relocalisation) when a vocabulary exists
  FeatureVector feat;

  TrackedFrame() = default;
  TrackedFrame(Frame frame, const CameraIntrinsics& c, std::shared_ptr<const ScaleLevels> s)
      : f(std::move(frame)), grid(f.keypoints_un, c.bounds), cam(c), scale(std::move(s)),
        points(f.keypoints_un.size()), outlier(f.keypoints_un.size(), 0) {}

  size_t size() const { return f.keypoints_un.size(); }
  bool usable(size_t i) const { return f.usable(i); }
  bool hasStereo(size_t i) const { return i < f.u_right.size() && f.u_right[i] >= 0; }
  Eigen::Vector3d center() const { return T_cw->inverse().translation(); }
  /** Keypoint i back-projected with its depth into the world (false if none). */
  bool unprojectStereo(size_t i, Eigen::Vector3d& Xw) const {
    if (!T_cw || i >= f.depth.size() || f.depth[i] <= 0) return false;
    const float z = f.depth[i];
    Xw = T_cw->inverse() * backProject(cam, f.keypoints_un[i].pt, z);
    return true;
  }
  int numMatches() const {
    int n = 0;
    for (size_t i = 0; i < points.size(); i++) n += (points[i] && !outlier[i]);
    return n;
  }
};

}  // namespace dslam
