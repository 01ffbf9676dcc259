#include "dslam/features/frontend.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/core/error.h"
#include "dslam/core/log.h"

namespace dslam {

namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string sizeStr(const cv::Size& s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

std::string frameName(const SensorFrame& in) {
  std::string s = "frame " + std::to_string(in.index);
  if (!in.image_path.empty()) s += " (" + in.image_path + ")";
  return s;
}

cv::Matx33d intrinsics(const PinholeCamera& c) { return {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1}; }

cv::Mat distCoeffs(const PinholeCamera& c) {
  cv::Mat d(1, 5, CV_64F);
  for (int i = 0; i < 5; i++) d.at<double>(i) = c.dist[i];
  return d;
}

Eigen::Matrix3d toEigen(const cv::Matx33d& m) {
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) r(i, j) = m(i, j);
  return r;
}

}  // namespace

cv::Mat toGray(const cv::Mat& img, bool rgb_order) {
  if (img.empty()) throw DataError("grey conversion: empty image");
  if (img.depth() != CV_8U)
    throw DataError("grey conversion: expected an 8-bit image, got depth " + std::to_string(img.depth()));
  cv::Mat g;
  switch (img.channels()) {
    case 1: return img;
    case 3: cv::cvtColor(img, g, rgb_order ? cv::COLOR_BGR2GRAY : cv::COLOR_RGB2GRAY); return g;
    case 4: cv::cvtColor(img, g, rgb_order ? cv::COLOR_BGRA2GRAY : cv::COLOR_RGBA2GRAY); return g;
    default:
      throw DataError("grey conversion: unsupported channel count " + std::to_string(img.channels()));
  }
}

void undistortKeypoints(const PinholeCamera& cam, const std::vector<cv::KeyPoint>& kps,
                        std::vector<cv::KeyPoint>& kps_un) {
  kps_un = kps;
  if (!cam.hasDistortion()) return;
  for (auto& k : kps_un) {
    const Eigen::Vector2d u = cam.undistort(k.pt.x, k.pt.y);
    k.pt.x = static_cast<float>(u.x());
    k.pt.y = static_cast<float>(u.y());
  }
}

void computeRgbdDepth(const std::vector<cv::KeyPoint>& kps, const std::vector<cv::KeyPoint>& kps_un,
                      const cv::Mat& depth_image, double bf, std::vector<float>& depth, std::vector<float>& u_right,
                      double depth_factor) {
  const size_t n = kps.size();
  depth.assign(n, -1.0f);
  u_right.assign(n, -1.0f);
  if (kps_un.size() != n) throw DataError("RGB-D depth: keypoints and undistorted keypoints differ in count");
  if (depth_image.empty()) throw DataError("RGB-D depth: empty depth image");
  const int type = depth_image.type();
  if (type != CV_32FC1 && type != CV_16UC1)
    throw DataError("RGB-D depth: depth image must be CV_32F metres or CV_16U raw, got type " + std::to_string(type));
  if (type == CV_16UC1 && !(depth_factor > 0))
    throw DataError("RGB-D depth: depth_factor must be > 0 for a CV_16U depth image");
  for (size_t i = 0; i < n; i++) {
    // Nearest pixel (ORB-SLAM2 truncates, which biases depth on slanted surfaces by half a pixel).
    // A keypoint in the last half pixel (x in [cols-0.5, cols)) reads the last column.
    const float x = kps[i].pt.x, y = kps[i].pt.y;
    if (!(x >= 0.f && y >= 0.f && x < depth_image.cols && y < depth_image.rows)) continue;
    const int u = std::min(cvRound(x), depth_image.cols - 1), v = std::min(cvRound(y), depth_image.rows - 1);
    const float d = type == CV_32FC1 ? depth_image.at<float>(v, u)
                                     : static_cast<float>(depth_image.at<uint16_t>(v, u) / depth_factor);
    if (d > 0 && std::isfinite(d)) {
      depth[i] = d;
      u_right[i] = static_cast<float>(kps_un[i].pt.x - bf / d);
    }
  }
}

