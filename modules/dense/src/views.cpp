// renderView(): orthographic top / side pictures of the dense map with the
// trajectory drawn on them (OpenCV drawing, no GUI).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <Eigen/Eigenvalues>

#include <opencv2/imgproc.hpp>

#include "dslam/dense/dense_map.h"

namespace dslam::dense {

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

/** The up axis refined to the normal of the largest plane within 25 degrees
 *  of the cameras' mean up (floor, ceiling, table tops: horizontal), found by
 *  RANSAC and fitted by least squares; the cameras' up when there is none.
 *  (A camera pitched down tilts its up axis; the floor does not.) */
Eigen::Vector3d horizontalPlaneUp(const std::vector<Voxel>& vox, const Eigen::Vector3d& up0, double res) {
  if (vox.size() < 100) return up0;
  const size_t stride = std::max<size_t>(1, vox.size() / 5000);
  std::vector<Eigen::Vector3d> pts;
  for (size_t i = 0; i < vox.size(); i += stride) pts.push_back(vox[i].c);
  std::mt19937 rng(1);
  std::uniform_int_distribution<size_t> pick(0, pts.size() - 1);
  const double cos_max = std::cos(25.0 * M_PI / 180.0);
  size_t best = 0;
  Eigen::Vector3d best_n = up0, best_a = Eigen::Vector3d::Zero();
  for (int it = 0; it < 300; it++) {
    const Eigen::Vector3d a = pts[pick(rng)], b = pts[pick(rng)], c = pts[pick(rng)];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (n.dot(up0) < 0) n = -n;
    if (n.dot(up0) < cos_max) continue;
    size_t in = 0;
    for (const auto& q : pts) in += std::abs(n.dot(q - a)) <= res;
    if (in > best) best = in, best_n = n, best_a = a;
  }
  if (best < 30) return up0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> in;
  for (const auto& q : pts)
    if (std::abs(best_n.dot(q - best_a)) <= res) in.push_back(q), mean += q;
  mean /= static_cast<double>(in.size());
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (const auto& q : in) C += (q - mean) * (q - mean).transpose();
  Eigen::Vector3d n = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(C).eigenvectors().col(0);
  if (n.dot(up0) < 0) n = -n;
  return n.dot(up0) >= cos_max ? n : best_n;
}

}  // namespace

