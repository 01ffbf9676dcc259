#pragma once
/** \file label_io.h
 *  Readers and writers of the per-frame label formats of docs/detectors.md:
 *  box JSON, semantic label PNG and COCO panoptic PNG + JSON. Used by
 *  FileDetector and GroundTruthDetector, by tests, and by anything that
 *  writes labels (synthetic scenes, export scripts). Errors are DataErrors
 *  naming the file (and the JSON line when known). */
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/core/detection.h"

namespace dslam::labels {

// ---------------------------------------------------------------- box JSON

/** Reads `{"boxes": [{"category_id", "bbox": [x, y, w, h], "score"?,
 *  "instance_id"?}, ...]}` (or a top-level list of box objects).
 *  `index80`: category_id holds YOLO 0..79 indices, converted to COCO ids.
 *  `size` (optional out): the "width"/"height" fields, (0, 0) if absent. */
std::vector<BoundingBox> readBoxJson(const std::string& file, bool index80 = false, cv::Size* size = nullptr);
/** Box JSON text (the format read by readBoxJson). `size`/`image` are
 *  written when non-empty. */
std::string boxJsonText(const std::vector<BoundingBox>& boxes, cv::Size size = {}, const std::string& image = "");
void writeBoxJson(const std::string& file, const std::vector<BoundingBox>& boxes, cv::Size size = {},
                  const std::string& image = "");

// ------------------------------------------------------- semantic label PNG

/** Reads an 8-bit (or 16-bit with values <= 255) single-channel PNG of COCO
 *  ids (255 = none) as CV_8U. */
cv::Mat readSemanticPng(const std::string& file);
/** Writes a CV_8U label image as PNG. */
void writeSemanticPng(const std::string& file, const cv::Mat& labels);

// --------------------------------------------------------- COCO panoptic

/** RGB PNG -> CV_32S ids, id = R + 256 G + 256^2 B. */
cv::Mat readPanopticPng(const std::string& file);
/** CV_32S ids (0 .. 2^24-1) -> RGB PNG. */
void writePanopticPng(const std::string& file, const cv::Mat& ids);

struct PanopticCategory {
  int id = 0;
  std::string name;
  bool isthing = false;
};

/** One `annotations[]` entry. Segment kinds are filled from the label set
 *  when read (readPanopticJson); instance_id is the `instance_id` key or -1
 *  if absent. */
struct PanopticAnnotation {
  std::string file_name;
  std::string image_id;
  std::vector<PanopticSegment> segments;
};

struct PanopticJson {
  std::string file;                          ///< where it was read from
  std::vector<PanopticCategory> categories;  ///< label set (COCO 133 if the file had none)
  bool has_categories = false;               ///< the file had a `categories` list
  std::vector<PanopticAnnotation> annotations;
  std::map<std::string, size_t> by_file;     ///< file_name (and its stem) -> index in annotations

  const PanopticCategory* category(int id) const;
  /** Annotation for a PNG file name or stem, or nullptr. */
  const PanopticAnnotation* find(const std::string& file_name_or_stem) const;
};

/** The 133 COCO panoptic categories (dslam::coco) as PanopticCategory. */
std::vector<PanopticCategory> cocoPanopticCategories();

/** Reads a COCO panoptic JSON: either the whole-dataset form
 *  `{"annotations": [...], "categories": [...]}` or a single annotation
 *  object `{"file_name"?, "segments_info": [...]}` (per-frame file). */
PanopticJson readPanopticJson(const std::string& file);
std::string panopticJsonText(const std::vector<PanopticAnnotation>& annotations,
                             const std::vector<PanopticCategory>& categories);
void writePanopticJson(const std::string& file, const std::vector<PanopticAnnotation>& annotations,
                       const std::vector<PanopticCategory>& categories);

/** Combines a panoptic id image with its annotation into Detections fields:
 *  out.panoptic = ids; out.segments = one segment per non-zero id present
 *  in the image or listed in the annotation. Kinds: Thing/Stuff from the
 *  label set; Unknown for categories not in it and for ids in the image
 *  without a segments_info entry (category 0). Missing bbox/area are
 *  computed from the image. Things without an instance_id get their
 *  segment id; stuff gets -1. `ann` may be null (every id Unknown). */
void fillPanoptic(const cv::Mat& ids, const PanopticAnnotation* ann, const PanopticJson& label_set,
                  Detections& out);

/** Semantic image (COCO id per pixel, 255 none) derived from a panoptic
 *  result: each segment's pixels get its category id (Unknown -> 255). */
cv::Mat semanticFromPanoptic(const Detections& d);

/** JSON text of a Detections (boxes and segments, not the images), for
 *  `dslam detect --json`. */
std::string detectionsJsonText(const Detections& d);

}  // namespace dslam::labels
