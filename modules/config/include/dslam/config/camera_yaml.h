#pragma once
/** \file camera_yaml.h
 *  The `camera:` section. Keys (all documented in docs/config.md):
 *  preset, name, sensor, width, height, fx, fy, cx, cy, dist, baseline, bf,
 *  depth_factor, depth_threshold, fps, rgb, rectified, right, T_left_right,
 *  T_body_cam. With `preset:` every other key is optional and overrides the
 *  preset; without it width/height/fx/fy/cx/cy are required. */
#include <string>
#include <vector>

#include "dslam/core/camera.h"
#include "dslam/core/params.h"

namespace dslam::config {

std::vector<ParamSpec> cameraParamSpecs();
/** Builds a camera from validated params; throws ConfigError naming the key. */
CameraModel cameraFromParams(const Params& p);
/** Fully resolved YAML text of a camera (every key). */
std::string cameraToYaml(const CameraModel& c);
/** Loads a camera YAML file (`camera:` map at top level or the map itself). */
CameraModel loadCameraFile(const std::string& path);
/** Parses a 4x4 (16 values) or 3x4 (12 values) row-major matrix. */
SE3 se3FromRowMajor(const std::vector<double>& v, const std::string& what);

}  // namespace dslam::config
