#include "dslam/core/camera.h"

#include <algorithm>
#include <cctype>

#include "dslam/core/error.h"

namespace dslam {

Eigen::Vector2d PinholeCamera::distort(double u, double v) const {
  const double x = (u - cx) / fx, y = (v - cy) / fy;
  const double k1 = dist[0], k2 = dist[1], p1 = dist[2], p2 = dist[3], k3 = dist[4];
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {fx * xd + cx, fy * yd + cy};
}

Eigen::Vector2d PinholeCamera::undistort(double u, double v) const {
  if (!hasDistortion()) return {u, v};
  const double k1 = dist[0], k2 = dist[1], p1 = dist[2], p2 = dist[3], k3 = dist[4];
  const double xd = (u - cx) / fx, yd = (v - cy) / fy;
  double x = xd, y = yd;
  // Fixed-point iteration as in cv::undistortPoints (more iterations for accuracy).
  for (int it = 0; it < 20; it++) {
    const double r2 = x * x + y * y;
    const double icdist = 1.0 / (1 + r2 * (k1 + r2 * (k2 + r2 * k3)));
    const double dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    const double dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    x = (xd - dx) * icdist;
    y = (yd - dy) * icdist;
  }
  return {fx * x + cx, fy * y + cy};
}

const char* toString(SensorType s) {
  switch (s) {
    case SensorType::Monocular: return "monocular";
    case SensorType::Stereo: return "stereo";
    case SensorType::RGBD: return "rgbd";
  }
  return "?";
}

SensorType sensorTypeFromString(const std::string& s) {
  std::string l = s;
  std::transform(l.begin(), l.end(), l.begin(), [](unsigned char c) { return std::tolower(c); });
  if (l == "monocular" || l == "mono") return SensorType::Monocular;
  if (l == "stereo") return SensorType::Stereo;
  if (l == "rgbd" || l == "rgb-d") return SensorType::RGBD;
  throw ConfigError("unknown sensor type '" + s + "' (valid: monocular, stereo, rgbd)");
}

}  // namespace dslam
