#pragma once
/** \file camera.h
 *  Camera models: pinhole with radial-tangential distortion, stereo rig,
 *  RGB-D (pinhole + depth factor). The YAML form is documented in
 *  docs/config.md ("camera" section) and parsed by dslam::parseCamera()
 *  (dslam/config/camera_yaml.h). */
#include <array>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "dslam/core/se3.h"

namespace dslam {

/** Pinhole intrinsics with OpenCV's radial-tangential distortion
 *  (k1, k2, p1, p2, k3). */
struct PinholeCamera {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> dist{0, 0, 0, 0, 0};  ///< k1 k2 p1 p2 k3

  bool valid() const { return width > 0 && height > 0 && fx > 0 && fy > 0; }
  /** Whether (cx, cy) lies in the image (borders included). Outside, the
   *  calibration is wrong (a typo, cx/cy swapped with width/height): every
   *  camera of a SLAM dataset has it near the centre. */
  bool principalPointInside() const { return cx >= 0 && cx <= width && cy >= 0 && cy <= height; }
  bool hasDistortion() const {
    for (double d : dist)
      if (d != 0.0) return true;
    return false;
  }
  /** Projection of a point in the camera frame (no distortion). */
  Eigen::Vector2d project(const Eigen::Vector3d& p) const {
    return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
  }
  /** Back-projection of an undistorted pixel at depth z. */
  Eigen::Vector3d unproject(double u, double v, double z) const {
    return {(u - cx) * z / fx, (v - cy) * z / fy, z};
  }
  bool inImage(double u, double v, double border = 0) const {
    return u >= border && v >= border && u < width - border && v < height - border;
  }
  /** Applies the distortion model to an ideal pixel (u,v). */
  Eigen::Vector2d distort(double u, double v) const;
  /** Removes distortion from a pixel (iterative, as cv::undistortPoints). */
  Eigen::Vector2d undistort(double u, double v) const;
};

enum class SensorType { Monocular, Stereo, RGBD };

const char* toString(SensorType s);
/** Parses "monocular" | "stereo" | "rgbd" (case-insensitive); throws ConfigError. */
SensorType sensorTypeFromString(const std::string& s);

/** The camera of a pipeline. For stereo, `left` is the reference camera; if
 *  `rectified` is false the pair is rectified at start-up from `right`,
 *  `T_left_right` (EuRoC style) and `left`. For RGB-D, `baseline` is the
 *  virtual baseline used for the virtual right coordinate (ORB-SLAM2's
 *  `Camera.bf / fx`). */
struct CameraModel {
  std::string name;
  SensorType sensor = SensorType::RGBD;
  PinholeCamera left;
  PinholeCamera right;               ///< stereo only (unrectified rigs)
  SE3 T_left_right;                  ///< pose of the right camera in the left frame
  SE3 T_body_cam;                    ///< camera pose in the body frame (EuRoC T_BS)
  bool rectified = true;
  double baseline = 0.0;             ///< metres (stereo) / virtual (RGB-D)
  double depth_factor = 5000.0;      ///< raw depth units per metre (RGB-D)
  double depth_threshold = 40.0;     ///< close/far limit, in baselines (ORB-SLAM ThDepth)
  double fps = 30.0;
  bool rgb_order = true;             ///< colour images stored RGB (true) or BGR

  double bf() const { return baseline * left.fx; }
  /** Depth (m) below which stereo/RGB-D points count as "close". */
  double closeDepth() const { return depth_threshold * baseline; }
  bool valid() const { return left.valid(); }
};

}  // namespace dslam
