#pragma once
/** Synthetic images for the features tests. */
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace dslam::test {

/** Smooth random texture: uniform noise at 1/`cell` resolution, upsampled
 *  with cubic interpolation (features of about `cell` pixels). */
inline cv::Mat smoothNoise(cv::Size size, int cell, cv::RNG& rng, int lo = 30, int hi = 225) {
  cv::Mat small(std::max(2, size.height / cell + 2), std::max(2, size.width / cell + 2), CV_8UC1);
  rng.fill(small, cv::RNG::UNIFORM, lo, hi);
  cv::Mat big;
  cv::resize(small, big, cv::Size(small.cols * cell, small.rows * cell), 0, 0, cv::INTER_CUBIC);
  return big(cv::Rect(0, 0, size.width, size.height)).clone();
}

/** A 640x480-style scene: a weakly textured background with random
 *  rectangles and discs over the whole image, and one heavily textured
 *  region (the top-left `corner` rectangle, high-contrast fine noise) that
 *  would take most FAST corners without a spatial distribution. */
inline cv::Mat texturedScene(cv::Size size, uint64_t seed = 7, cv::Rect corner = cv::Rect(0, 0, 200, 150)) {
  cv::RNG rng(seed);
  cv::Mat img = smoothNoise(size, 24, rng, 90, 160);
  const int n_shapes = size.area() / 3000;
  for (int i = 0; i < n_shapes; i++) {
    const cv::Point c(rng.uniform(0, size.width), rng.uniform(0, size.height));
    const int r = rng.uniform(4, 22);
    const int v = rng.uniform(0, 256);
    if (rng.uniform(0, 2) == 0)
      cv::rectangle(img, cv::Rect(c.x - r, c.y - r / 2, 2 * r, r + rng.uniform(2, 18)), cv::Scalar(v), cv::FILLED);
    else
      cv::circle(img, c, r, cv::Scalar(v), cv::FILLED, cv::LINE_AA);
  }
  corner &= cv::Rect(0, 0, size.width, size.height);
  if (corner.empty()) {
    cv::GaussianBlur(img, img, cv::Size(3, 3), 0.7);
    return img;
  }
  cv::Mat fine(corner.size(), CV_8UC1);
  rng.fill(fine, cv::RNG::UNIFORM, 0, 256);
  fine.copyTo(img(corner));
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.7);
  return img;
}

}  // namespace dslam::test
