// An out-of-tree keypoint classifier plug-in: my::BorderFilter marks the
// keypoints within `margin` pixels of the image border dynamic (tracking and
// mapping then ignore them), e.g. for a lens with a smeared rim.
//
// A plug-in is a class derived from one of dslam's interfaces
// (KeypointClassifier, Detector, Backend, DatasetSource, MapManager) with
// MRPT's class macros, plus the extern "C" registration function.
#include <dslam/core/keypoint_classifier.h>
#include <dslam/core/registry.h>

namespace my {

class BorderFilter : public dslam::KeypointClassifier {
  DEFINE_MRPT_OBJECT(BorderFilter, my)
 public:
  std::string description() const override { return "example plug-in: keypoints near the image border are dynamic"; }
  std::vector<dslam::ParamSpec> paramSpecs() const override {
    return {dslam::P_double("margin", 16, "border width, pixels", 0, 10000)};
  }
  void configure(const dslam::Params& p, const dslam::PluginContext&) override { margin_ = static_cast<float>(p.getDouble("margin")); }
  void classify(dslam::Frame& f, const dslam::Detections&, const dslam::ClassifierContext&) override {
    const float w = static_cast<float>(f.gray.cols), h = static_cast<float>(f.gray.rows);
    for (size_t i = 0; i < f.size(); i++) {
      const cv::Point2f& p = f.keypoints[i].pt;
      if (p.x < margin_ || p.y < margin_ || p.x >= w - margin_ || p.y >= h - margin_) {
        f.meta[i].label = dslam::KpLabel::Dynamic;
        f.meta[i].reason = dslam::KpReason::None;
      }
    }
  }

 private:
  float margin_ = 16;
};

}  // namespace my

IMPLEMENTS_MRPT_OBJECT(BorderFilter, dslam::KeypointClassifier, my)

extern "C" void dslam_register_plugins() { dslam::registerPlugin<my::BorderFilter>(); }
