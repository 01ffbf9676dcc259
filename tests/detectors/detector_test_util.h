#pragma once
// Helpers shared by the detector tests.
#include <memory>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "dslam/core/detector.h"
#include "dslam/core/params.h"
#include "dslam/core/registry.h"

namespace dslam {
void register_detectors_plugins();
}

namespace dslam::test {

/** Creates and configures a detector plugin from YAML params text. */
inline std::shared_ptr<Detector> makeDetector(const std::string& type, const std::string& yaml = "",
                                              PluginContext ctx = {}) {
  static const bool once = (register_detectors_plugins(), true);
  (void)once;
  auto d = create<Detector>(type);
  const Params p = Params::resolve(d->paramSpecs(), yaml);
  d->configure(p, ctx);
  return d;
}

inline SensorFrame frameFromFile(const std::string& path, int index = 0) {
  SensorFrame f;
  f.index = index;
  f.image_path = path;
  f.image = cv::imread(path, cv::IMREAD_COLOR);
  return f;
}

/** Best IoU of a box of class `cls` against `ref`; -1 if none of that class. */
inline float bestIou(const Detections& d, int cls, const cv::Rect2f& ref) {
  float best = -1;
  for (const auto& b : d.boxes)
    if (b.class_id == cls) best = std::max(best, iou(b.box, ref));
  return best;
}

}  // namespace dslam::test
