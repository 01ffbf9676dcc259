#include "dslam/plugins/datasets/kitti.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <array>
#include <cmath>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/png.h"
#include "dslam/core/yaml_util.h"
#include "dslam/trajectory/io.h"

IMPLEMENTS_MRPT_OBJECT(KittiDataset, DatasetSource, dslam)

namespace dslam {

static const char* kKittiLayout =
    "expected a KITTI odometry folder: image_0/ and image_1/ (or image_l/ and image_r/, image_2/ and image_3/) "
    "with the same PNG names, calib.txt with P0/P1 3x4 matrices, optional times.txt and poses.txt";

const std::vector<double>* KittiCalib::find(const std::string& name) const {
  for (const auto& m : matrices)
    if (m.first == name) return &m.second;
  return nullptr;
}

KittiCalib readKittiCalib(const std::string& file) {
  static const char* kOrder[] = {"P0", "P1", "P2", "P3", "Tr"};
  KittiCalib c;
  size_t unlabelled = 0;
  for (const auto& l : readDataLines(file, kKittiLayout)) {
    auto f = splitFields(l.text);
    std::string name;
    if (!f.empty() && f[0].back() == ':') {
      name = f[0].substr(0, f[0].size() - 1);
      f.erase(f.begin());
    } else {
      if (unlabelled >= 5)
        throw DataError(file + ":" + std::to_string(l.lineno) + ": more than 5 unlabelled matrices");
      name = kOrder[unlabelled++];
    }
    std::vector<double> v;
    for (const auto& s : f) {
      auto d = yamlu::parseDouble(s);
      if (!d || !std::isfinite(*d))
        throw DataError(file + ":" + std::to_string(l.lineno) + ": '" + s + "' is not a number in matrix " + name);
      v.push_back(*d);
    }
    if (v.size() != 12)
      throw DataError(file + ":" + std::to_string(l.lineno) + ": matrix " + name + " has " + std::to_string(v.size()) +
                      " numbers, expected 12 (3x4 row-major)");
    c.matrices.emplace_back(name, v);
  }
  return c;
}

std::string KittiDataset::description() const {
  return "KITTI odometry stereo sequence (image_0/image_1 or image_l/image_r, calib.txt, optional times.txt, "
         "poses.txt)";
}

std::vector<ParamSpec> KittiDataset::paramSpecs() const {
  return {
      P_required("path", ParamType::Path, "sequence folder"),
      P_bool("stereo", true, "read the right images (false: monocular, left only)"),
      P_string("left_dir", "", "left image folder relative to the sequence; '' = image_0, image_l or image_2"),
      P_string("right_dir", "", "right image folder; '' = the partner of the left one (image_1, image_r, image_3)"),
      P_string("calib", "calib.txt", "calibration file relative to the sequence"),
      P_string("times", "times.txt", "frame times file (one per line); used if it exists, else i / rate"),
      P_double("rate", 10.0, "frame rate in Hz when there is no times file (KITTI: 10 Hz)", 1e-6),
      P_string("poses", "poses.txt", "ground truth (KITTI 3x4 T_wc per frame) relative to the sequence; '' = none"),
  };
}

namespace {

/** Frame times: the times file (one per line, as many as images), else i / rate. */
std::vector<double> kittiTimes(const Params& p, const std::string& root, size_t n_images, const std::string& left_dir,
                               double rate) {
  std::vector<double> stamps;
  const std::string times = p.getString("times");
  const std::string tf = times.empty() ? "" : resolvePath(times, root);
  if (!tf.empty() && fileExists(tf)) {
    for (const auto& l : readDataLines(tf)) {
      const auto f = splitFields(l.text);
      const auto t = f.size() == 1 ? yamlu::parseDouble(f[0]) : std::nullopt;
      if (!t) throw DataError(tf + ":" + std::to_string(l.lineno) + ": expected one time in seconds, got '" + l.text + "'");
      stamps.push_back(*t);
    }
    if (stamps.size() != n_images)
      throw DataError(tf + ": has " + std::to_string(stamps.size()) + " times but " + left_dir + " has " +
                      std::to_string(n_images) + " images");
    ds::requireIncreasing(stamps, tf);
  } else {
    if (p.isGiven("times") && !times.empty()) requireFile(tf, "KITTI times file", kKittiLayout);
    for (size_t i = 0; i < n_images; i++) stamps.push_back(static_cast<double>(i) / rate);
  }
  return stamps;
}

/** Rectified camera from the projection matrices `pl` / `pr` of calib.txt
 *  and the size of the first readable left image (fps set by the caller). */
CameraModel kittiCamera(const std::string& cf, const std::string& pl, const std::string& pr, bool stereo,
                        const std::string& left_dir, const std::vector<std::string>& names) {
  requireFile(cf, "KITTI calibration file", kKittiLayout);
  const KittiCalib calib = readKittiCalib(cf);
  const auto* P_l = calib.find(pl);
  const auto* P_r = calib.find(pr);
  if (!P_l) throw DataError(cf + ": no matrix " + pl + " for the left camera (" + kKittiLayout + ")");
  if (stereo && !P_r) throw DataError(cf + ": no matrix " + pr + " for the right camera (" + kKittiLayout + ")");
  CameraModel cam;
  cam.name = "kitti";
  cam.sensor = stereo ? SensorType::Stereo : SensorType::Monocular;
  cam.left.fx = (*P_l)[0];
  cam.left.fy = (*P_l)[5];
  cam.left.cx = (*P_l)[2];
  cam.left.cy = (*P_l)[6];
  if (!(cam.left.fx > 0) || !(cam.left.fy > 0)) throw DataError(cf + ": matrix " + pl + " has no positive focal length");
  if (P_r) {
    cam.baseline = ((*P_l)[3] - (*P_r)[3]) / cam.left.fx;
    if (stereo && !(cam.baseline > 0))
      throw DataError(cf + ": baseline from " + pl + "/" + pr + " is " + std::to_string(cam.baseline) +
                      " m; expected > 0 (P1[0][3] = -fx * baseline)");
  }
  // Image size from the first readable left image.
  for (size_t i = 0; i < std::min<size_t>(names.size(), 5) && cam.left.width == 0; i++) {
    cv::Mat im = readImageFile(left_dir + "/" + names[i], cv::IMREAD_UNCHANGED);
    cam.left.width = im.cols;
    cam.left.height = im.rows;
  }
  if (cam.left.width == 0) throw DataError("KITTI: cannot read any of the first images in " + left_dir);
  if (!cam.left.principalPointInside())
    throw DataError(cf + ": matrix " + pl + " puts the principal point (" + formatNumber("%g", cam.left.cx) + ", " +
                    formatNumber("%g", cam.left.cy) + ") outside the " + std::to_string(cam.left.width) + "x" +
                    std::to_string(cam.left.height) + " images of " + left_dir);
  cam.right = cam.left;
  cam.T_left_right = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(cam.baseline, 0, 0));
  cam.rectified = true;
  cam.depth_threshold = 35.0;  // ORB-SLAM2 KITTI*.yaml ThDepth
  cam.depth_factor = 1.0;
  return cam;
}

}  // namespace