StereoRectification computeStereoRectification(const CameraModel& cam) {
  const std::string who = "camera '" + cam.name + "'";
  if (cam.sensor != SensorType::Stereo) throw ConfigError(who + ": stereo rectification needs a stereo camera");
  if (!cam.left.valid()) throw ConfigError(who + ": invalid left camera intrinsics/size");
  if (!cam.right.valid()) throw ConfigError(who + ": unrectified stereo needs valid right camera intrinsics and size");
  const cv::Size size(cam.left.width, cam.left.height);
  if (cam.right.width != cam.left.width || cam.right.height != cam.left.height)
    throw ConfigError(who + ": left and right image sizes differ (" + sizeStr(size) + " vs " +
                      sizeStr({cam.right.width, cam.right.height}) + ")");
  const SE3 T_rl = cam.T_left_right.inverse();  // p_right = T_rl * p_left
  if (T_rl.translation().norm() < 1e-9) throw ConfigError(who + ": T_left_right has no translation (baseline 0)");
  cv::Matx33d R;
  const Eigen::Matrix3d Re = T_rl.rotation();
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) R(i, j) = Re(i, j);
  const cv::Vec3d t(T_rl.translation().x(), T_rl.translation().y(), T_rl.translation().z());

  StereoRectification r;
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(intrinsics(cam.left), distCoeffs(cam.left), intrinsics(cam.right), distCoeffs(cam.right), size, R,
                    t, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0, size);
  if (std::abs(P2.at<double>(1, 3)) > 1e-9 * std::abs(P2.at<double>(0, 3)) + 1e-12)
    throw ConfigError(who + ": the stereo rig is vertical after rectification (check T_left_right)");
  r.baseline = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
  if (!(r.baseline > 0) || !std::isfinite(r.baseline))
    throw ConfigError(who + ": the right camera is not to the right of the left one (rectified baseline " +
                      std::to_string(r.baseline) + " m; check T_left_right)");
  r.R_left = cv::Matx33d(R1);
  r.R_right = cv::Matx33d(R2);
  r.left.width = size.width;
  r.left.height = size.height;
  r.left.fx = P1.at<double>(0, 0);
  r.left.fy = P1.at<double>(1, 1);
  r.left.cx = P1.at<double>(0, 2);
  r.left.cy = P1.at<double>(1, 2);
  if (!r.left.valid() || !std::isfinite(r.left.fx) || !std::isfinite(r.left.cx))
    throw ConfigError(who + ": stereo rectification failed (check intrinsics and T_left_right)");
  cv::initUndistortRectifyMap(intrinsics(cam.left), distCoeffs(cam.left), R1, P1.colRange(0, 3), size, CV_16SC2,
                              r.map_left1, r.map_left2);
  cv::initUndistortRectifyMap(intrinsics(cam.right), distCoeffs(cam.right), R2, P2.colRange(0, 3), size, CV_16SC2,
                              r.map_right1, r.map_right2);

  r.model = cam;
  r.model.left = r.left;
  r.model.right = r.left;
  r.model.right.cx = P2.at<double>(0, 2);
  r.model.right.cy = P2.at<double>(1, 2);
  r.model.baseline = r.baseline;
  r.model.T_left_right = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(r.baseline, 0, 0));
  // Rectified left frame: p_rect = R1 p_cam, so T_cam_rect = [R1^T | 0].
  r.model.T_body_cam = cam.T_body_cam * SE3(Eigen::Matrix3d(toEigen(r.R_left).transpose()), Eigen::Vector3d::Zero());
  r.model.rectified = true;
  return r;
}

std::vector<ParamSpec> FrontendParams::specs() {
  const FrontendParams d;
  return {
      P_int("n_features", d.orb.n_features, "ORB features per image (ORBextractor.nFeatures)", 1, 100000),
      P_double("scale_factor", d.orb.scale_factor, "scale between pyramid levels (ORBextractor.scaleFactor)", 1.01, 4),
      P_int("n_levels", d.orb.n_levels, "pyramid levels (ORBextractor.nLevels)", 1, 32),
      P_int("ini_th_fast", d.orb.ini_th_fast, "FAST threshold tried first per 30 px cell (ORBextractor.iniThFAST)", 1,
            254),
      P_int("min_th_fast", d.orb.min_th_fast, "FAST threshold for cells without corners (ORBextractor.minThFAST)", 1,
            254),
      P_bool("parallel_levels", d.orb.parallel_levels, "process pyramid levels in parallel (same output)"),
      P_bool("parallel_stereo", d.parallel_stereo, "extract left and right images in parallel (same output)"),
      P_int("stereo_th_high", d.stereo.th_high, "stereo: max descriptor distance of the best candidate (TH_HIGH)", 0,
            256),
      P_int("stereo_th_low", d.stereo.th_low,
            "stereo: TH_LOW; a match needs distance < (TH_HIGH + TH_LOW) / 2", 0, 256),
      P_double("stereo_row_radius", d.stereo.row_radius, "stereo: row band half-height (px at level 0, x scale)", 0,
               100),
      P_int("stereo_sad_window", d.stereo.sad_half_window, "stereo: SAD half window w (window 2w+1)", 1, 30),
      P_int("stereo_sad_search", d.stereo.sad_search, "stereo: SAD sliding range +-L (px on the level)", 1, 30),
      P_double("stereo_outlier_factor", d.stereo.outlier_factor,
               "stereo: drop matches with SAD distance >= factor * median (1.5 * 1.4)", 0, 100),
      P_enum("stereo_subpixel", "equiangular", {"equiangular", "parabola"},
             "stereo: sub-pixel fit to the SAD minimum (ORB-SLAM2: parabola)"),
      P_enum("stereo_offset", "mean", {"mean", "center"},
             "stereo: brightness offset removed from SAD windows (ORB-SLAM2: center)"),
  };
}

