#pragma once
// Small exact worlds for unit tests of the map, matcher, local mapper and
// keyframe database: known 3D points, each with its own random ORB
// descriptor, seen by RGB-D frames at known poses (keypoints at the exact
// projections, level 0, depth = true depth). Seeded, header-only.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "dslam/map/keyframe.h"
#include "dslam/map/map.h"
#include "dslam/map/map_point.h"
#include "dslam/tracking/tracked_frame.h"

namespace dslam::test {

/** Camera 640x480, f = 500, principal point (320, 240), bf = 40 (a Kinect
 *  in ORB-SLAM2), close depth 3.2 m. */
inline CameraIntrinsics synthIntrinsics() {
  CameraIntrinsics c;
  c.fx = c.fy = 500;
  c.cx = 320;
  c.cy = 240;
  c.invfx = c.invfy = 1.f / 500;
  c.bf = 40;
  c.close_depth = 3.2f;
  c.bounds = {0, 640, 0, 480};
  return c;
}

/** Camera-from-world pose of a camera at `centre` looking along +z, turned
 *  by `yaw_deg` about the y axis. */
inline SE3 poseAt(const Eigen::Vector3d& centre, double yaw_deg = 0) {
  const Eigen::Quaterniond R(Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()));
  return SE3(R, centre).inverse();
}

struct SynthWorld {
  CameraIntrinsics cam = synthIntrinsics();
  std::shared_ptr<const ScaleLevels> scale = std::make_shared<const ScaleLevels>(ScaleLevels::make(8, 1.2f));
  std::vector<Eigen::Vector3d> X;  ///< world points
  std::vector<Descriptor> desc;    ///< one random descriptor per point (pairwise distance ~128)

  /** n points in x in [-2, 2], y in [-1.5, 1.5], z in [z_min, z_max] (in
   *  front of a camera near the origin looking along +z; beyond the close
   *  depth of 3.2 m by default). */
  explicit SynthWorld(int n = 300, unsigned seed = 7, double z_min = 3, double z_max = 5) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(-2, 2), uy(-1.5, 1.5), uz(z_min, z_max);
    std::uniform_int_distribution<int> byte(0, 255);
    for (int i = 0; i < n; i++) {
      X.emplace_back(ux(rng), uy(rng), uz(rng));
      Descriptor d;
      for (auto& b : d) b = static_cast<uint8_t>(byte(rng));
      desc.push_back(d);
    }
  }

  /** An RGB-D frame seeing every point that projects into the image from
   *  T_cw (keypoints in world-point order). `seen[k]` = world point of
   *  keypoint k. Every keypoint has the angle `angle_deg`. */
  Frame frame(const SE3& T_cw, int index, std::vector<int>* seen = nullptr, float angle_deg = 0) const {
    Frame f;
    f.input.index = index;
    f.input.timestamp = index / 30.0;
    std::vector<int> which;
    for (size_t i = 0; i < X.size(); i++) {
      const Eigen::Vector3d Xc = T_cw * X[i];
      if (Xc.z() < 0.5) continue;
      const double u = cam.fx * Xc.x() / Xc.z() + cam.cx, v = cam.fy * Xc.y() / Xc.z() + cam.cy;
      if (!cam.bounds.contains(static_cast<float>(u), static_cast<float>(v))) continue;
      cv::KeyPoint k(static_cast<float>(u), static_cast<float>(v), 31.f, angle_deg, 50.f, 0);
      f.keypoints.push_back(k);
      f.depth.push_back(static_cast<float>(Xc.z()));
      f.u_right.push_back(static_cast<float>(u - cam.bf / Xc.z()));
      which.push_back(static_cast<int>(i));
    }
    f.keypoints_un = f.keypoints;
    f.descriptors = cv::Mat(static_cast<int>(which.size()), 32, CV_8U);
    for (size_t k = 0; k < which.size(); k++)
      std::copy(desc[which[k]].begin(), desc[which[k]].end(), f.descriptors.ptr<uint8_t>(static_cast<int>(k)));
    f.resetMeta();
    if (seen) *seen = which;
    return f;
  }

  TrackedFrame tracked(const SE3& T_cw, int index, std::vector<int>* seen = nullptr, float angle_deg = 0) const {
    TrackedFrame t(frame(T_cw, index, seen, angle_deg), cam, scale);
    t.T_cw = T_cw;
    return t;
  }

  KeyFramePtr keyframe(Map& m, const SE3& T_cw, int index, std::vector<int>* seen = nullptr) const {
    return std::make_shared<KeyFrame>(Map::nextKeyFrameId(), frame(T_cw, index, seen), T_cw, cam, scale, &m);
  }

  /** A map point of world point i, observed by `kf` at keypoint `idx`
   *  (descriptor, normal and depth range updated), added to the map. */
  MapPointPtr point(Map& m, int i, KeyFrame* kf, int idx) const {
    auto mp = std::make_shared<MapPoint>(Map::nextPointId(), X[i], kf, &m);
    kf->addPoint(mp, idx);
    mp->addObservation(kf, idx);
    mp->computeDistinctiveDescriptor();
    mp->updateNormalAndDepth();
    m.addPoint(mp);
    return mp;
  }
};

/** Index of world point `i` among the keypoints of a frame (`seen` as filled
 *  by SynthWorld::frame), -1 if not seen. */
inline int keypointOf(const std::vector<int>& seen, int i) {
  for (size_t k = 0; k < seen.size(); k++)
    if (seen[k] == i) return static_cast<int>(k);
  return -1;
}

}  // namespace dslam::test