void KittiDataset::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  root_ = p.getString("path");
  requireDir(root_, "KITTI sequence folder", kKittiLayout);
  stereo_ = p.getBool("stereo");

  // Image folders and the matching projection matrices.
  std::string left = p.getString("left_dir"), right = p.getString("right_dir");
  static const std::vector<std::array<const char*, 4>> kPairs = {
      {"image_0", "image_1", "P0", "P1"}, {"image_l", "image_r", "P0", "P1"}, {"image_2", "image_3", "P2", "P3"}};
  std::string pl = "P0", pr = "P1";
  if (left.empty()) {
    for (const auto& c : kPairs)
      if (dirExists(root_ + "/" + c[0])) {
        left = c[0];
        if (right.empty()) right = c[1];
        pl = c[2];
        pr = c[3];
        break;
      }
    if (left.empty()) throw DataError("KITTI left image folder not found in " + root_ + " (" + kKittiLayout + ")");
  } else {
    for (const auto& c : kPairs)
      if (left == c[0]) {
        if (right.empty()) right = c[1];
        pl = c[2];
        pr = c[3];
      }
    if (stereo_ && right.empty())
      throw ConfigError("KITTI: right_dir must be given with a non-standard left_dir '" + left + "'");
  }
  left_dir_ = resolvePath(left, root_);
  requireDir(left_dir_, "KITTI left image folder", kKittiLayout);
  right_dir_.clear();
  if (stereo_) {
    right_dir_ = resolvePath(right, root_);
    requireDir(right_dir_, "KITTI right image folder", kKittiLayout);
  }
  names_ = ds::listFiles(left_dir_, ".png");
  if (names_.empty()) throw DataError("no .png images in " + left_dir_ + " (" + kKittiLayout + ")");
  if (stereo_) {
    const auto rn = ds::listFiles(right_dir_, ".png");
    if (rn.size() != names_.size())
      DSLAM_LOG(Warn, "KITTI: " << left_dir_ << " has " << names_.size() << " images but " << right_dir_ << " has "
                                << rn.size() << "; frames without a right image fail when read");
  }

  const double rate = p.getDouble("rate");
  stamps_ = kittiTimes(p, root_, names_.size(), left_dir_, rate);
  camera_ = kittiCamera(resolvePath(p.getString("calib"), root_), pl, pr, stereo_, left_dir_, names_);
  camera_->fps = names_.size() > 1 ? (names_.size() - 1) / (stamps_.back() - stamps_.front()) : rate;

  // Ground truth: one pose per frame, in frame order.
  gt_.clear();
  gt_index_.assign(names_.size(), -1);
  const std::string poses = p.getString("poses");
  const std::string pf = poses.empty() ? "" : resolvePath(poses, root_);
  if (!pf.empty() && fileExists(pf)) {
    const Trajectory t = traj::readKitti(pf, "", rate);
    if (t.size() != names_.size())
      DSLAM_LOG(Warn, "KITTI: " << pf << " has " << t.size() << " poses for " << names_.size()
                                << " frames; pose i is used for frame i");
    for (size_t i = 0; i < std::min(t.size(), names_.size()); i++) {
      gt_.push_back(stamps_[i], t.poses[i]);
      gt_index_[i] = static_cast<int>(i);
    }
  } else if (p.isGiven("poses") && !poses.empty()) {
    requireFile(pf, "KITTI ground-truth poses", kKittiLayout);
  }
}

SensorFrame KittiDataset::read(size_t i) {
  ds::requireFrameIndex(i, names_.size());
  SensorFrame f;
  f.index = static_cast<int>(i);
  f.timestamp = stamps_[i];
  f.image_path = left_dir_ + "/" + names_[i];
  f.image = ds::readCameraImage(f.image_path, i, "left image");
  if (stereo_) {
    f.image_right_path = right_dir_ + "/" + names_[i];
    f.image_right = ds::readCameraImage(f.image_right_path, i, "right image");
    if (f.image_right.size() != f.image.size())
      throw DataError("frame " + std::to_string(i) + ": right image " + f.image_right_path +
                      " size differs from the left image " + f.image_path);
  }
  if (gt_index_[i] >= 0) f.gt_T_wc = gt_.poses[gt_index_[i]];
  return f;
}

}  // namespace dslam
