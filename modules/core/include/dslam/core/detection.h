#pragma once
/** \file detection.h
 *  Output of a Detector: boxes, a semantic label image and/or panoptic
 *  segments. Class ids are official COCO category ids (see coco.h). */
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dslam {

/** One detected object box. */
struct BoundingBox {
  cv::Rect2f box;        ///< pixels, (x, y) = top-left corner
  int class_id = -1;     ///< COCO category id (person = 1)
  float score = 0.f;     ///< confidence in [0, 1]
  int instance_id = -1;  ///< instance id if the source knows one (synthetic, panoptic), else -1
};

/** Panoptic segment kinds (Panoptic-SLAM): things have instances, stuff is
 *  background-like, unknown is "void" (class not in the label set). */
enum class SegmentKind : uint8_t { Thing, Stuff, Unknown };
const char* toString(SegmentKind k);

struct PanopticSegment {
  int id = 0;            ///< value in Detections::panoptic (0 = void/unknown)
  int category_id = 0;   ///< COCO category id (0 = unknown)
  SegmentKind kind = SegmentKind::Unknown;
  int instance_id = -1;  ///< things: instance id; stuff: -1
  int area = 0;          ///< pixels
  cv::Rect bbox;
  float score = 1.f;
};

/** Everything a detector produced for one frame. Fields a detector does not
 *  fill stay empty. */
struct Detections {
  int frame_index = -1;  ///< frame the detector saw
  double timestamp = 0;
  bool valid = true;  ///< false when the detector skipped this frame (no output)
  /** Frames between the image the detector saw and the frame these
   *  detections are given with: 0 = its own detection; > 0 = an older one
   *  carried to this frame by optical flow (asynchronous detection, or
   *  `every: N` in between), see dslam/slam/detection_carry.h. */
  int age_frames = 0;
  std::vector<BoundingBox> boxes;
  cv::Mat semantic;   ///< CV_8U, COCO id per pixel, 255 = none (empty if not produced)
  cv::Mat panoptic;   ///< CV_32S segment id per pixel, 0 = void (empty if not produced)
  std::vector<PanopticSegment> segments;

  bool empty() const { return boxes.empty() && semantic.empty() && panoptic.empty(); }
  const PanopticSegment* segment(int id) const {
    for (const auto& s : segments)
      if (s.id == id) return &s;
    return nullptr;
  }
};

/** Intersection over union of two boxes. */
inline float iou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const float inter = (a & b).area();
  const float uni = a.area() + b.area() - inter;
  return uni > 0 ? inter / uni : 0.f;
}

}  // namespace dslam
