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
  for (int y = 0; y < disp.rows; y++) {
    const int16_t* d = disp.ptr<int16_t>(y);
    float* z = depth.ptr<float>(y);
    for (int x = 0; x < disp.cols; x++)
      if (d[x] >= 16) z[x] = fbf * 16.f / static_cast<float>(d[x]);  // disparity >= 1 px
  }
  return depth;
}

}  // namespace dslam::dense
