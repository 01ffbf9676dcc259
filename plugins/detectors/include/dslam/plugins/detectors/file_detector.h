#pragma once
/** \file file_detector.h
 *  Detections precomputed by any network and stored per frame in the
 *  formats of docs/detectors.md (box JSON, semantic PNG, COCO panoptic). */
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/detector.h"
#include "dslam/plugins/detectors/label_io.h"

namespace dslam {

/** Locates and reads the label files of one folder:
 *  <root>/<boxes_dir>/<key>.json, <root>/<semantic_dir>/<key>.png,
 *  <root>/<panoptic_dir>/<key>.png + panoptic.json. The key of a frame is
 *  the stem of its image file or its formatted index. */
class LabelSource {
 public:
  struct Options {
    std::string root;
    std::string boxes_dir = "boxes", semantic_dir = "semantic", panoptic_dir = "panoptic";
    /** Sub-folders that must exist (named explicitly by the user). */
    bool require_boxes = false, require_semantic = false, require_panoptic = false;
    std::string panoptic_json;      ///< '' = <root>/panoptic.json, <panoptic_dir>/panoptic.json, per-frame <key>.json
    std::string naming = "stem";    ///< stem | index
    std::string index_format = "%06d";
    int index_offset = 0;
    bool box_index80 = false;       ///< box category_id are YOLO 0..79 indices
    bool semantic_from_panoptic = true;  ///< derive the semantic image from panoptic when there is no semantic folder
    std::map<int, int> semantic_map;     ///< raw semantic value -> COCO id (others unchanged)
  };

  /** Checks folders, loads panoptic.json. Throws DataError / ConfigError. */
  void open(const Options& o);
  /** DetectorOutput flags of what is available. */
  unsigned outputs() const;
  const Options& options() const { return o_; }
  std::string boxesDir() const { return boxes_; }
  std::string semanticDir() const { return semantic_; }
  std::string panopticDir() const { return panoptic_; }

  /** Key (file stem) of a frame: stem of frame.image_path (else the
   *  timestamp with 6 decimals) or index_format(frame.index + offset). */
  std::string key(const SensorFrame& frame) const;
  /** Sorted keys of the label files present in the first available source
   *  (numeric order when every key is a number). */
  std::vector<std::string> keys() const;

  /** Reads every available label of `key` into `out` (boxes, semantic,
   *  panoptic + segments). Returns the paths of the files that do not exist
   *  (empty = complete). `image_size`, if non-empty, is checked against
   *  the label images and box JSON size. Throws DataError for unreadable
   *  files. */
  std::vector<std::string> read(const std::string& key, Detections& out, cv::Size image_size = {}) const;

 private:
  Options o_;
  std::string boxes_, semantic_, panoptic_;
  std::shared_ptr<labels::PanopticJson> pjson_;  ///< whole-sequence JSON (null: per-frame files)
};

/** ParamSpecs shared by FileDetector and GroundTruthDetector (label folder
 *  layout, naming, missing-file policy). */
std::vector<ParamSpec> labelSourceParamSpecs(const std::string& root_doc);
/** LabelSource::Options from those params. The root is the `dir` parameter,
 *  else the dataset folder; ConfigError naming `who` when there is neither. */
LabelSource::Options labelSourceOptions(const Params& p, const PluginContext& ctx, const std::string& who);

/** Precomputed detections from files (any network: Mask R-CNN, Detectron2
 *  panoptic, YOLO exports...). */
class FileDetector : public Detector {
  DEFINE_MRPT_OBJECT(FileDetector, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  Detections detect(const SensorFrame& frame) override;
  unsigned outputs() const override { return src_.outputs(); }
  bool precomputed() const override { return true; }
  const LabelSource& source() const { return src_; }
  /** Frames seen so far whose label files were (partly) missing. */
  size_t missingCount() const { return missing_; }

 private:
  LabelSource src_;
  bool fail_on_missing_ = false;
  std::vector<int> keep_;
  float min_score_ = 0;
  size_t missing_ = 0;  // detect() is called one at a time per instance
};

}  // namespace dslam
