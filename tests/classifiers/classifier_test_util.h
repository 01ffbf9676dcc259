#pragma once
// Helpers for the keypoint-classifier tests: plugin creation from YAML,
// hand-made frames and detections.
#include <gtest/gtest.h>

#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/registry.h"
#include "dslam/plugins/classifiers/register.h"

namespace dslam::test {

/** Creates "dslam::<name>" through the registry and configures it from YAML. */
template <class T>
std::shared_ptr<T> makeClassifier(const std::string& name, const std::string& yaml = "",
                                  const CameraModel* cam = nullptr) {
  static std::once_flag once;
  std::call_once(once, [] { register_classifiers_plugins(); });
  auto p = create<KeypointClassifier>("dslam::" + name);
  EXPECT_TRUE(p) << name;
  PluginContext ctx;
  ctx.camera = cam;
  p->configure(Params::resolve(p->paramSpecs(), yaml), ctx);
  auto t = std::dynamic_pointer_cast<T>(p);
  EXPECT_TRUE(t) << name;
  return t;
}

/** Frame of size `size` (black grey image) with keypoints at `pts`
 *  (keypoints_un = keypoints, angle 0, octave 0), meta reset. */
inline Frame makeFrame(const std::vector<cv::Point2f>& pts, cv::Size size = {640, 480}, int index = 0,
                       double timestamp = 0) {
  Frame f;
  f.input.index = index;
  f.input.timestamp = timestamp;
  f.gray = cv::Mat::zeros(size, CV_8U);
  for (const auto& p : pts) f.keypoints.emplace_back(p, 7.f, 0.f, 1.f, 0);
  f.keypoints_un = f.keypoints;
  f.depth.assign(pts.size(), -1.f);
  f.u_right.assign(pts.size(), -1.f);
  f.resetMeta();
  return f;
}

inline BoundingBox box(float x, float y, float w, float h, int cls, float score = 0.9f, int instance = -1) {
  BoundingBox b;
  b.box = cv::Rect2f(x, y, w, h);
  b.class_id = cls;
  b.score = score;
  b.instance_id = instance;
  return b;
}

inline CameraModel pinhole(double f = 500, int w = 640, int h = 480) {
  CameraModel c;
  c.name = "test";
  c.sensor = SensorType::RGBD;
  c.left.width = w;
  c.left.height = h;
  c.left.fx = c.left.fy = f;
  c.left.cx = w / 2.0;
  c.left.cy = h / 2.0;
  c.fps = 30;
  return c;
}

/** Random 32-byte ORB-like descriptors, one row each. */
inline cv::Mat randomDescriptors(int n, uint64_t seed) {
  cv::Mat d(n, 32, CV_8U);
  cv::RNG rng(seed);
  rng.fill(d, cv::RNG::UNIFORM, 0, 256);
  return d;
}

}  // namespace dslam::test
