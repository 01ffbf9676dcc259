#include "dslam/plugins/classifiers/semantic_filter.h"

#include <opencv2/imgproc.hpp>

#include "common.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"

IMPLEMENTS_MRPT_OBJECT(SemanticFilter, KeypointClassifier, dslam)

namespace dslam {

std::string SemanticFilter::description() const {
  return "a-priori removal: keypoints on semantic/panoptic pixels of dynamic classes (person) are dynamic";
}

std::vector<ParamSpec> SemanticFilter::paramSpecs() const {
  return {
      P_list("classes", ParamType::IntList, "[1]",
             "COCO ids removed a priori (DeepLabV3+ SLAM, STDyn-SLAM: person = 1)"),
      P_int("dilation", 0, "grow the dynamic mask by this many pixels (0 = exact mask, as the papers)", 0, 1000),
      P_enum("source", "auto", {"auto", "semantic", "panoptic"},
             "label input: semantic image, panoptic segments, or auto (semantic if present)"),
      P_bool("ground_truth", false, "labels are ground truth (reason GroundTruth instead of SemanticDynamic)"),
  };
}

void SemanticFilter::configure(const Params& p, const PluginContext& ctx) {
  KeypointClassifier::configure(p, ctx);
  classes_ = cls::cocoIdList(p, "classes");
  dilation_ = static_cast<int>(p.getInt("dilation"));
  source_ = p.getString("source");
  ground_truth_ = p.getBool("ground_truth");
}

void SemanticFilter::classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) {
  cls::ensureMeta(frame);
  if (!det.valid) return;
  const bool have_sem = !det.semantic.empty();
  const bool have_pan = !det.panoptic.empty();
  bool use_sem = false;
  if (source_ == "semantic") {
    if (!have_sem) return;
    use_sem = true;
  } else if (source_ == "panoptic") {
    if (!have_pan) return;
  } else {
    if (!have_sem && !have_pan) return;
    use_sem = have_sem;
  }
  const cv::Mat& lab = use_sem ? det.semantic : det.panoptic;
  if (use_sem && lab.type() != CV_8U)
    throw DataError("frame " + std::to_string(frame.index()) + ": semantic label image must be CV_8U, got type " +
                    std::to_string(lab.type()));
  if (!use_sem && lab.type() != CV_32S)
    throw DataError("frame " + std::to_string(frame.index()) + ": panoptic image must be CV_32S, got type " +
                    std::to_string(lab.type()));
  const cv::Size ref = cls::imageSize(frame, ctx.camera, lab.size());
  const cls::PixelLookup lut(lab, ref);
  const cls::SegmentIndex segs(det);
  const KpReason reason = ground_truth_ ? KpReason::GroundTruth : KpReason::SemanticDynamic;

  // Category / instance of a label pixel.
  auto category = [&](const cv::Point& q, int& instance) -> int {
    instance = -1;
    if (use_sem) {
      const int c = lab.at<uint8_t>(q);
      return c == coco::kNone ? -1 : c;
    }
    const int id = lab.at<int32_t>(q);
    if (id == 0) return -1;
    const PanopticSegment* s = segs.find(id);
    if (!s || s->kind == SegmentKind::Unknown || s->category_id <= 0) return -1;
    instance = s->kind == SegmentKind::Thing ? s->instance_id : -1;
    return s->category_id;
  };

  cv::Mat mask;  // dilated dynamic mask (only with dilation > 0)
  if (dilation_ > 0) {
    if (use_sem) {
      cv::Mat table(1, 256, CV_8U, cv::Scalar(0));
      for (int c : classes_)
        if (c >= 0 && c < 255) table.at<uint8_t>(c) = 255;
      cv::LUT(lab, table, mask);
    } else {
      mask = cv::Mat::zeros(lab.size(), CV_8U);
      int last_id = 0;
      bool last_dyn = false;
      for (int r = 0; r < lab.rows; r++) {
        const int32_t* l = lab.ptr<int32_t>(r);
        uint8_t* m = mask.ptr<uint8_t>(r);
        for (int c = 0; c < lab.cols; c++) {
          if (l[c] == 0) continue;
          if (l[c] != last_id) {
            int inst;
            last_id = l[c];
            last_dyn = cls::contains(classes_, category(cv::Point(c, r), inst));
          }
          if (last_dyn) m[c] = 255;
        }
      }
    }
    const cv::Mat k = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * dilation_ + 1, 2 * dilation_ + 1));
    cv::dilate(mask, mask, k);
  }

  for (size_t i = 0; i < frame.size(); i++) {
    const auto q = lut.pixel(frame.keypoints[i].pt);
    if (!q) continue;
    int inst = -1;
    const int c = category(*q, inst);
    KeypointMeta& m = frame.meta[i];
    if (c >= 0) {
      m.class_id = static_cast<int16_t>(c);
      if (inst >= 0) m.object_id = inst;
    }
    const bool dyn = dilation_ > 0 ? mask.at<uint8_t>(*q) != 0 : cls::contains(classes_, c);
    if (dyn) cls::raise(m, KpLabel::Dynamic, reason);
  }
}

}  // namespace dslam
