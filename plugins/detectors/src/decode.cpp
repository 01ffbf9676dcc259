#include "dslam/plugins/detectors/decode.h"

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include "dslam/core/error.h"

namespace dslam::det {

std::string shapeString(const cv::Mat& m) {
  if (m.empty()) return "[empty]";
  std::string s("[");
  for (int i = 0; i < m.dims; i++) {
    if (i) s.push_back('x');
    s.append(std::to_string(m.size[i]));
  }
  if (m.channels() > 1) s.append("x").append(std::to_string(m.channels())).append("ch");
  s.push_back(']');
  return s;
}

namespace {

/** Views a [N, K] or [1, N, K] CV_32F blob as a 2-D N x K matrix, or throws. */
cv::Mat rows2d(const cv::Mat& out, const std::string& layer, const std::string& expected) {
  auto bad = [&](const std::string& why) {
    return DataError("output layer '" + layer + "' has unexpected shape " + shapeString(out) + " (expected " +
                     expected + (why.empty() ? "" : "; " + why) + ")");
  };
  if (out.empty()) throw bad("empty output");
  if (out.depth() != CV_32F || out.channels() != 1) throw bad("not a single-channel float blob");
  if (out.dims == 2) return out.isContinuous() ? out : out.clone();
  if (out.dims == 3 && out.size[0] == 1) {
    cv::Mat m = out.isContinuous() ? out : out.clone();
    return cv::Mat(m.size[1], m.size[2], CV_32F, m.ptr<float>());
  }
  throw bad("");
}

}  // namespace

void decodeYoloRegion(const cv::Mat& out, const std::string& layer, int num_classes, float conf, cv::Size image_size,
                      bool multiply_objectness, std::vector<RawBox>& boxes) {
  const std::string expected =
      num_classes > 0 ? "[N x " + std::to_string(5 + num_classes) + "]: cx, cy, w, h, objectness, " +
                            std::to_string(num_classes) + " class scores"
                      : "[N x (5 + classes)]";
  cv::Mat m = rows2d(out, layer, expected);
  if (m.cols < 6 || (num_classes > 0 && m.cols != 5 + num_classes))
    throw DataError("output layer '" + layer + "' has unexpected shape " + shapeString(out) + " (expected " + expected +
                    "; wrong class-names file or not a YOLO model?)");
  const int nc = m.cols - 5;
  for (int r = 0; r < m.rows; r++) {
    const float* p = m.ptr<float>(r);
    const float* cls = p + 5;
    const int best = int(std::max_element(cls, cls + nc) - cls);
    const float score = multiply_objectness ? p[4] * cls[best] : cls[best];
    if (!(score >= conf) || score <= 0.f) continue;
    const float cx = p[0] * image_size.width, cy = p[1] * image_size.height;
    const float w = p[2] * image_size.width, h = p[3] * image_size.height;
    boxes.push_back({cv::Rect2f(cx - 0.5f * w, cy - 0.5f * h, w, h), best, score});
  }
}

cv::Mat letterbox(const cv::Mat& img, cv::Size input, double pad, float& ratio) {
  ratio = std::min(float(input.width) / float(img.cols), float(input.height) / float(img.rows));
  const cv::Size rs(std::max(1, int(img.cols * ratio)), std::max(1, int(img.rows * ratio)));
  cv::Mat out(input, img.type(), cv::Scalar::all(pad));
  cv::Mat resized;
  cv::resize(img, resized, rs, 0, 0, cv::INTER_LINEAR);
  resized.copyTo(out(cv::Rect(0, 0, std::min(rs.width, input.width), std::min(rs.height, input.height))));
  return out;
}

int yoloxAnchorCount(cv::Size input, const std::vector<int>& strides) {
  int n = 0;
  for (int s : strides) n += (input.width / s) * (input.height / s);
  return n;
}

void decodeYolox(const cv::Mat& out, const std::string& layer, cv::Size input, const std::vector<int>& strides,
                 float ratio, int num_classes, float conf, std::vector<RawBox>& boxes) {
  const int n = yoloxAnchorCount(input, strides);
  const std::string expected = "[1 x " + std::to_string(n) + " x " +
                               (num_classes > 0 ? std::to_string(5 + num_classes) : std::string("(5 + classes)")) +
                               "] for a " + std::to_string(input.width) + "x" + std::to_string(input.height) +
                               " input at strides 8/16/32";
  cv::Mat m = rows2d(out, layer, expected);
  if (m.rows != n || m.cols < 6 || (num_classes > 0 && m.cols != 5 + num_classes))
    throw DataError("output layer '" + layer + "' has unexpected shape " + shapeString(out) + " (expected " + expected +
                    "; wrong input_size or not a YOLOX model?)");
  const int nc = m.cols - 5;
  const float inv = ratio > 0 ? 1.f / ratio : 1.f;
  int r = 0;
  for (int s : strides) {
    const int gw = input.width / s, gh = input.height / s;
    for (int gy = 0; gy < gh; gy++)
      for (int gx = 0; gx < gw; gx++, r++) {
        const float* p = m.ptr<float>(r);
        const float* cls = p + 5;
        const int best = int(std::max_element(cls, cls + nc) - cls);
        const float score = p[4] * cls[best];
        if (!(score >= conf) || score <= 0.f) continue;
        const float cx = (p[0] + float(gx)) * float(s), cy = (p[1] + float(gy)) * float(s);
        const float w = std::exp(p[2]) * float(s), h = std::exp(p[3]) * float(s);
        boxes.push_back({cv::Rect2f((cx - 0.5f * w) * inv, (cy - 0.5f * h) * inv, w * inv, h * inv), best, score});
      }
  }
}

std::vector<RawBox> nms(const std::vector<RawBox>& boxes, float score_threshold, float nms_threshold, bool per_class) {
  std::vector<RawBox> kept;
  auto run = [&](const std::vector<size_t>& idx) {
    std::vector<cv::Rect2d> rects;
    std::vector<float> scores;
    for (size_t i : idx) {
      rects.emplace_back(boxes[i].box.x, boxes[i].box.y, boxes[i].box.width, boxes[i].box.height);
      scores.push_back(boxes[i].score);
    }
    std::vector<int> keep;
    cv::dnn::NMSBoxes(rects, scores, score_threshold, nms_threshold, keep);
    for (int k : keep) kept.push_back(boxes[idx[size_t(k)]]);
  };
  if (per_class) {
    std::map<int, std::vector<size_t>> by;
    for (size_t i = 0; i < boxes.size(); i++) by[boxes[i].class_index].push_back(i);
    for (const auto& [c, idx] : by) run(idx);
  } else {
    std::vector<size_t> idx(boxes.size());
    std::iota(idx.begin(), idx.end(), size_t(0));
    run(idx);
  }
  std::stable_sort(kept.begin(), kept.end(), [](const RawBox& a, const RawBox& b) { return a.score > b.score; });
  return kept;
}

cv::Rect2f clipBox(const cv::Rect2f& b, cv::Size image) {
  return b & cv::Rect2f(0.f, 0.f, float(image.width), float(image.height));
}

}  // namespace dslam::det
