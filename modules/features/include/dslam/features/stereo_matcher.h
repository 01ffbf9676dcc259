#pragma once
/** \file stereo_matcher.h
 *  Stereo matching of ORB keypoints on a rectified pair (ORB-SLAM2
 *  Frame::ComputeStereoMatches): descriptor search along the row band,
 *  sub-pixel refinement by SAD correlation on the keypoint's pyramid level,
 *  and rejection of matches with a large correlation distance. */
#include <vector>

#include <opencv2/core.hpp>

namespace dslam {

class OrbExtractor;

/** Sub-pixel model fitted to the three SAD values around the best integer shift. */
enum class StereoSubpixel {
  Parabola,     ///< ORB-SLAM2: parabola (biased towards integer shifts for SAD)
  Equiangular,  ///< V-shaped fit (Shimizu & Okutomi 2005): the model of an L1 cost
};

/** Brightness offset removed from the SAD windows. */
enum class StereoOffset {
  Center,  ///< ORB-SLAM2: the difference of the centre pixels
  Mean,    ///< the difference of the window means
};

struct StereoMatchParams {
  int th_high = 100;           ///< ORBmatcher::TH_HIGH: best-candidate search threshold
  int th_low = 50;             ///< ORBmatcher::TH_LOW; a match needs distance < (th_high + th_low) / 2
  float row_radius = 2.0f;     ///< row band half-height at level 0, scaled by the level's scale factor
  int sad_half_window = 5;     ///< w: SAD window is (2w+1)^2 on the keypoint's level
  int sad_search = 5;          ///< L: SAD sliding range +-L pixels on the keypoint's level
  float outlier_factor = 2.1f; ///< reject matches with SAD distance >= factor * median (1.5 * 1.4)
  /** Defaults: window-mean offset and V fit, about 5x more accurate than
   *  ORB-SLAM2's centre-pixel offset and parabola (see docs/slam.md); set
   *  both to the ORB-SLAM2 values to reproduce it exactly. */
  StereoSubpixel subpixel = StereoSubpixel::Equiangular;
  StereoOffset offset = StereoOffset::Mean;

  /** ORB-SLAM2's exact refinement (centre offset, parabola). */
  static StereoMatchParams orbSlam2() {
    StereoMatchParams p;
    p.subpixel = StereoSubpixel::Parabola;
    p.offset = StereoOffset::Center;
    return p;
  }
};

struct StereoMatchStats {
  int left = 0;        ///< left keypoints
  int right = 0;       ///< right keypoints
  int candidates = 0;  ///< left keypoints with a descriptor match below the threshold
  int matched = 0;     ///< final matches (u_right >= 0)
  int outliers = 0;    ///< removed by the median SAD-distance test
};

/** Matches the left keypoints of a rectified pair against the right ones.
 *  `left`/`right` are the extractors that produced the keypoints (their
 *  pyramids are used for the SAD refinement). `bf` = baseline * fx (pixels *
 *  metres), `baseline` in metres (the minimum depth; disparities are searched
 *  in [0, bf / baseline]). Fills `u_right` (right x in level-0 pixels) and
 *  `depth` (= bf / disparity) with one value per left keypoint, -1 if no
 *  match. Deterministic. */
StereoMatchStats computeStereoMatches(const OrbExtractor& left, const std::vector<cv::KeyPoint>& kps_left,
                                      const cv::Mat& desc_left, const OrbExtractor& right,
                                      const std::vector<cv::KeyPoint>& kps_right, const cv::Mat& desc_right,
                                      float bf, float baseline, std::vector<float>& u_right,
                                      std::vector<float>& depth, const StereoMatchParams& p = StereoMatchParams());

}  // namespace dslam
