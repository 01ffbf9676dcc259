#include "dslam/slam/detection_carry.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace dslam {

namespace {

float median(std::vector<float> v) {
  if (v.empty()) return 0.f;
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(m), v.end());
  return v[m];
}

cv::Rect clampRect(const cv::Rect& r, const cv::Size& s) { return r & cv::Rect(0, 0, s.width, s.height); }

/** Pastes the pixels of `src` equal to `value` inside `roi`, shifted by
 *  `shift`, into `dst` (same size). */
template <class T>
void pasteShifted(const cv::Mat& src, cv::Mat& dst, const cv::Rect& roi, T value, cv::Point shift) {
  for (int y = roi.y; y < roi.y + roi.height; y++) {
    const int yd = y + shift.y;
    if (yd < 0 || yd >= dst.rows) continue;
    const T* s = src.ptr<T>(y);
    T* d = dst.ptr<T>(yd);
    for (int x = roi.x; x < roi.x + roi.width; x++) {
      const int xd = x + shift.x;
      if (s[x] == value && xd >= 0 && xd < dst.cols) d[xd] = value;
    }
  }
}

}  // namespace

RegionMotion regionMotion(const cv::Mat& from, const cv::Mat& to, const cv::Rect& roi_in, const cv::Mat& mask,
                          const CarryParams& p) {
  RegionMotion m;
  const cv::Rect roi = clampRect(roi_in, from.size());
  if (roi.width < 4 || roi.height < 4 || from.empty() || to.empty() || from.size() != to.size()) return m;
  std::vector<cv::Point2f> p0;
  cv::goodFeaturesToTrack(from(roi), p0, p.max_corners, 0.01, 3, mask.empty() ? cv::noArray() : mask(roi), 3);
  if (static_cast<int>(p0.size()) < p.min_points) return m;
  for (auto& q : p0) q += cv::Point2f(static_cast<float>(roi.x), static_cast<float>(roi.y));
  std::vector<cv::Point2f> p1, back;
  std::vector<uchar> st1, st2;
  std::vector<float> err;
  const cv::Size win(p.lk_window, p.lk_window);
  const cv::TermCriteria tc(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);
  cv::calcOpticalFlowPyrLK(from, to, p0, p1, st1, err, win, p.lk_levels - 1, tc);
  cv::calcOpticalFlowPyrLK(to, from, p1, back, st2, err, win, p.lk_levels - 1, tc);
  std::vector<cv::Point2f> a, b;
  for (size_t i = 0; i < p0.size(); i++) {
    if (!st1[i] || !st2[i]) continue;
    const cv::Point2f e = back[i] - p0[i];
    if (std::hypot(e.x, e.y) > p.max_fb_error) continue;
    a.push_back(p0[i]);
    b.push_back(p1[i]);
  }
  if (static_cast<int>(a.size()) < p.min_points) return m;
  std::vector<float> dx, dy;
  for (size_t i = 0; i < a.size(); i++) {
    dx.push_back(b[i].x - a[i].x);
    dy.push_back(b[i].y - a[i].y);
  }
  m.shift = {median(dx), median(dy)};
  m.points = static_cast<int>(a.size());
  // Scale: median ratio of the distances to the median point, after / before.
  std::vector<float> ax, ay, bx, by;
  for (size_t i = 0; i < a.size(); i++) {
    ax.push_back(a[i].x);
    ay.push_back(a[i].y);
    bx.push_back(b[i].x);
    by.push_back(b[i].y);
  }
  const cv::Point2f ca(median(ax), median(ay)), cb(median(bx), median(by));
  std::vector<float> ratios;
  for (size_t i = 0; i < a.size(); i++) {
    const float da = std::hypot(a[i].x - ca.x, a[i].y - ca.y);
    if (da > 3.f) ratios.push_back(std::hypot(b[i].x - cb.x, b[i].y - cb.y) / da);
  }
  if (ratios.size() >= 3) m.scale = std::clamp(median(ratios), 0.5f, 2.f);
  return m;
}

Detections carryDetections(const Detections& d, const cv::Mat& from, const cv::Mat& to, int age,
                           const CarryParams& p) {
  Detections out = d;
  out.age_frames = age;
  if (from.empty() || to.empty() || from.data == to.data) return out;
  const cv::Size size = from.size();
  // Boxes: corners of the central part; moved and scaled about their centre.
  for (auto& bb : out.boxes) {
    const cv::Rect2f& r = bb.box;
    const float f = static_cast<float>(p.inner_fraction);
    const cv::Rect inner(cvRound(r.x + r.width * (1 - f) / 2), cvRound(r.y + r.height * (1 - f) / 2),
                         cvRound(r.width * f), cvRound(r.height * f));
    const RegionMotion m = regionMotion(from, to, inner, cv::Mat(), p);
    if (m.points == 0) continue;
    const cv::Point2f c(r.x + r.width / 2 + m.shift.x, r.y + r.height / 2 + m.shift.y);
    const float w = r.width * m.scale, h = r.height * m.scale;
    bb.box = cv::Rect2f(c.x - w / 2, c.y - h / 2, w, h);
  }
  // Panoptic segments: each moved by its own flow (translation).
  if (!d.panoptic.empty() && d.panoptic.size() == size) {
    out.panoptic = cv::Mat(size, CV_32S, cv::Scalar(0));  // a new buffer (d's is shared by the copy)
    for (auto& seg : out.segments) {
      const cv::Rect roi = clampRect(seg.bbox, size);
      if (roi.area() == 0) continue;
      cv::Mat mask = cv::Mat::zeros(size, CV_8U);
      mask(roi).setTo(255, d.panoptic(roi) == seg.id);
      const RegionMotion m = regionMotion(from, to, roi, mask, p);
      const cv::Point s(cvRound(m.shift.x), cvRound(m.shift.y));
      pasteShifted<int32_t>(d.panoptic, out.panoptic, roi, seg.id, s);
      seg.bbox = clampRect(seg.bbox + s, size);
    }
  }
  // Semantic image: each connected region of each class moved by its flow.
  if (!d.semantic.empty() && d.semantic.size() == size) {
    out.semantic = cv::Mat(size, CV_8U, cv::Scalar(255));
    bool present[256] = {false};
    for (int y = 0; y < size.height; y++) {
      const uchar* row = d.semantic.ptr<uchar>(y);
      for (int x = 0; x < size.width; x++) present[row[x]] = true;
    }
    for (int c = 0; c < 255; c++) {
      if (!present[c]) continue;
      const cv::Mat cls = d.semantic == c;
      cv::Mat labels, stats, centroids;
      const int n = cv::connectedComponentsWithStats(cls, labels, stats, centroids, 8, CV_32S);
      for (int k = 1; k < n; k++) {
        const cv::Rect roi(stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP),
                           stats.at<int>(k, cv::CC_STAT_WIDTH), stats.at<int>(k, cv::CC_STAT_HEIGHT));
        const cv::Mat comp = labels == k;
        const RegionMotion m = regionMotion(from, to, roi, comp, p);
        const cv::Point s(cvRound(m.shift.x), cvRound(m.shift.y));
        for (int y = roi.y; y < roi.y + roi.height; y++) {
          const int yd = y + s.y;
          if (yd < 0 || yd >= size.height) continue;
          const int* l = labels.ptr<int>(y);
          uchar* o = out.semantic.ptr<uchar>(yd);
          for (int x = roi.x; x < roi.x + roi.width; x++) {
            const int xd = x + s.x;
            if (l[x] == k && xd >= 0 && xd < size.width) o[xd] = static_cast<uchar>(c);
          }
        }
      }
    }
  }
  return out;
}

}  // namespace dslam
