#pragma once
/** \file orb_extractor.h
 *  ORB-SLAM2-style ORB extractor: scale pyramid, FAST per 30 px cell with a
 *  fallback threshold, quadtree distribution per level with geometric
 *  per-level quotas, intensity-centroid orientation and oriented BRIEF
 *  descriptors with ORB's learned 256-pair pattern. */
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace dslam {

/** Parameters of OrbExtractor (ORB-SLAM2 ORBextractor.* settings). */
struct OrbParams {
  int n_features = 1000;      ///< features per image (all levels)
  float scale_factor = 1.2f;  ///< scale between pyramid levels
  int n_levels = 8;           ///< pyramid levels
  int ini_th_fast = 20;       ///< FAST threshold tried first in each cell
  int min_th_fast = 7;        ///< FAST threshold used when a cell has no corner at ini_th_fast
  /** Process the levels with cv::parallel_for_ (the output does not depend on it). */
  bool parallel_levels = false;

  /** Throws ConfigError naming the bad field. */
  void validate() const;
};

/** Timing of the last OrbExtractor::extract() call (ms). The stages are
 *  CPU time of the threads that ran them (summed over levels, so they do not
 *  depend on other processes' load); `total_ms` is wall time. */
struct OrbTimings {
  double pyramid_ms = 0;   ///< pyramid + border (CPU)
  double detect_ms = 0;    ///< FAST per cell + quadtree + orientation (CPU)
  double describe_ms = 0;  ///< Gaussian blur + BRIEF (CPU)
  double total_ms = 0;     ///< wall time of extract()
};

/** ORB extractor. Not re-entrant: use one instance per thread/image stream
 *  (the pyramid of the last call is kept for stereo matching). */
class OrbExtractor {
 public:
  using Params = OrbParams;
  static constexpr int kPatchSize = 31;
  static constexpr int kHalfPatchSize = 15;
  static constexpr int kEdgeThreshold = 19;  ///< border of every pyramid level (pixels)
  static constexpr int kCellSize = 30;       ///< FAST cell size on each level (pixels)

  explicit OrbExtractor(const Params& p = Params());

  /** Extracts keypoints and descriptors from an 8-bit grey image.
   *  Keypoints are in level-0 pixels, ordered by level; `octave` = level,
   *  `size` = 31 * scale(level), `angle` in degrees [0, 360), `response` =
   *  FAST score. `descriptors` gets one 32-byte CV_8U row per keypoint.
   *  `mask` (optional, CV_8U, same size): keypoints are only detected where
   *  mask != 0. Deterministic. Throws DataError on a wrong image or mask. */
  void extract(const cv::Mat& gray, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
               const cv::Mat& mask = cv::Mat());

  /** Changes the requested feature count (per-level quotas are recomputed). */
  void setFeatureCount(int n);
  int featureCount() const { return p_.n_features; }
  const Params& params() const { return p_; }

  int levels() const { return p_.n_levels; }
  float scaleFactor() const { return p_.scale_factor; }
  /** ORB-SLAM mvScaleFactor: scale_factor^level. */
  const std::vector<float>& scaleFactors() const { return scale_; }
  const std::vector<float>& invScaleFactors() const { return inv_scale_; }
  /** ORB-SLAM mvLevelSigma2: scale^2. */
  const std::vector<float>& levelSigma2() const { return sigma2_; }
  const std::vector<float>& invLevelSigma2() const { return inv_sigma2_; }
  /** Feature quota of each level (ORB-SLAM mnFeaturesPerLevel). */
  const std::vector<int>& featuresPerLevel() const { return per_level_; }

  /** Unblurred pyramid of the last extract(): level l is
   *  round(size / scale(l)); each Mat is a view with kEdgeThreshold pixels of
   *  reflected border around it in its parent buffer. */
  const std::vector<cv::Mat>& pyramid() const { return levels_; }
  const OrbTimings& lastTimings() const { return timings_; }

 private:
  void computeQuotas();
  void buildPyramid(const cv::Mat& gray);
  void processLevel(int level, const cv::Mat& mask, std::vector<cv::KeyPoint>& kps, cv::Mat& desc);

  Params p_;
  std::vector<float> scale_, inv_scale_, sigma2_, inv_sigma2_;
  std::vector<int> per_level_;
  std::vector<int> umax_;
  std::vector<cv::Mat> padded_, levels_;          ///< pyramid buffers and their inner views
  std::vector<cv::Mat> blurred_padded_, blurred_; ///< blurred copies for the descriptors
  std::vector<double> detect_ms_, describe_ms_;   ///< per level, last call
  OrbTimings timings_;
};

}  // namespace dslam
