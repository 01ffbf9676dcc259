#pragma once
/** \file camera_presets.h
 *  Published calibrations of the public datasets. The YAML files in config/cameras hold
 *  the same values in YAML (a test checks they agree). */
#include <optional>
#include <string>
#include <vector>

#include "dslam/core/camera.h"

namespace dslam {

/** Preset names: tum_fr1, tum_fr2, tum_fr3, bonn, kitti_00_02, kitti_03,
 *  kitti_04_12, euroc (rectified, as ORB-SLAM's EuRoC.yaml). */
std::vector<std::string> cameraPresetNames();
/** The preset or nullopt. */
std::optional<CameraModel> cameraPreset(const std::string& name);

}  // namespace dslam
