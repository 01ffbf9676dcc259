// Rawlog helpers (rawlog_util.h): cameras from MRPT observations and back,
// poses, and the registration of a depth image into the colour camera.
#include "rawlog_util.h"

#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DQuat.h>

#include <algorithm>
#include <cmath>

#include "dslam/core/error.h"

using namespace mrpt::obs;

namespace dslam {

namespace rawlog {

PinholeCamera fromTCamera(const mrpt::img::TCamera& c, const std::string& what) {
  if (c.distortion == mrpt::img::DistortionModel::kannala_brandt)
    throw DataError(what + ": Kannala-Brandt (fisheye) distortion is not supported");
  PinholeCamera p;
  p.width = static_cast<int>(c.ncols);
  p.height = static_cast<int>(c.nrows);
  p.fx = c.fx();
  p.fy = c.fy();
  p.cx = c.cx();
  p.cy = c.cy();
  if (c.distortion == mrpt::img::DistortionModel::plumb_bob)
    for (size_t k = 0; k < 5; k++) p.dist[k] = c.dist[k];
  return p;
}

mrpt::img::TCamera toTCamera(const PinholeCamera& p, const std::string& name) {
  mrpt::img::TCamera c;
  c.cameraName = name;
  c.ncols = static_cast<uint32_t>(p.width);
  c.nrows = static_cast<uint32_t>(p.height);
  c.setIntrinsicParamsFromValues(p.fx, p.fy, p.cx, p.cy);
  c.distortion = p.hasDistortion() ? mrpt::img::DistortionModel::plumb_bob : mrpt::img::DistortionModel::none;
  c.dist.fill(0);
  for (size_t k = 0; k < 5; k++) c.dist[k] = p.dist[k];
  return c;
}

SE3 toSE3(const mrpt::poses::CPose3D& p) {
  const auto M = p.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  return SE3(Eigen::Matrix4d(M.asEigen()));
}

/** Pose of the depth camera's optical frame (z forward) in MRPT's
 *  X-forward range-scan frame: the pure rotation (0,0,0,-90,0,-90). */
static const mrpt::poses::CPose3D& opticalInScanFrame() {
  static const mrpt::poses::CPose3D R0(0, 0, 0, mrpt::DEG2RAD(-90.0), 0, mrpt::DEG2RAD(-90.0));
  return R0;
}

SE3 intensityFromDepth(const CObservation3DRangeScan& o) {
  // MRPT projects a point p (X-forward depth frame) into the intensity
  // camera as relativePoseIntensityWRTDepth^-1 * p; p = R0 * p_optical.
  return toSE3(o.relativePoseIntensityWRTDepth).inverse() * toSE3(opticalInScanFrame());
}

std::string describeObs(const CObservation& o) {
  return "observation '" + o.sensorLabel + "' (" + o.GetRuntimeClass()->className + ")";
}

cv::Mat rangeToMat(const mrpt::math::CMatrix_u16& r) {
  cv::Mat m(static_cast<int>(r.rows()), static_cast<int>(r.cols()), CV_16UC1);
  for (int y = 0; y < m.rows; y++) {
    auto* row = m.ptr<uint16_t>(y);
    for (int x = 0; x < m.cols; x++) row[x] = r(y, x);
  }
  return m;
}

cv::Mat registerDepth(const cv::Mat& depth, const PinholeCamera& kd, const PinholeCamera& ki, const SE3& T_i_d) {
  cv::Mat out(ki.height, ki.width, CV_32F, cv::Scalar(0));
  const Eigen::Matrix3f R = T_i_d.rotation().cast<float>();
  const Eigen::Vector3f t = T_i_d.translation().cast<float>();
  const float fxd = static_cast<float>(kd.fx), fyd = static_cast<float>(kd.fy);
  const float cxd = static_cast<float>(kd.cx), cyd = static_cast<float>(kd.cy);
  const float fxi = static_cast<float>(ki.fx), fyi = static_cast<float>(ki.fy);
  const float cxi = static_cast<float>(ki.cx), cyi = static_cast<float>(ki.cy);
  auto project = [&](float u, float v, float z, float& pu, float& pv, float& pz) {
    const Eigen::Vector3f P((u - cxd) / fxd * z, (v - cyd) / fyd * z, z);
    const Eigen::Vector3f Q = R * P + t;
    pz = Q.z();
    if (pz <= 0) return false;
    pu = fxi * Q.x() / pz + cxi;
    pv = fyi * Q.y() / pz + cyi;
    return true;
  };
  for (int v = 0; v < depth.rows; v++) {
    const float* row = depth.ptr<float>(v);
    for (int u = 0; u < depth.cols; u++) {
      const float z = row[u];
      if (!(z > 0)) continue;
      float cu, cv_, cz, u0, v0, z0, u1, v1, z1;
      if (!project(static_cast<float>(u), static_cast<float>(v), z, cu, cv_, cz)) continue;
      // Footprint of the source pixel in the target image (librealsense's
      // align: the projected corners, rounded, inclusive).
      if (!project(u - 0.5f, v - 0.5f, z, u0, v0, z0) || !project(u + 0.5f, v + 0.5f, z, u1, v1, z1)) continue;
      int x0 = static_cast<int>(std::lround(std::min(u0, u1))), x1 = static_cast<int>(std::lround(std::max(u0, u1)));
      int y0 = static_cast<int>(std::lround(std::min(v0, v1))), y1 = static_cast<int>(std::lround(std::max(v0, v1)));
      if (x1 < 0 || y1 < 0 || x0 >= out.cols || y0 >= out.rows) continue;
      x0 = std::max(x0, 0);
      y0 = std::max(y0, 0);
      x1 = std::min(x1, out.cols - 1);
      y1 = std::min(y1, out.rows - 1);
      for (int y = y0; y <= y1; y++) {
        float* o = out.ptr<float>(y);
        for (int x = x0; x <= x1; x++)
          if (o[x] == 0 || cz < o[x]) o[x] = cz;
      }
    }
  }
  return out;
}

bool needsRegistration(const CObservation3DRangeScan& o) {
  const auto& a = o.cameraParams;
  const auto& b = o.cameraParamsIntensity;
  const auto same = [](double x, double y) { return std::abs(x - y) <= 1e-6 * std::max(1.0, std::abs(x)); };
  const bool same_k = same(a.fx(), b.fx()) && same(a.fy(), b.fy()) && same(a.cx(), b.cx()) && same(a.cy(), b.cy());
  const bool same_size = o.rangeImage.cols() == static_cast<int>(b.ncols) && o.rangeImage.rows() == static_cast<int>(b.nrows);
  return !(same_k && same_size && o.doDepthAndIntensityCamerasCoincide());
}

}  // namespace rawlog

}  // namespace dslam
