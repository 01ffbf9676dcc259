// Fuzz target: camera YAML files (config::loadCameraFile, the `camera:`
// section with presets, intrinsics, stereo extrinsics) and its YAML dump.
#include "dslam/config/camera_yaml.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = dslam::fuzz::writeFile("camera.yaml", data, size);
  dslam::fuzz::guarded([&] {
    const auto cam = dslam::config::loadCameraFile(path);
    (void)dslam::config::cameraToYaml(cam);
  });
  return 0;
}
