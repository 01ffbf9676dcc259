#pragma once
/** \file rotation_histogram.h
 *  Rotation consistency of keypoint matches (ORB-SLAM's rotation histogram),
 *  the one implementation used by the tracking matcher and the classifiers.
 *
 *  Binning: the angle difference of a match (keypoint angle in the current
 *  image minus the one in the other image, degrees) is taken to [0, 360) and
 *  put in bin round(diff * bins / 360), 360 wrapping to bin 0: `bins` bins of
 *  360 / bins degrees each (12 degrees for ORB-SLAM's HISTO_LENGTH = 30).
 *  ORB-SLAM's code computes round(diff * 1 / 30), i.e. 30-degree bins of
 *  which only 13 are used; dslam uses the binning its comment intends.
 *
 *  Selection (ORBmatcher::ComputeThreeMaxima): the matches in the three
 *  fullest bins are kept; the second and third bins only if they hold at
 *  least 10% of the first's matches. All others are inconsistent. */
#include <vector>

namespace dslam {

/** Indices of the three fullest bins (-1 where none or below 10% of the first). */
void threeMaxima(const std::vector<std::vector<int>>& hist, int& i1, int& i2, int& i3);

/** Bin of an angle difference in degrees (any sign) for `bins` bins. */
int rotationBin(float diff_deg, int bins);

/** keep[k] == true for the matches whose angle difference angle_diff_deg[k]
 *  falls in one of the three selected bins. */
std::vector<bool> rotationConsistent(const std::vector<float>& angle_diff_deg, int bins = 30);

}  // namespace dslam
