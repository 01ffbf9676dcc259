#pragma once
/** \file tum.h
 *  TUM RGB-D folder reader (also used for Bonn RGB-D Dynamic and our
 *  synthetic scenes):
 *
 *      <root>/rgb.txt, depth.txt        "timestamp path" lines, '#' comments
 *      <root>/associations.txt          optional "t_rgb rgb t_depth depth"
 *      <root>/groundtruth.txt           optional TUM trajectory
 *      <root>/rgb/ and depth/ PNGs      depth uint16, factor 5000 */
#include <string>
#include <vector>

#include "dslam/core/dataset.h"

namespace dslam {

/** One line of a TUM list file. */
struct TumEntry {
  double stamp = 0;
  std::string path;  ///< relative to the root
};

/** Reads "timestamp path" lines (rgb.txt, depth.txt). */
std::vector<TumEntry> readTumList(const std::string& file);

/** TUM associate.py semantics: greedy one-to-one matching of the pairs with
 *  the smallest |t_a - t_b| first, |dt| < max_dt; result sorted by t_a.
 *  Returns index pairs (i into a, j into b). */
std::vector<std::pair<size_t, size_t>> associateStamps(const std::vector<double>& a, const std::vector<double>& b,
                                                       double max_dt);

class TumDataset : public DatasetSource {
  DEFINE_MRPT_OBJECT(TumDataset, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  size_t size() const override { return frames_.size(); }
  SensorFrame read(size_t i) override;
  double timestamp(size_t i) const override;
  SensorType sensor() const override { return SensorType::RGBD; }
  std::optional<CameraModel> camera() const override { return camera_; }
  std::string root() const override { return root_; }

 protected:
  /** Preset used when `preset: auto` finds no freiburgN in the folder name. */
  virtual std::string defaultPreset() const { return "tum_fr1"; }

  struct Item {
    double t_rgb, t_depth;
    std::string rgb, depth;
  };
  std::string root_;
  std::vector<Item> frames_;
  std::optional<CameraModel> camera_;
  double depth_factor_ = 5000;
};

/** Bonn RGB-D Dynamic: TUM layout with its own intrinsics preset. */
class BonnDataset : public TumDataset {
  DEFINE_MRPT_OBJECT(BonnDataset, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;

 protected:
  std::string defaultPreset() const override { return "bonn"; }
};

}  // namespace dslam
