#include "dslam/slam/detection_carry.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
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

/** Whether two 8-bit grey images have the same size and pixels. */
bool samePixels(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  const size_t row = static_cast<size_t>(a.cols) * a.elemSize();
  for (int y = 0; y < a.rows; y++)
    if (std::memcmp(a.ptr(y), b.ptr(y), row) != 0) return false;
  return true;
}

/** One region to move: `mask` (CV_8U, roi-sized, non-zero = inside) or empty
 *  for the whole roi. */
struct Region {
  cv::Rect roi;
  cv::Mat mask;
};

/** Shift and scale from the corner pairs a -> b. */
RegionMotion motionFromPairs(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  RegionMotion m;
  std::vector<float> dx, dy, ax, ay, bx, by;
  for (size_t i = 0; i < a.size(); i++) {
    dx.push_back(b[i].x - a[i].x);
    dy.push_back(b[i].y - a[i].y);
    ax.push_back(a[i].x);
    ay.push_back(a[i].y);
    bx.push_back(b[i].x);
    by.push_back(b[i].y);
  }
  m.shift = {median(dx), median(dy)};
  m.points = static_cast<int>(a.size());
  // Scale: median ratio of the distances to the median point, after / before.
  const cv::Point2f ca(median(ax), median(ay)), cb(median(bx), median(by));
  std::vector<float> ratios;
  for (size_t i = 0; i < a.size(); i++) {
    const float da = std::hypot(a[i].x - ca.x, a[i].y - ca.y);
    if (da > 3.f) ratios.push_back(std::hypot(b[i].x - cb.x, b[i].y - cb.y) / da);
  }
  if (ratios.size() >= 3) m.scale = std::clamp(median(ratios), 0.5f, 2.f);
  return m;
}

/** The motions of all `regions` from `from` to `to`: corners of every region
 *  tracked in one forward and one backward Lucas-Kanade pass over pyramids
 *  built once (per-region calls would rebuild both pyramids each time). */
std::vector<RegionMotion> regionMotions(const cv::Mat& from, const cv::Mat& to, const std::vector<Region>& regions,
                                        const CarryParams& p) {
  std::vector<RegionMotion> out(regions.size());
  if (from.empty() || to.empty() || from.size() != to.size()) return out;
  std::vector<cv::Point2f> p0;
  std::vector<std::pair<size_t, size_t>> span(regions.size(), {0, 0});  // [begin, end) in p0
  for (size_t r = 0; r < regions.size(); r++) {
    const cv::Rect roi = clampRect(regions[r].roi, from.size());
    if (roi.width < 4 || roi.height < 4) continue;
    std::vector<cv::Point2f> c;
    cv::goodFeaturesToTrack(from(roi), c, p.max_corners, 0.01, 3,
                            regions[r].mask.empty() ? cv::noArray() : regions[r].mask, 3);
    if (static_cast<int>(c.size()) < p.min_points) continue;
    span[r] = {p0.size(), p0.size() + c.size()};
    for (auto& q : c) p0.push_back(q + cv::Point2f(static_cast<float>(roi.x), static_cast<float>(roi.y)));
  }
  if (p0.empty()) return out;
  const cv::Size win(p.lk_window, p.lk_window);
  // Kept between calls: rebuilt in place instead of allocating (and page
  // faulting) megabytes of pyramid and derivative images every frame. A
  // detection is carried frame to frame (System: `from` is the image the
  // previous call carried it to), so the pyramid of the last `to` is the one
  // of the next `from`: reused when its level 0 holds the same pixels (a
  // comparison costs about a twentieth of a pyramid).
  thread_local std::vector<cv::Mat> pyr_from, pyr_to;
  thread_local int to_levels = -1, to_max_level = -1;
  thread_local cv::Size to_win;
  int levels = 0;
  if (to_levels >= 0 && to_win == win && to_max_level == p.lk_levels - 1 && samePixels(pyr_to[0], from)) {
    std::swap(pyr_from, pyr_to);
    levels = to_levels;
  } else {
    levels = cv::buildOpticalFlowPyramid(from, pyr_from, win, p.lk_levels - 1);
  }
  to_levels = cv::buildOpticalFlowPyramid(to, pyr_to, win, p.lk_levels - 1);
  to_win = win;
  to_max_level = p.lk_levels - 1;
  levels = std::min(levels, to_levels);
  std::vector<cv::Point2f> p1, back;
  std::vector<uchar> st1, st2;
  std::vector<float> err;
  const cv::TermCriteria tc(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);
  cv::calcOpticalFlowPyrLK(pyr_from, pyr_to, p0, p1, st1, err, win, levels, tc);
  cv::calcOpticalFlowPyrLK(pyr_to, pyr_from, p1, back, st2, err, win, levels, tc);
  for (size_t r = 0; r < regions.size(); r++) {
    std::vector<cv::Point2f> a, b;
    for (size_t i = span[r].first; i < span[r].second; i++) {
      if (!st1[i] || !st2[i]) continue;
      const cv::Point2f e = back[i] - p0[i];
      if (std::hypot(e.x, e.y) > p.max_fb_error) continue;
      a.push_back(p0[i]);
      b.push_back(p1[i]);
    }
    if (static_cast<int>(a.size()) >= p.min_points) out[r] = motionFromPairs(a, b);
  }
  return out;
}

}  // namespace

