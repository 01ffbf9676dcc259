#pragma once
/** \file frontend.h
 *  Feature front end: SensorFrame -> dslam::Frame (grey conversion, stereo
 *  rectification of unrectified rigs, ORB extraction, keypoint undistortion,
 *  RGB-D depth / stereo matches with the (virtual) right coordinate). */
#include <functional>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/core/camera.h"
#include "dslam/core/frame.h"
#include "dslam/core/params.h"
#include "dslam/features/feature_grid.h"
#include "dslam/features/orb_extractor.h"
#include "dslam/features/stereo_matcher.h"

namespace dslam {

/** 8-bit grey image from an image as loaded by cv::imread (grey, BGR or
 *  BGRA). `rgb_order` is CameraModel::rgb_order, the channel order of the
 *  image *files*: true (normal RGB files) means the loaded Mat is BGR; false
 *  (files stored BGR) means the loaded Mat is RGB. Throws DataError for other
 *  types. Returns `img` itself (no copy) if it is already CV_8UC1. */
cv::Mat toGray(const cv::Mat& img, bool rgb_order);

/** Undistorted copies of `kps` (same octave/angle/size/response) with the
 *  camera's radial-tangential model; a plain copy if it has no distortion. */
void undistortKeypoints(const PinholeCamera& cam, const std::vector<cv::KeyPoint>& kps,
                        std::vector<cv::KeyPoint>& kps_un);

/** RGB-D depth per keypoint (ORB-SLAM2 ComputeStereoFromRGBD): depth read
 *  at the *distorted* keypoint pixel (truncated to int) of `depth_image`
 *  (CV_32F metres, or CV_16U raw units divided by `depth_factor`), and the
 *  virtual right coordinate u_right = u_un - bf / depth. Missing depth
 *  (<= 0, NaN, inf) gives -1 for both. Throws DataError on a wrong type. */
void computeRgbdDepth(const std::vector<cv::KeyPoint>& kps, const std::vector<cv::KeyPoint>& kps_un,
                      const cv::Mat& depth_image, double bf, std::vector<float>& depth,
                      std::vector<float>& u_right, double depth_factor = 1.0);

/** Rectification of an unrectified stereo rig (cv::stereoRectify with
 *  CALIB_ZERO_DISPARITY and alpha = 0, then initUndistortRectifyMap). */
struct StereoRectification {
  cv::Mat map_left1, map_left2, map_right1, map_right2;  ///< cv::remap maps (CV_16SC2 + CV_16UC1)
  cv::Matx33d R_left, R_right;  ///< p_rect = R * p_raw, for the left / right raw camera frames
  PinholeCamera left;           ///< rectified left camera (no distortion), image size of the input
  double baseline = 0;          ///< metres, from the rectified projection of the right camera
  CameraModel model;            ///< the input camera with `left`, `right`, baseline, T_left_right,
                                ///< T_body_cam replaced by the rectified ones and rectified = true
};

/** Computes the rectification of `cam` (sensor stereo, rectified == false).
 *  Throws ConfigError naming the camera for a missing/invalid right camera,
 *  different image sizes, a non-horizontal rig or a right camera on the left. */
StereoRectification computeStereoRectification(const CameraModel& cam);

/** Front-end parameters. */
struct FrontendParams {
  OrbParams orb;
  StereoMatchParams stereo;
  bool parallel_stereo = true;  ///< extract left and right in two threads (same output)

  /** Parameter specs (names as in the YAML "features" section), defaults = ORB-SLAM2. */
  static std::vector<ParamSpec> specs();
  /** Reads the values of specs() from validated params. Throws ConfigError. */
  static FrontendParams fromParams(const Params& p);
};

/** Wall time of the stages of the last FeatureFrontend::process() (ms). */
struct FrontendTimings {
  double gray_ms = 0;     ///< colour conversion (and rectification)
  double extract_ms = 0;  ///< ORB, left and right together
  double extract_left_ms = 0, extract_right_ms = 0;
  double post_ms = 0;     ///< undistortion, depth / stereo matching
  double total_ms = 0;
};

/** Turns SensorFrames into Frames for one camera. Not thread safe (one
 *  instance per stream). */
class FeatureFrontend {
 public:
  /** Throws ConfigError for an invalid camera or parameters. */
  explicit FeatureFrontend(const CameraModel& camera, const FrontendParams& p = FrontendParams());
  ~FeatureFrontend();
  FeatureFrontend(const FeatureFrontend&) = delete;
  FeatureFrontend& operator=(const FeatureFrontend&) = delete;

  /** Builds the Frame: gray (rectified for unrectified stereo), keypoints,
   *  keypoints_un, descriptors, depth and u_right (-1 where unknown), meta
   *  (all Static) and requested_features. `mask` (optional, CV_8U, input
   *  image size, 0 = no features) is rectified with the images if needed.
   *  Throws DataError naming the frame for missing/mismatched images.
   *  `on_gray`, if given, is called with the grey (rectified) left image as
   *  soon as it exists, before feature extraction: work that needs only the
   *  image can start on another thread meanwhile. */
  Frame process(const SensorFrame& in, const cv::Mat& mask = cv::Mat(),
                const std::function<void(const cv::Mat&)>& on_gray = {});

  /** Feature count for the next frames (left and right extractors). */
  void setFeatureCount(int n);
  int featureCount() const;

  /** The camera as given. */
  const CameraModel& inputCamera() const { return input_cam_; }
  /** The camera of the Frames' keypoints_un: the rectified camera for an
   *  unrectified stereo rig (fx, cx, cy, baseline of the rectified pair),
   *  otherwise the input camera. Tracking must use this one. */
  const CameraModel& camera() const { return cam_; }
  /** Rectification in use (nullptr unless the input is unrectified stereo). */
  const StereoRectification* rectification() const { return rect_.get(); }
  /** Bounds of keypoints_un for FeatureGrid. */
  const ImageBounds& imageBounds() const { return bounds_; }

  const OrbExtractor& extractor() const { return left_; }
  const OrbExtractor& rightExtractor() const { return right_; }
  const FrontendParams& params() const { return p_; }
  const FrontendTimings& lastTimings() const { return timings_; }
  const StereoMatchStats& lastStereoStats() const { return stereo_stats_; }

 private:
  FrontendParams p_;
  CameraModel input_cam_, cam_;
  std::unique_ptr<StereoRectification> rect_;
  ImageBounds bounds_;
  OrbExtractor left_, right_;
  FrontendTimings timings_;
  StereoMatchStats stereo_stats_;
};

}  // namespace dslam
