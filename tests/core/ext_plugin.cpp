// A minimal external plugin library: a KeypointClassifier that marks every
// keypoint dynamic. Loaded by test_registry through DSLAM_PLUGIN_PATH /
// loadExternalPlugins().
#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/registry.h"

namespace dslam_ext {
class MarkAllDynamic : public dslam::KeypointClassifier {
  DEFINE_MRPT_OBJECT(MarkAllDynamic, dslam_ext)
 public:
  std::string description() const override { return "test plugin: marks every keypoint dynamic"; }
  std::vector<dslam::ParamSpec> paramSpecs() const override {
    return {dslam::P_double("strength", 1.0, "unused test parameter")};
  }
  void classify(dslam::Frame& f, const dslam::Detections&, const dslam::ClassifierContext&) override {
    for (auto& m : f.meta) m.label = dslam::KpLabel::Dynamic;
  }
};
}  // namespace dslam_ext

IMPLEMENTS_MRPT_OBJECT(MarkAllDynamic, dslam::KeypointClassifier, dslam_ext)

extern "C" void dslam_register_plugins() { dslam::registerPlugin<dslam_ext::MarkAllDynamic>(); }
