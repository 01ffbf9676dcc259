#include "dslam/features/feature_grid.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "dslam/core/camera.h"
#include "dslam/core/error.h"
#include "dslam/core/frame.h"

namespace dslam {

ImageBounds computeImageBounds(const PinholeCamera& cam) {
  ImageBounds b;
  if (!cam.hasDistortion()) {
    b.max_x = static_cast<float>(cam.width);
    b.max_y = static_cast<float>(cam.height);
    return b;
  }
  const double w = cam.width, h = cam.height;
  const Eigen::Vector2d c0 = cam.undistort(0, 0), c1 = cam.undistort(w, 0), c2 = cam.undistort(0, h),
                        c3 = cam.undistort(w, h);
  b.min_x = static_cast<float>(std::min(c0.x(), c2.x()));
  b.max_x = static_cast<float>(std::max(c1.x(), c3.x()));
  b.min_y = static_cast<float>(std::min(c0.y(), c1.y()));
  b.max_y = static_cast<float>(std::max(c2.y(), c3.y()));
  return b;
}

FeatureGrid::FeatureGrid(const Frame& frame, const ImageBounds& bounds) { build(frame.keypoints_un, bounds); }

bool FeatureGrid::posInGrid(float x, float y, int& cx, int& cy) const {
  // Range-checked as floats first: a far-off or non-finite coordinate must
  // not be converted to int (undefined behaviour).
  const float fx = std::round((x - bounds_.min_x) * inv_w_), fy = std::round((y - bounds_.min_y) * inv_h_);
  if (!(fx >= 0.f && fx < static_cast<float>(kCols) && fy >= 0.f && fy < static_cast<float>(kRows))) {
    cx = cy = -1;
    return false;
  }
  cx = static_cast<int>(fx);
  cy = static_cast<int>(fy);
  return true;
}

void FeatureGrid::build(const std::vector<cv::KeyPoint>& kps, const ImageBounds& bounds) {
  if (!bounds.valid())
    throw ConfigError("FeatureGrid: empty image bounds [" + std::to_string(bounds.min_x) + ", " +
                      std::to_string(bounds.max_x) + "] x [" + std::to_string(bounds.min_y) + ", " +
                      std::to_string(bounds.max_y) + "]");
  bounds_ = bounds;
  inv_w_ = kCols / (bounds.max_x - bounds.min_x);
  inv_h_ = kRows / (bounds.max_y - bounds.min_y);
  n_ = kps.size();
  std::vector<int> cell_of(kps.size(), -1);
  start_.assign(kCols * kRows + 1, 0);
  for (size_t i = 0; i < kps.size(); i++) {
    int cx, cy;
    if (posInGrid(kps[i].pt.x, kps[i].pt.y, cx, cy)) {
      cell_of[i] = cx * kRows + cy;
      start_[cell_of[i] + 1]++;
    }
  }
  for (int c = 0; c < kCols * kRows; c++) start_[c + 1] += start_[c];
  idx_.resize(start_.back());
  std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
  for (size_t i = 0; i < kps.size(); i++) {
    if (cell_of[i] < 0) continue;
    idx_[fill[cell_of[i]]++] = Entry{kps[i].pt.x, kps[i].pt.y, kps[i].octave, static_cast<uint32_t>(i)};
  }
}

std::vector<size_t> FeatureGrid::featuresInArea(float x, float y, float r, int min_level, int max_level) const {
  std::vector<size_t> out;
  featuresInArea(x, y, r, min_level, max_level, out);
  return out;
}

void FeatureGrid::featuresInArea(float x, float y, float r, int min_level, int max_level,
                                 std::vector<size_t>& out) const {
  out.clear();
  if (start_.empty()) return;
  const int min_cx = std::max(0, static_cast<int>(std::floor((x - bounds_.min_x - r) * inv_w_)));
  if (min_cx >= kCols) return;
  const int max_cx = std::min(kCols - 1, static_cast<int>(std::ceil((x - bounds_.min_x + r) * inv_w_)));
  if (max_cx < 0) return;
  const int min_cy = std::max(0, static_cast<int>(std::floor((y - bounds_.min_y - r) * inv_h_)));
  if (min_cy >= kRows) return;
  const int max_cy = std::min(kRows - 1, static_cast<int>(std::ceil((y - bounds_.min_y + r) * inv_h_)));
  if (max_cy < 0) return;
  const bool check_levels = min_level > 0 || max_level >= 0;
  for (int cx = min_cx; cx <= max_cx; cx++) {
    for (int cy = min_cy; cy <= max_cy; cy++) {
      const int c = cx * kRows + cy;
      for (uint32_t k = start_[c]; k < start_[c + 1]; k++) {
        const Entry& e = idx_[k];
        if (check_levels) {
          if (e.octave < min_level) continue;
          if (max_level >= 0 && e.octave > max_level) continue;
        }
        if (std::fabs(e.x - x) < r && std::fabs(e.y - y) < r) out.push_back(e.index);
      }
    }
  }
}

std::vector<size_t> FeatureGrid::cell(int cx, int cy) const {
  std::vector<size_t> out;
  if (start_.empty() || cx < 0 || cx >= kCols || cy < 0 || cy >= kRows) return out;
  const int c = cx * kRows + cy;
  for (uint32_t k = start_[c]; k < start_[c + 1]; k++) out.push_back(idx_[k].index);
  return out;
}

}  // namespace dslam
