#include "dslam/core/registry.h"
#include "dslam/plugins/detectors/darknet_yolo.h"
#include "dslam/plugins/detectors/dnn_semantic.h"
#include "dslam/plugins/detectors/file_detector.h"
#include "dslam/plugins/detectors/ground_truth.h"
#include "dslam/plugins/detectors/hog_people.h"
#include "dslam/plugins/detectors/yolox_onnx.h"

namespace dslam {

void register_detectors_plugins() {
  registerPlugin<DarknetYoloDetector>();
  registerPlugin<YoloxOnnxDetector>();
  registerPlugin<HogPeopleDetector>();
  registerPlugin<DnnSemanticSegmenter>();
  registerPlugin<FileDetector>();
  registerPlugin<GroundTruthDetector>();
}

}  // namespace dslam
