// stereoDepth(): dense depth of a rectified pair by OpenCV SGBM (as
// STDyn-SLAM builds its OctoMap from stereo disparity).
#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/dense/dense_map.h"

namespace dslam::dense {

cv::Mat stereoDepth(const cv::Mat& gray_left, const cv::Mat& gray_right, double bf, const DenseMapParams& p) {
  cv::Mat depth = cv::Mat::zeros(gray_left.size(), CV_32F);
  if (gray_left.empty() || gray_right.empty() || gray_left.size() != gray_right.size() || bf <= 0) return depth;
  int nd = p.num_disparities;
  if (nd <= 0) {
    nd = static_cast<int>(std::ceil(bf / std::max(p.stereo_min_depth, 1e-3) / 16.0)) * 16;
    nd = std::min(nd, (gray_left.cols / 4) / 16 * 16);
  }
  nd = std::clamp(nd, 16, std::max(16, (gray_left.cols / 2) / 16 * 16));
  const int bs = p.block_size;
  auto sgbm = cv::StereoSGBM::create(0, nd, bs, 8 * bs * bs, 32 * bs * bs, /*disp12MaxDiff=*/1, /*preFilterCap=*/63,
                                     p.uniqueness, /*speckleWindowSize=*/100, /*speckleRange=*/2,
                                     cv::StereoSGBM::MODE_SGBM);
  cv::Mat disp;
  sgbm->compute(gray_left, gray_right, disp);  // CV_16S, 16 x disparity, < 0 invalid
  const float fbf = static_cast<float>(bf);
  const int w = p.refine_window;
  cv::Mat L, R;
  gray_left.convertTo(L, CV_16S);
  gray_right.convertTo(R, CV_16S);
  // SAD between the left window at (x, y) and the right one at (x - d, y).
  auto sad = [&](int x, int y, int d) {
    int s = 0;
    for (int j = -w; j <= w; j++) {
      const int16_t* a = L.ptr<int16_t>(y + j) + x;
      const int16_t* b = R.ptr<int16_t>(y + j) + x - d;
      for (int i = -w; i <= w; i++) s += std::abs(a[i] - b[i]);
    }
    return s;
  };
  for (int y = 0; y < disp.rows; y++) {
    const int16_t* d16 = disp.ptr<int16_t>(y);
    float* z = depth.ptr<float>(y);
    for (int x = 0; x < disp.cols; x++) {
      if (d16[x] < 16) continue;  // disparity < 1 px or invalid
      float d = static_cast<float>(d16[x]) / 16.f;
      // Refinement: SAD at the integer disparity and its neighbours, V-shaped
      // (equiangular) fit, which does not pull towards integers as SGBM's
      // parabola does.
      int d0 = static_cast<int>(std::lround(d));
      if (w > 0 && y >= w && y + w < disp.rows && x + w < disp.cols && x - d0 - 2 - w >= 0) {
        int a = sad(x, y, d0 - 1), b = sad(x, y, d0), c = sad(x, y, d0 + 1);
        for (int it = 0; it < 2 && (a < b || c < b); it++) {  // the SAD minimum is one step away
          if (a < b) {
            d0--;
            c = b, b = a;
            if (x - d0 - 1 - w < 0 || d0 - 1 < 1) break;
            a = sad(x, y, d0 - 1);
          } else {
            d0++;
            a = b, b = c;
            if (x - d0 - 1 - w < 0) break;
            c = sad(x, y, d0 + 1);
          }
        }
        if (b <= a && b <= c && (a > b || c > b)) {
          const float delta = a > c ? 0.5f * static_cast<float>(a - c) / static_cast<float>(a - b)
                                    : 0.5f * static_cast<float>(a - c) / static_cast<float>(c - b);
          d = static_cast<float>(d0) + delta;
        }
      }
      if (d >= 1.f) z[x] = fbf / d;
    }
  }
  return depth;
}

}  // namespace dslam::dense
