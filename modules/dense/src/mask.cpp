// dynamicMask(): which pixels of a keyframe are dynamic (docs/dense_map.md,
// "Dynamic pixels").
#include <algorithm>
#include <cmath>
#include <map>

#include <opencv2/imgproc.hpp>

#include "dslam/dense/dense_map.h"

namespace dslam::dense {

namespace {

bool contains(const std::vector<int>& v, int x) { return std::find(v.begin(), v.end(), x) != v.end(); }

/** A label image of another size than the frame, scaled (nearest neighbour). */
cv::Mat toFrameSize(const cv::Mat& m, const cv::Size& sz) {
  if (m.size() == sz) return m;
  cv::Mat r;
  cv::resize(m, r, sz, 0, 0, cv::INTER_NEAREST);
  return r;
}

/** Keypoints whose region is covered by a mask of their own: no disk for them. */
bool maskedByRegion(KpReason r) {
  return r == KpReason::InDynamicBox || r == KpReason::SemanticDynamic || r == KpReason::GroundTruth ||
         r == KpReason::PersonPrior;
}

/** Median of the valid depths (> 0) in `roi` of `depth`; 0 if fewer than 10. */
float medianDepth(const cv::Mat& depth, const cv::Rect& roi) {
  std::vector<float> v;
  v.reserve(static_cast<size_t>(roi.area()));
  for (int y = roi.y; y < roi.y + roi.height; y++) {
    const float* d = depth.ptr<float>(y);
    for (int x = roi.x; x < roi.x + roi.width; x++)
      if (d[x] > 0 && std::isfinite(d[x])) v.push_back(d[x]);
  }
  if (v.size() < 10) return 0.f;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/** Box without a mask: the pixels whose depth is near the object's (the
 *  depth-repopulation test); the whole box when the depth says nothing. */
int maskBox(cv::Mat& m, const cv::Rect& r, const cv::Mat& depth, const DenseMapParams& p) {
  if (r.area() <= 0) return 0;
  float obj = 0.f;
  if (!depth.empty()) {
    const int cw = std::max(1, static_cast<int>(r.width * p.center_fraction));
    const int ch = std::max(1, static_cast<int>(r.height * p.center_fraction));
    obj = medianDepth(depth, cv::Rect(r.x + (r.width - cw) / 2, r.y + (r.height - ch) / 2, cw, ch));
  }
  if (obj <= 0.f) {
    m(r).setTo(255);
    return r.area();
  }
  int n = 0;
  const float lo = obj - static_cast<float>(p.depth_margin), hi = obj + static_cast<float>(p.depth_margin);
  for (int y = r.y; y < r.y + r.height; y++) {
    const float* d = depth.ptr<float>(y);
    uint8_t* o = m.ptr<uint8_t>(y);
    for (int x = r.x; x < r.x + r.width; x++)
      if (d[x] >= lo && d[x] <= hi) {
        o[x] = 255;
        n++;
      }
  }
  return n;
}

}  // namespace

cv::Mat dynamicMask(const Frame& f, const std::vector<Detections>& dets, const cv::Mat& depth, const DenseMapParams& p,
                    MaskStats* stats) {
  const cv::Size sz = !f.gray.empty() ? f.gray.size() : f.input.image.size();
  cv::Mat m = cv::Mat::zeros(sz, CV_8U);
  MaskStats st;
  if (!p.mask || sz.area() == 0) {
    if (stats) *stats = st;
    return m;
  }
  const cv::Rect img(0, 0, sz.width, sz.height);
  const bool have_depth = !depth.empty() && depth.size() == sz && depth.type() == CV_32F;
  auto isDynamicKp = [&](size_t i) { return i < f.meta.size() && f.meta[i].label == KpLabel::Dynamic; };

  for (const Detections& d : dets) {
    if (!d.valid) continue;
    // Semantic image: pixels of the dropped classes.
    if (!d.semantic.empty() && !p.classes.empty()) {
      cv::Mat lut(1, 256, CV_8U, cv::Scalar(0));
      for (int c : p.classes)
        if (c >= 0 && c < 255) lut.at<uint8_t>(c) = 255;
      cv::Mat s;
      cv::LUT(toFrameSize(d.semantic, sz), lut, s);
      st.semantic += cv::countNonZero(s);
      m |= s;
    }
    // Panoptic segments: of the dropped classes, or (follow_classifiers) things
    // and unknown segments whose keypoints the classifiers found dynamic.
    if (!d.panoptic.empty()) {
      const cv::Mat pan = toFrameSize(d.panoptic, sz);
      std::map<int, std::pair<int, int>> kp_count;  // segment id -> (keypoints, dynamic)
      if (p.follow_classifiers)
        for (size_t i = 0; i < f.keypoints.size(); i++) {
          const cv::Point q(cvRound(f.keypoints[i].pt.x), cvRound(f.keypoints[i].pt.y));
          if (!img.contains(q)) continue;
          auto& c = kp_count[pan.at<int32_t>(q)];
          c.first++;
          c.second += isDynamicKp(i);
        }
      std::vector<int> drop;
      for (const PanopticSegment& s : d.segments) {
        bool dyn = s.kind != SegmentKind::Stuff && contains(p.classes, s.category_id);
        if (!dyn && p.follow_classifiers && s.kind != SegmentKind::Stuff) {
          const auto it = kp_count.find(s.id);
          if (it != kp_count.end() && it->second.second >= p.min_dynamic_keypoints &&
              it->second.second >= p.min_dynamic_fraction * it->second.first)
            dyn = true;
        }
        if (dyn) drop.push_back(s.id);
      }
      if (!drop.empty()) {
        std::sort(drop.begin(), drop.end());
        for (int y = 0; y < sz.height; y++) {
          const int32_t* in = pan.ptr<int32_t>(y);
          uint8_t* o = m.ptr<uint8_t>(y);
          for (int x = 0; x < sz.width; x++)
            if (in[x] != 0 && std::binary_search(drop.begin(), drop.end(), in[x])) {
              o[x] = 255;
              st.panoptic++;
            }
        }
      }
    }
    // Boxes: of the dropped classes when this detector gave no mask, or
    // (follow_classifiers) boxes whose keypoints are dynamic; the pixels near
    // the object's depth.
    const bool has_mask = !d.semantic.empty() || !d.panoptic.empty();
    for (const BoundingBox& b : d.boxes) {
      bool dyn = !has_mask && contains(p.classes, b.class_id);
      if (!dyn && p.follow_classifiers) {
        int n = 0, nd = 0;
        for (size_t i = 0; i < f.keypoints.size(); i++)
          if (b.box.contains(f.keypoints[i].pt)) {
            n++;
            nd += isDynamicKp(i);
          }
        dyn = nd >= p.min_dynamic_keypoints && nd >= p.min_dynamic_fraction * n;
      }
      if (!dyn) continue;
      const cv::Rect r = cv::Rect(cvFloor(b.box.x), cvFloor(b.box.y), cvCeil(b.box.width) + 1, cvCeil(b.box.height) + 1) & img;
      st.boxes += maskBox(m, r, have_depth ? depth : cv::Mat(), p);
    }
  }
  // Keypoints labelled dynamic whose region no mask covers (epipolar
  // outliers, EKF-moving objects): a disk around each.
  if (p.keypoint_radius > 0)
    for (size_t i = 0; i < f.keypoints.size(); i++) {
      if (!isDynamicKp(i) || maskedByRegion(f.meta[i].reason)) continue;
      cv::circle(m, f.keypoints[i].pt, p.keypoint_radius, cv::Scalar(255), cv::FILLED);
      st.keypoints++;
    }
  if (p.dilation > 0) {
    const cv::Mat k = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * p.dilation + 1, 2 * p.dilation + 1));
    cv::dilate(m, m, k);
  }
  st.total = cv::countNonZero(m);
  if (stats) *stats = st;
  return m;
}

}  // namespace dslam::dense
