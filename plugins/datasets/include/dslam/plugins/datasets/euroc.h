#pragma once
/** \file euroc.h
 *  EuRoC MAV dataset, ASL folder layout:
 *
 *      <root>/mav0/cam0/data.csv        "#timestamp [ns],filename" then "ns,name.png" lines
 *      <root>/mav0/cam0/data/<ns>.png    (without data.csv: every PNG, named <ns>.png)
 *      <root>/mav0/cam0/sensor.yaml     intrinsics [fu, fv, cu, cv], distortion_coefficients
 *                                       (radial-tangential k1 k2 p1 p2), resolution, T_BS, rate_hz
 *      <root>/mav0/cam1/...             right camera, same layout
 *      <root>/mav0/state_groundtruth_estimate0/data.csv   optional ground truth (body frame)
 *      <root>/groundtruth.txt           optional ground truth, TUM format (body frame)
 *
 *  Stereo pairs are matched by timestamp. Camera: unrectified stereo with
 *  both intrinsics and distortions, T_left_right = T_BS(cam0)^-1 T_BS(cam1),
 *  T_body_cam = T_BS(cam0). Ground truth is returned as camera poses:
 *  T_wc = T_wb * T_body_cam (the world frame is the ground-truth frame). */
#include <cstdint>
#include <string>
#include <vector>

#include "dslam/core/dataset.h"

namespace dslam {

/** Contents of one EuRoC sensor.yaml. */
struct EurocCameraInfo {
  PinholeCamera cam;
  SE3 T_BS;            ///< sensor pose in the body frame
  double rate_hz = 0;  ///< 0 if absent
};
/** Parses a camera sensor.yaml (`%YAML:1.0` header accepted). Throws
 *  DataError naming the file and key. */
EurocCameraInfo readEurocSensorYaml(const std::string& file);

/** One entry of a cam data.csv. */
struct EurocImageEntry {
  int64_t stamp_ns = 0;
  std::string file;  ///< relative to the cam's data/ folder
};
/** Reads mav0/camN/data.csv (or lists data/ if it does not exist), sorted by
 *  time; of repeated times the last line is kept (one warning). */
std::vector<EurocImageEntry> readEurocImageList(const std::string& cam_dir);

class EurocDataset : public DatasetSource {
  DEFINE_MRPT_OBJECT(EurocDataset, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  size_t size() const override { return frames_.size(); }
  SensorFrame read(size_t i) override;
  double timestamp(size_t i) const override;
  SensorType sensor() const override { return stereo_ ? SensorType::Stereo : SensorType::Monocular; }
  std::optional<CameraModel> camera() const override { return camera_; }
  std::string root() const override { return root_; }

  /** Ground truth as read, in the body frame (T_wb); groundTruth() is T_wc. */
  const Trajectory& groundTruthBody() const { return gt_body_; }
  /** File the ground truth came from ("" if none). */
  const std::string& groundTruthFile() const { return gt_file_; }
  /** Frame stamp in nanoseconds (exact). */
  int64_t timestampNs(size_t i) const { return frames_.at(i).t_ns; }

 private:
  struct Item {
    int64_t t_ns = 0;
    std::string left, right;  ///< absolute paths
  };
  std::string root_, gt_file_;
  std::vector<Item> frames_;
  std::optional<CameraModel> camera_;
  Trajectory gt_body_;
  bool stereo_ = true;
};

}  // namespace dslam