FrontendParams FrontendParams::fromParams(const Params& p) {
  FrontendParams f;
  auto i = [&](const char* k, int& v) {
    if (p.has(k)) v = static_cast<int>(p.getInt(k));
  };
  auto d = [&](const char* k, float& v) {
    if (p.has(k)) v = static_cast<float>(p.getDouble(k));
  };
  auto b = [&](const char* k, bool& v) {
    if (p.has(k)) v = p.getBool(k);
  };
  i("n_features", f.orb.n_features);
  d("scale_factor", f.orb.scale_factor);
  i("n_levels", f.orb.n_levels);
  i("ini_th_fast", f.orb.ini_th_fast);
  i("min_th_fast", f.orb.min_th_fast);
  b("parallel_levels", f.orb.parallel_levels);
  b("parallel_stereo", f.parallel_stereo);
  i("stereo_th_high", f.stereo.th_high);
  i("stereo_th_low", f.stereo.th_low);
  d("stereo_row_radius", f.stereo.row_radius);
  i("stereo_sad_window", f.stereo.sad_half_window);
  i("stereo_sad_search", f.stereo.sad_search);
  d("stereo_outlier_factor", f.stereo.outlier_factor);
  if (p.has("stereo_subpixel"))
    f.stereo.subpixel =
        p.getString("stereo_subpixel") == "parabola" ? StereoSubpixel::Parabola : StereoSubpixel::Equiangular;
  if (p.has("stereo_offset"))
    f.stereo.offset = p.getString("stereo_offset") == "center" ? StereoOffset::Center : StereoOffset::Mean;
  f.orb.validate();
  return f;
}

FeatureFrontend::FeatureFrontend(const CameraModel& camera, const FrontendParams& p)
    : p_(p), input_cam_(camera), cam_(camera), left_(p.orb), right_(p.orb) {
  const std::string who = "camera '" + camera.name + "'";
  if (!camera.left.valid())
    throw ConfigError(who + ": invalid intrinsics or image size (width, height, fx, fy must be > 0)");
  if (camera.sensor == SensorType::Stereo) {
    if (!camera.rectified) {
      rect_ = std::make_unique<StereoRectification>(computeStereoRectification(camera));
      cam_ = rect_->model;
    } else if (camera.left.hasDistortion()) {
      throw ConfigError(who + ": a rectified stereo pair must have no distortion coefficients "
                        "(set rectified: false to rectify at start-up)");
    }
    if (!(cam_.baseline > 0)) throw ConfigError(who + ": stereo needs a baseline > 0 (bf / fx)");
  } else if (camera.sensor == SensorType::RGBD) {
    if (!(camera.baseline > 0)) throw ConfigError(who + ": RGB-D needs a virtual baseline > 0 (bf / fx)");
  }
  bounds_ = computeImageBounds(cam_.left);
}

FeatureFrontend::~FeatureFrontend() = default;

void FeatureFrontend::setFeatureCount(int n) {
  left_.setFeatureCount(n);
  right_.setFeatureCount(n);
}

int FeatureFrontend::featureCount() const { return left_.featureCount(); }

