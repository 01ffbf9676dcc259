#pragma once
/** \file hog_people.h
 *  OpenCV's HOG + linear SVM people detector (Dalal-Triggs), no model file. */
#include <string>
#include <vector>

#include <opencv2/objdetect.hpp>

#include "dslam/core/detector.h"

namespace dslam {

/** cv::HOGDescriptor with getDefaultPeopleDetector() (64x128 window),
 *  detectMultiScale; outputs person boxes (COCO id 1). Score = logistic of
 *  the SVM margin. Defaults are those of OpenCV's peopledetect sample. */
class HogPeopleDetector : public Detector {
  DEFINE_MRPT_OBJECT(HogPeopleDetector, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  Detections detect(const SensorFrame& frame) override;
  unsigned outputs() const override { return kBoxes; }

 private:
  cv::HOGDescriptor hog_;
  double hit_threshold_ = 0, scale_ = 1.05, min_score_ = 0;
  int win_stride_ = 8, padding_ = 0, group_threshold_ = 2, max_width_ = 0;
  bool shrink_ = true;
};

}  // namespace dslam