RegionMotion regionMotion(const cv::Mat& from, const cv::Mat& to, const cv::Rect& roi_in, const cv::Mat& mask,
                          const CarryParams& p) {
  const cv::Rect roi = clampRect(roi_in, from.size());
  if (roi.area() == 0) return {};
  return regionMotions(from, to, {Region{roi, mask.empty() ? cv::Mat() : mask(roi)}}, p)[0];
}

Detections carryDetections(const Detections& d, const cv::Mat& from, const cv::Mat& to, int age,
                           const CarryParams& p) {
  Detections out = d;
  out.age_frames = age;
  if (from.empty() || to.empty() || from.data == to.data) return out;
  const cv::Size size = from.size();
  // Every region of the detection (boxes, panoptic segments, connected
  // regions of semantic classes) is collected first, then all are tracked
  // in one pass.
  std::vector<Region> regions;
  // Boxes: corners of the central part; moved and scaled about their centre.
  const float f = static_cast<float>(p.inner_fraction);
  for (const auto& bb : out.boxes) {
    const cv::Rect2f& r = bb.box;
    regions.push_back({clampRect(cv::Rect(cvRound(r.x + r.width * (1 - f) / 2), cvRound(r.y + r.height * (1 - f) / 2),
                                          cvRound(r.width * f), cvRound(r.height * f)),
                                 size),
                       cv::Mat()});
  }
  // Panoptic segments: each moved by its own flow (translation).
  const bool panoptic = !d.panoptic.empty() && d.panoptic.size() == size;
  const size_t first_segment = regions.size();
  if (panoptic)
    for (const auto& seg : out.segments) {
      const cv::Rect roi = clampRect(seg.bbox, size);
      regions.push_back({roi, roi.area() ? cv::Mat(d.panoptic(roi) == seg.id) : cv::Mat()});
    }
  // Semantic image: each connected region of each class moved by its flow.
  struct Component {
    int cls, label;
    cv::Mat labels;  ///< shared per class
  };
  std::vector<Component> components;
  const bool semantic = !d.semantic.empty() && d.semantic.size() == size;
  const size_t first_component = regions.size();
  if (semantic) {
    bool present[256] = {false};
    for (int y = 0; y < size.height; y++) {
      const uchar* row = d.semantic.ptr<uchar>(y);
      for (int x = 0; x < size.width; x++) present[row[x]] = true;
    }
    for (int c = 0; c < 255; c++) {
      if (!present[c]) continue;
      cv::Mat labels, stats, centroids;
      const int n = cv::connectedComponentsWithStats(d.semantic == c, labels, stats, centroids, 8, CV_32S);
      for (int k = 1; k < n; k++) {
        const cv::Rect roi(stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP),
                           stats.at<int>(k, cv::CC_STAT_WIDTH), stats.at<int>(k, cv::CC_STAT_HEIGHT));
        regions.push_back({roi, cv::Mat(labels(roi) == k)});
        components.push_back({c, k, labels});
      }
    }
  }
  const std::vector<RegionMotion> motion = regionMotions(from, to, regions, p);

  for (size_t i = 0; i < out.boxes.size(); i++) {
    const RegionMotion& m = motion[i];
    if (m.points == 0) continue;
    const cv::Rect2f& r = out.boxes[i].box;
    const cv::Point2f c(r.x + r.width / 2 + m.shift.x, r.y + r.height / 2 + m.shift.y);
    const float w = r.width * m.scale, h = r.height * m.scale;
    out.boxes[i].box = cv::Rect2f(c.x - w / 2, c.y - h / 2, w, h);
  }
  if (panoptic) {
    out.panoptic = cv::Mat(size, CV_32S, cv::Scalar(0));  // a new buffer (d's is shared by the copy)
    for (size_t i = 0; i < out.segments.size(); i++) {
      auto& seg = out.segments[i];
      const cv::Rect roi = regions[first_segment + i].roi;
      if (roi.area() == 0) continue;
      const RegionMotion& m = motion[first_segment + i];
      const cv::Point s(cvRound(m.shift.x), cvRound(m.shift.y));
      pasteShifted<int32_t>(d.panoptic, out.panoptic, roi, seg.id, s);
      seg.bbox = clampRect(seg.bbox + s, size);
    }
  }
  if (semantic) {
    out.semantic = cv::Mat(size, CV_8U, cv::Scalar(255));
    for (size_t i = 0; i < components.size(); i++) {
      const Component& comp = components[i];
      const cv::Rect roi = regions[first_component + i].roi;
      const RegionMotion& m = motion[first_component + i];
      const cv::Point s(cvRound(m.shift.x), cvRound(m.shift.y));
      for (int y = roi.y; y < roi.y + roi.height; y++) {
        const int yd = y + s.y;
        if (yd < 0 || yd >= size.height) continue;
        const int* l = comp.labels.ptr<int>(y);
        uchar* o = out.semantic.ptr<uchar>(yd);
        for (int x = roi.x; x < roi.x + roi.width; x++) {
          const int xd = x + s.x;
          if (l[x] == comp.label && xd >= 0 && xd < size.width) o[xd] = static_cast<uchar>(comp.cls);
        }
      }
    }
  }
  return out;
}

