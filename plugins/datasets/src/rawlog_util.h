#pragma once
/** \file rawlog_util.h
 *  MRPT <-> dslam conversions shared by the rawlog reader and the
 *  converters (internal; pulls in MRPT obs headers). */
#include <mrpt/img/TCamera.h>
#include <mrpt/math/CMatrixDynamic.h>
#include <mrpt/poses/CPose3D.h>
#include <opencv2/core.hpp>

#include <string>

#include "dslam/core/camera.h"

namespace mrpt::obs {
class CObservation;
class CObservation3DRangeScan;
}  // namespace mrpt::obs

namespace dslam::rawlog {

/** TCamera -> PinholeCamera (plumb_bob distortion kept; fisheye rejected). */
PinholeCamera fromTCamera(const mrpt::img::TCamera& c, const std::string& what);
mrpt::img::TCamera toTCamera(const PinholeCamera& p, const std::string& name);
SE3 toSE3(const mrpt::poses::CPose3D& p);
/** T_intensity_depth between the two optical frames of a 3D range scan. */
SE3 intensityFromDepth(const mrpt::obs::CObservation3DRangeScan& o);
std::string describeObs(const mrpt::obs::CObservation& o);
/** CMatrix_u16 -> CV_16UC1 (copy). */
cv::Mat rangeToMat(const mrpt::math::CMatrix_u16& r);
/** Reprojects a CV_32F depth image (metres) of camera kd into camera ki
 *  (output ki.width x ki.height), T_i_d mapping depth-camera points into the
 *  intensity camera; z-buffered forward splatting of each pixel's footprint. */
cv::Mat registerDepth(const cv::Mat& depth, const PinholeCamera& kd, const PinholeCamera& ki, const SE3& T_i_d);
/** True unless depth and intensity cameras coincide (same intrinsics and
 *  size, relativePoseIntensityWRTDepth the pure axis rotation). */
bool needsRegistration(const mrpt::obs::CObservation3DRangeScan& o);

}  // namespace dslam::rawlog
