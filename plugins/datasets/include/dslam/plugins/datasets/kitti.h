#pragma once
/** \file kitti.h
 *  KITTI odometry stereo sequence:
 *
 *      <root>/image_0/ + image_1/   (or image_l/ + image_r/, image_2/ + image_3/)
 *                                   rectified PNGs, same file names left and right
 *      <root>/calib.txt             P0..P3 3x4 projection matrices, "P0: 12 numbers"
 *                                   lines or the bare 12 numbers in P0, P1, ... order
 *      <root>/times.txt             optional, one time per frame (else i / rate)
 *      <root>/poses.txt             optional ground truth, 3x4 T_wc of the left camera
 *                                   per line (frame 0 = identity)
 *
 *  Camera: stereo, rectified; fx, fy, cx, cy from the left P matrix,
 *  baseline = (P_left[0][3] - P_right[0][3]) / fx (= -P1[0][3] / fx). */
#include <string>
#include <vector>

#include "dslam/core/dataset.h"

namespace dslam {

/** Projection matrices read from a KITTI calib.txt, indexed by name ("P0",
 *  "P1", ..., "Tr"); unlabelled lines get P0, P1, P2, P3, Tr in order.
 *  Throws DataError "file:line: ..." for lines without 12 numbers. */
struct KittiCalib {
  std::vector<std::pair<std::string, std::vector<double>>> matrices;
  const std::vector<double>* find(const std::string& name) const;
};
KittiCalib readKittiCalib(const std::string& file);

class KittiDataset : public DatasetSource {
  DEFINE_MRPT_OBJECT(KittiDataset, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  size_t size() const override { return names_.size(); }
  SensorFrame read(size_t i) override;
  double timestamp(size_t i) const override { return stamps_.at(i); }
  SensorType sensor() const override { return stereo_ ? SensorType::Stereo : SensorType::Monocular; }
  std::optional<CameraModel> camera() const override { return camera_; }
  std::string root() const override { return root_; }

  const std::string& leftDir() const { return left_dir_; }
  const std::string& rightDir() const { return right_dir_; }

 private:
  std::string root_, left_dir_, right_dir_;
  std::vector<std::string> names_;  ///< image file names (same in both folders)
  std::vector<double> stamps_;
  std::vector<int> gt_index_;  ///< index into gt_ per frame, -1 = none
  std::optional<CameraModel> camera_;
  bool stereo_ = true;
};

}  // namespace dslam