cv::Mat renderView(const std::vector<Voxel>& voxels, double resolution, const std::vector<SE3>& camera_T_wc,
                   const std::vector<SE3>& keyframe_T_wc, bool top, const DenseMapParams& p, const std::string& title) {
  // Axes: up = the normal of the dominant horizontal plane (start: the mean
  // camera up, -y of the camera), forward = the first camera's viewing
  // direction made horizontal, right = forward x up.
  const std::vector<SE3>& ref = keyframe_T_wc.empty() ? camera_T_wc : keyframe_T_wc;
  Eigen::Vector3d up(0, -1, 0), fwd(0, 0, 1);
  if (!ref.empty()) {
    up.setZero();
    for (const SE3& T : ref) up += T.rotation() * Eigen::Vector3d(0, -1, 0);
    up.normalize();
    fwd = ref.front().rotation() * Eigen::Vector3d(0, 0, 1);
  }
  up = horizontalPlaneUp(voxels, up, resolution);
  fwd -= up * fwd.dot(up);
  if (fwd.norm() < 1e-6) fwd = up.unitOrthogonal();
  fwd.normalize();
  const Eigen::Vector3d right = fwd.cross(up);
  // Image axes: top view x = right, y = -forward; side view x = forward, y = -up.
  auto imgX = [&](const Eigen::Vector3d& c) { return top ? c.dot(right) : c.dot(fwd); };
  auto imgY = [&](const Eigen::Vector3d& c) { return top ? -c.dot(fwd) : -c.dot(up); };
  auto depthKey = [&](const Eigen::Vector3d& c) { return top ? c.dot(up) : c.dot(right); };  // drawn ascending

  std::vector<Eigen::Vector3d> cams;
  for (const SE3& T : camera_T_wc) cams.push_back(T.translation());
  if (cams.empty())
    for (const SE3& T : keyframe_T_wc) cams.push_back(T.translation());
  double cam_hmax = -1e300, cam_amin = 1e300, cam_amax = -1e300;
  for (const auto& c : cams) {
    cam_hmax = std::max(cam_hmax, c.dot(up));
    cam_amin = std::min(cam_amin, c.dot(right));
    cam_amax = std::max(cam_amax, c.dot(right));
  }
  // Which voxels: the top view leaves out what is above the cameras (ceiling),
  // the side view is a section around the trajectory.
  std::vector<size_t> idx;
  for (size_t i = 0; i < voxels.size(); i++) {
    const Eigen::Vector3d& c = voxels[i].c;
    if (!cams.empty()) {
      if (top && c.dot(up) > cam_hmax + p.view_clip) continue;
      if (!top && (c.dot(right) < cam_amin - p.side_half_width || c.dot(right) > cam_amax + p.side_half_width)) continue;
    }
    idx.push_back(i);
  }
  std::vector<double> xs, ys, hs;
  for (size_t i : idx) {
    xs.push_back(imgX(voxels[i].c));
    ys.push_back(imgY(voxels[i].c));
    hs.push_back(voxels[i].c.dot(up));
  }
  // Extent: 0.5-99.5 percentiles of the voxels (a few stray ones do not
  // shrink the picture) and every camera position.
  double x0 = percentile(xs, 0.005), x1 = percentile(xs, 0.995), y0 = percentile(ys, 0.005), y1 = percentile(ys, 0.995);
  if (xs.empty()) x0 = y0 = 1e300, x1 = y1 = -1e300;
  for (const auto& c : cams) {
    x0 = std::min(x0, imgX(c)), x1 = std::max(x1, imgX(c));
    y0 = std::min(y0, imgY(c)), y1 = std::max(y1, imgY(c));
  }
  if (x0 > x1) x0 = -1, x1 = 1, y0 = -1, y1 = 1;
  x0 -= 0.2, x1 += 0.2, y0 -= 0.2, y1 += 0.2;
  const int margin = 40, header = 56;
  const double span = std::max({x1 - x0, y1 - y0, 0.5});
  const double s = (p.view_size - 2.0 * margin) / span;  // px per metre
  const int W = static_cast<int>(std::ceil((x1 - x0) * s)) + 2 * margin;
  const int H = static_cast<int>(std::ceil((y1 - y0) * s)) + 2 * margin + header;
  cv::Mat img(std::max(H, 200), std::max(W, 420), CV_8UC3, cv::Scalar(40, 40, 40));
  auto toPx = [&](double x, double y) {
    return cv::Point2d(margin + (x - x0) * s, header + margin + (y - y0) * s);
  };

  const double h_lo = percentile(hs, 0.02), h_hi = percentile(hs, 0.98);
  cv::Mat lut;
  {
    cv::Mat g(1, 256, CV_8U);
    for (int i = 0; i < 256; i++) g.at<uint8_t>(i) = static_cast<uint8_t>(i);
    cv::applyColorMap(g, lut, cv::COLORMAP_TURBO);
  }
  auto colourOf = [&](double h) {
    const double t = h_hi > h_lo ? std::clamp((h - h_lo) / (h_hi - h_lo), 0.0, 1.0) : 0.5;
    const cv::Vec3b c = lut.at<cv::Vec3b>(static_cast<int>(std::lround(t * 255)));
    return cv::Scalar(c[0], c[1], c[2]);
  };
  std::vector<size_t> order(idx.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return depthKey(voxels[idx[a]].c) < depthKey(voxels[idx[b]].c);
  });
  const double q = std::max(1.0, resolution * s);
  for (size_t k : order) {
    const cv::Point2d c = toPx(xs[k], ys[k]);
    const cv::Point a(static_cast<int>(std::floor(c.x - q / 2)), static_cast<int>(std::floor(c.y - q / 2)));
    const int e = static_cast<int>(std::ceil(q));
    cv::rectangle(img, cv::Rect(a.x, a.y, e, e), colourOf(hs[k]), cv::FILLED);
  }
  // Trajectory: white line with a dark outline, keyframes as yellow dots,
  // start green, end red.
  std::vector<cv::Point> line;
  for (const auto& c : cams) line.push_back(toPx(imgX(c), imgY(c)));
  if (line.size() >= 2) {
    cv::polylines(img, line, false, cv::Scalar(0, 0, 0), 4, cv::LINE_AA);
    cv::polylines(img, line, false, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  }
  for (const SE3& T : keyframe_T_wc) {
    const Eigen::Vector3d c = T.translation();
    cv::circle(img, toPx(imgX(c), imgY(c)), 3, cv::Scalar(0, 220, 255), cv::FILLED, cv::LINE_AA);
  }
  if (!line.empty()) {
    cv::circle(img, line.front(), 6, cv::Scalar(0, 200, 0), cv::FILLED, cv::LINE_AA);
    cv::circle(img, line.back(), 6, cv::Scalar(0, 0, 230), cv::FILLED, cv::LINE_AA);
  }
  // Header: title, height colour bar, scale bar.
  const cv::Scalar white(235, 235, 235);
  cv::putText(img, title, cv::Point(10, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, white, 1, cv::LINE_AA);
  const int bar_x = 10, bar_y = 32, bar_w = 160, bar_h = 12;
  for (int i = 0; i < bar_w; i++) {
    const cv::Vec3b c = lut.at<cv::Vec3b>(i * 255 / (bar_w - 1));
    cv::line(img, cv::Point(bar_x + i, bar_y), cv::Point(bar_x + i, bar_y + bar_h), cv::Scalar(c[0], c[1], c[2]));
  }
  char b[96];
  std::snprintf(b, sizeof(b), "height %.2f .. %.2f m", h_lo, h_hi);
  cv::putText(img, b, cv::Point(bar_x + bar_w + 8, bar_y + 11), cv::FONT_HERSHEY_SIMPLEX, 0.45, white, 1, cv::LINE_AA);
  double len = 1.0;
  for (double c : {0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0})
    if (c * s <= 150) len = c;
  const int sx = img.cols - 20 - static_cast<int>(len * s), sy = bar_y + bar_h;
  cv::line(img, cv::Point(sx, sy), cv::Point(img.cols - 20, sy), white, 2);
  std::snprintf(b, sizeof(b), "%g m", len);
  cv::putText(img, b, cv::Point(sx, sy - 4), cv::FONT_HERSHEY_SIMPLEX, 0.45, white, 1, cv::LINE_AA);
  cv::putText(img, top ? "looking down; up = forward of the first camera" : "section along the path; up = up",
              cv::Point(10, img.rows - 10), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(180, 180, 180), 1, cv::LINE_AA);
  return img;
}

}  // namespace dslam::dense
