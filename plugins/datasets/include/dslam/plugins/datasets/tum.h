#pragma once
/** \file tum.h
 *  TUM RGB-D folder reader (also used for Bonn RGB-D Dynamic and our
 *  synthetic scenes):
 *
 *      <root>/rgb.txt, depth.txt        "timestamp path" lines, '#' comments
 *      <root>/associations.txt          optional "t_rgb rgb t_depth depth"
 *      <root>/groundtruth.txt           optional TUM trajectory (T_wc)
 *      <root>/camera.yaml               optional camera file (docs/config.md)
 *      <root>/rgb/ and depth/ PNGs      depth uint16, factor 5000
 *
 *  Frames without a depth list (rgb.txt only, or load_depth: false) are
 *  monocular. Documented in docs/datasets.md. */
#include <string>
#include <vector>

#include "dslam/core/dataset.h"

namespace dslam {

/** One line of a TUM list file. */
struct TumEntry {
  double stamp = 0;
  std::string path;  ///< relative to the root
};

/** Reads "timestamp path" lines (rgb.txt, depth.txt) as TUM's associate.py
 *  does: spaces, tabs and commas separate fields, '#' lines are comments,
 *  extra fields are ignored, a line with a timestamp only is skipped, and the
 *  result is sorted by time with the last line of a repeated time kept (one
 *  warning says what was done). Throws DataError "file:line: ..." for a
 *  field 1 that is not a finite number. */
std::vector<TumEntry> readTumList(const std::string& file);

/** One line of an association file. */
struct TumAssociation {
  double t_rgb = 0, t_depth = 0;
  std::string rgb, depth;  ///< relative to the root
};

/** Reads "t_rgb rgb t_depth depth" lines (associate.py output) with the
 *  same rules as readTumList, keyed by t_rgb; a line with fewer than four
 *  fields is an error. */
std::vector<TumAssociation> readTumAssociations(const std::string& file);

/** TUM associate.py semantics: greedy one-to-one matching of the pairs with
 *  the smallest |t_a - t_b| first, |dt| < max_dt; result sorted by t_a.
 *  Returns index pairs (i into a, j into b). Same as traj::associate(). */
std::vector<std::pair<size_t, size_t>> associateStamps(const std::vector<double>& a, const std::vector<double>& b,
                                                       double max_dt);

/** TUM RGB-D folder reader. Camera: `camera_file`, else a non-auto
 *  `preset`, else <root>/camera.yaml, else the freiburgN/bonn preset named by
 *  the folder, else defaultPreset(). Ground truth: groundtruth.txt (T_wc);
 *  each frame gets the nearest pose within 0.02 s as gt_T_wc. */
class TumDataset : public DatasetSource {
  DEFINE_MRPT_OBJECT(TumDataset, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  size_t size() const override { return frames_.size(); }
  SensorFrame read(size_t i) override;
  double timestamp(size_t i) const override;
  SensorType sensor() const override { return has_depth_ ? SensorType::RGBD : SensorType::Monocular; }
  std::optional<CameraModel> camera() const override { return camera_; }
  std::string root() const override { return root_; }

  /** Absolute paths and depth stamp of frame i (converters, tools). */
  std::string rgbPath(size_t i) const;
  std::string depthPath(size_t i) const;  ///< "" without depth
  double depthTimestamp(size_t i) const;  ///< -1 without depth
  /** Raw depth units per metre (`depth_factor`). */
  double depthFactor() const { return depth_factor_; }
  /** Where the camera came from: "camera.yaml", a file, or "preset <name>". */
  const std::string& cameraSource() const { return camera_source_; }

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
  std::string camera_source_;
  double depth_factor_ = 5000;
  bool has_depth_ = true;
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
