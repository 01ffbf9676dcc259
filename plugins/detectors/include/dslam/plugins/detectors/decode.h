#pragma once
/** \file decode.h
 *  Model-independent pre/post-processing of the YOLO-family detectors,
 *  factored out of the plugins so they can be tested on crafted blobs. */
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dslam::det {

/** A decoded box before class mapping: class index of the model. */
struct RawBox {
  cv::Rect2f box;  ///< image pixels, top-left + size
  int class_index = -1;
  float score = 0.f;
};

/** "[1x3549x85]" */
std::string shapeString(const cv::Mat& m);

/** Decodes one Darknet YOLO/region output layer as produced by OpenCV's DNN
 *  (`readNetFromDarknet`): rows [cx, cy, w, h, objectness, score_0 ..
 *  score_{C-1}], box values normalised to [0, 1] of the network input. The
 *  input is a plain resize of the image, so boxes scale by `image_size`.
 *  Score of a row = its best class score (OpenCV's region layer already
 *  multiplies class probabilities by the objectness) or, with
 *  `multiply_objectness`, objectness * class score. Rows scoring below
 *  `conf` are dropped. Accepts [N, 5+C] or [1, N, 5+C]; `num_classes` <= 0
 *  accepts any C >= 1. Throws DataError naming `layer` and the shape for any
 *  other shape. */
void decodeYoloRegion(const cv::Mat& out, const std::string& layer, int num_classes, float conf, cv::Size image_size,
                      bool multiply_objectness, std::vector<RawBox>& boxes);

/** YOLOX letterbox: resizes `img` by r = min(W/w, H/h) into the top-left of
 *  an `input`-sized image filled with `pad`. Returns the padded image and
 *  sets `ratio` = r. */
cv::Mat letterbox(const cv::Mat& img, cv::Size input, double pad, float& ratio);

/** Number of YOLOX anchor points for an input size and strides. */
int yoloxAnchorCount(cv::Size input, const std::vector<int>& strides);

/** Decodes a YOLOX head output [1, N, 5+C] (or [N, 5+C]) with N =
 *  yoloxAnchorCount(input, strides): for the anchor at grid cell (gx, gy) of
 *  stride s, cx = (x + gx) s, cy = (y + gy) s, w = exp(w) s, h = exp(h) s in
 *  letterboxed input pixels, divided by `ratio` to get image pixels; score =
 *  objectness * class score (best class). Rows below `conf` are dropped.
 *  Throws DataError naming `layer` and the shape if N or C do not match. */
void decodeYolox(const cv::Mat& out, const std::string& layer, cv::Size input, const std::vector<int>& strides,
                 float ratio, int num_classes, float conf, std::vector<RawBox>& boxes);

/** Non-maximum suppression with cv::dnn::NMSBoxes, per class
 *  (`per_class`) or across classes. Returns the kept boxes sorted by
 *  decreasing score. */
std::vector<RawBox> nms(const std::vector<RawBox>& boxes, float score_threshold, float nms_threshold, bool per_class);

/** Clips a box to the image rectangle. */
cv::Rect2f clipBox(const cv::Rect2f& b, cv::Size image);

}  // namespace dslam::det
