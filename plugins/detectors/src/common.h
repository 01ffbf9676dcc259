#pragma once
// Helpers shared by the detector plugins (private to plugins/detectors).
#include <string>
#include <vector>

#include <opencv2/dnn/dnn.hpp>

#include "dslam/core/detection.h"
#include "dslam/core/frame.h"
#include "dslam/core/params.h"
#include "dslam/plugins/detectors/decode.h"

namespace dslam::det {

/** Hint appended to missing-model errors. */
extern const char* kModelHint;

/** Model file from a Path param: `value` if non-empty, else
 *  sharedDir()/`default_rel`. Throws DataError naming the file if missing. */
std::string modelFile(const std::string& value, const std::string& default_rel, const std::string& what);

/** cv::dnn::readNet* wrapped: cv::Exception -> DataError naming the files. */
cv::dnn::Net loadNet(const std::string& what, const std::string& model, const std::string& config,
                     const std::string& framework = "");

/** 8-bit BGR view/copy of a frame image (grey and BGRA converted). Throws
 *  DataError naming the frame for empty or non-8-bit images. */
cv::Mat toBgr8(const SensorFrame& f);

/** Reads a class-names file (one name per line, blank lines ignored). */
std::vector<std::string> readNames(const std::string& file);

/** COCO id per model class: explicit `override_ids` if non-empty (must have
 *  `names.size()` entries when names are known), else 80 names = YOLO COCO
 *  order, else by name (COCO names, Darknet spellings, body/pedestrian/human
 *  = person). Throws ConfigError naming the file and the unknown name. */
std::vector<int> cocoIdsForNames(const std::vector<std::string>& names, const std::vector<int>& override_ids,
                                 const std::string& names_file);

/** Validates a `classes` filter list (COCO ids); throws ConfigError. */
std::vector<int> classFilter(const Params& p, const std::string& key = "classes");

/** Raw boxes -> BoundingBoxes with COCO ids, clipped to the image; drops
 *  boxes whose class is not in `keep` (if non-empty) or that clip to nothing. */
std::vector<BoundingBox> toBoxes(const std::vector<RawBox>& raw, const std::vector<int>& coco_ids,
                                 const std::vector<int>& keep, cv::Size image);

/** Removes raw boxes whose mapped class is not in `keep` (if non-empty). */
void filterRaw(std::vector<RawBox>& raw, const std::vector<int>& coco_ids, const std::vector<int>& keep);

/** Detections with frame index and timestamp filled. */
Detections emptyDetections(const SensorFrame& f);

/** Runs net.forward on all `names`; wraps cv::Exception into DataError. */
std::vector<cv::Mat> forward(cv::dnn::Net& net, const std::vector<std::string>& names, const std::string& what,
                             int frame_index);

}  // namespace dslam::det