std::vector<int> holdMissedBoxes(const Detections& prev, const cv::Mat& prev_img, const std::vector<int>& prev_seen,
                                 Detections& cur, const cv::Mat& img, int frame, int cur_seen, int hold, bool flow,
                                 const HoldParams& hp, const CarryParams& p) {
  std::vector<int> seen(cur.boxes.size(), cur_seen);
  if (hold <= 0 || !prev.valid) return seen;
  Detections held;
  std::vector<int> held_seen;
  for (size_t j = 0; j < prev.boxes.size() && j < prev_seen.size(); j++) {
    if (frame - prev_seen[j] > hold) continue;
    const BoundingBox& b = prev.boxes[j];
    bool reported = false;
    for (const auto& c : cur.boxes) {
      if (c.class_id != b.class_id || iou(c.box, b.box) < hp.min_iou) continue;
      const float area = c.box.area();
      const bool fragment =
          area <= hp.fragment_area * b.box.area() && (c.box & b.box).area() >= hp.fragment_inside * area;
      reported |= !fragment;
    }
    if (reported) continue;
    held.boxes.push_back(b);
    held_seen.push_back(prev_seen[j]);
  }
  if (held.boxes.empty()) return seen;
  if (flow) held = carryDetections(held, prev_img, img, 0, p);
  for (size_t j = 0; j < held.boxes.size(); j++) {
    cur.boxes.push_back(held.boxes[j]);
    seen.push_back(held_seen[j]);
  }
  return seen;
}

void dropExpiredBoxes(Detections& d, std::vector<int>& seen, int frame, int hold) {
  size_t k = 0;
  for (size_t j = 0; j < d.boxes.size() && j < seen.size(); j++) {
    if (frame - seen[j] > hold) continue;
    d.boxes[k] = d.boxes[j];
    seen[k] = seen[j];
    k++;
  }
  d.boxes.resize(k);
  seen.resize(k);
}

double boxCoverage(const Detections& d, cv::Size size) {
  if (d.boxes.empty() || size.area() <= 0) return 0.0;
  cv::Mat cover(size, CV_8U, cv::Scalar(0));
  for (const auto& b : d.boxes) {
    const cv::Rect r = clampRect(cv::Rect(b.box), size);
    if (!r.empty()) cover(r).setTo(255);
  }
  return cv::countNonZero(cover) / static_cast<double>(size.area());
}

}  // namespace dslam
