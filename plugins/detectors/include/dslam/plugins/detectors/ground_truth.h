#pragma once
/** \file ground_truth.h
 *  Ground-truth labels of synthetic scenes, degraded on purpose for
 *  ablations (misses, jitter, false positives, label swaps, latency). */
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "dslam/core/detector.h"
#include "dslam/plugins/detectors/file_detector.h"

namespace dslam {

/** How to degrade perfect labels. All zero = exact labels. */
struct Degradation {
  double miss_rate = 0;            ///< probability to drop an object (box + mask) in a frame
  double jitter = 0;               ///< max box centre shift and size change, fraction of the box size
  double false_positive_rate = 0;  ///< expected false-positive boxes per frame
  int fp_class = 1;                ///< COCO id of false positives
  double fp_min_size = 0.1, fp_max_size = 0.4;  ///< false-positive box size, fraction of the image
  bool fp_in_masks = false;        ///< also paint false positives into semantic/panoptic (ellipse)
  double swap_rate = 0;            ///< probability to change an object's class
  std::vector<int> swap_classes;   ///< classes to swap to (empty = the 80 COCO thing classes)
};

/** Uniform [0, 1) number from (seed, frame, object, salt): independent of
 *  call order. */
double hashUniform(uint64_t seed, int64_t frame, int64_t object, uint64_t salt);

/** Applies `d` to `truth` (labels of source frame `frame`). Objects are
 *  identified by instance_id (boxes and thing segments share it); boxes
 *  without one by their position in the list. A missed object loses its
 *  box, its panoptic segment (pixels -> 0, void) and its semantic pixels
 *  (-> 255; without panoptic: pixels of its class inside its box). A
 *  swapped object changes class in all three. Jitter moves only boxes.
 *  `image` bounds the boxes (clipped) and false positives. */
Detections degrade(const Detections& truth, const Degradation& d, uint64_t seed, int64_t frame, cv::Size image);

/** Reads the synthetic generator's labels from <dataset_root>/boxes,
 *  semantic, panoptic (FileDetector formats) and degrades them. Random
 *  decisions hash (pipeline seed, frame, object) so they do not depend on
 *  call order. `latency` N outputs the labels of the frame N positions
 *  earlier in the sorted label list (valid = false for the first N). */
class GroundTruthDetector : public Detector {
  DEFINE_MRPT_OBJECT(GroundTruthDetector, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  Detections detect(const SensorFrame& frame) override;
  unsigned outputs() const override { return src_.outputs(); }
  bool precomputed() const override { return true; }
  const Degradation& degradation() const { return deg_; }

 private:
  LabelSource src_;
  Degradation deg_;
  std::vector<std::string> keys_;
  std::map<std::string, int64_t> key_pos_;
  int latency_ = 0;
  uint64_t seed_ = 0;
  bool fail_on_missing_ = false;
  std::vector<int> keep_;
  size_t missing_ = 0;  // detect() is called one at a time per instance
};

}  // namespace dslam