Frame FeatureFrontend::process(const SensorFrame& in, const cv::Mat& mask,
                               const std::function<void(const cv::Mat&)>& on_gray) {
  const auto t0 = std::chrono::steady_clock::now();
  timings_ = FrontendTimings{};
  stereo_stats_ = StereoMatchStats{};
  const std::string fn = frameName(in);
  const cv::Size cam_size(input_cam_.left.width, input_cam_.left.height);
  if (in.image.empty()) throw DataError(fn + ": empty image");
  if (in.image.size() != cam_size)
    throw DataError(fn + ": image is " + sizeStr(in.image.size()) + " but camera '" + input_cam_.name +
                    "' expects " + sizeStr(cam_size));
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != in.image.size()))
    throw DataError(fn + ": mask must be CV_8UC1 of the image size " + sizeStr(in.image.size()));
  const bool stereo = input_cam_.sensor == SensorType::Stereo;
  const bool rgbd = input_cam_.sensor == SensorType::RGBD;
  if (stereo) {
    if (in.image_right.empty()) throw DataError(fn + ": stereo frame without right image");
    if (in.image_right.size() != in.image.size())
      throw DataError(fn + ": left image is " + sizeStr(in.image.size()) + " but right image (" +
                      in.image_right_path + ") is " + sizeStr(in.image_right.size()));
  }
  if (rgbd) {
    // A frame without depth keeps its keypoints with unknown depth: tracking
    // then works on monocular residuals and creates no new points.
    if (!in.has_depth()) DSLAM_LOG(Debug, fn << ": RGB-D frame without depth image");
    if (in.has_depth() && in.depth.size() != in.image.size())
      throw DataError(fn + ": depth image (" + in.depth_path + ") is " + sizeStr(in.depth.size()) +
                      " but the colour image is " + sizeStr(in.image.size()));
  }

  Frame f;
  f.input = in;
  f.requested_features = left_.featureCount();
  cv::Mat use_mask = mask;
  try {
    f.gray = toGray(in.image, input_cam_.rgb_order);
    if (stereo) f.gray_right = toGray(in.image_right, input_cam_.rgb_order);
  } catch (const DataError& e) {
    throw DataError(fn + ": " + e.what());
  }
  if (rect_) {
    cv::Mat l, r;
    cv::remap(f.gray, l, rect_->map_left1, rect_->map_left2, cv::INTER_LINEAR);
    cv::remap(f.gray_right, r, rect_->map_right1, rect_->map_right2, cv::INTER_LINEAR);
    f.gray = l;
    f.gray_right = r;
    if (!mask.empty()) {
      cv::remap(mask, use_mask, rect_->map_left1, rect_->map_left2, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                cv::Scalar(0));
    }
  }
  timings_.gray_ms = msSince(t0);
  if (on_gray) on_gray(f.gray);

  const auto t1 = std::chrono::steady_clock::now();
  std::vector<cv::KeyPoint> kps_r;
  cv::Mat desc_r;
  auto run = [&](int side) {
    const auto ts = std::chrono::steady_clock::now();
    if (side == 0) {
      left_.extract(f.gray, f.keypoints, f.descriptors, use_mask);
      timings_.extract_left_ms = msSince(ts);
    } else {
      right_.extract(f.gray_right, kps_r, desc_r);
      timings_.extract_right_ms = msSince(ts);
    }
  };
  if (stereo && p_.parallel_stereo) {
    cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& r) {
      for (int s = r.start; s < r.end; s++) run(s);
    }, 2);
  } else {
    run(0);
    if (stereo) run(1);
  }
  timings_.extract_ms = msSince(t1);

  const auto t2 = std::chrono::steady_clock::now();
  if (stereo) {
    f.keypoints_un = f.keypoints;  // rectified pair: no distortion
    stereo_stats_ = computeStereoMatches(left_, f.keypoints, f.descriptors, right_, kps_r, desc_r,
                                         static_cast<float>(cam_.bf()), static_cast<float>(cam_.baseline), f.u_right,
                                         f.depth, p_.stereo);
  } else {
    undistortKeypoints(cam_.left, f.keypoints, f.keypoints_un);
    if (rgbd && in.has_depth()) {
      try {
        computeRgbdDepth(f.keypoints, f.keypoints_un, in.depth, cam_.bf(), f.depth, f.u_right, cam_.depth_factor);
      } catch (const DataError& e) {
        throw DataError(fn + ": " + e.what());
      }
    } else {
      f.depth.assign(f.keypoints.size(), -1.0f);
      f.u_right.assign(f.keypoints.size(), -1.0f);
    }
  }
  f.resetMeta();
  timings_.post_ms = msSince(t2);
  timings_.total_ms = msSince(t0);
  return f;
}

}  // namespace dslam
