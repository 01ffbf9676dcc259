// Box JSON and semantic PNG (docs/detectors.md), the shared JSON helpers of
// the label files, and the JSON of `dslam detect --json`. JSON through
// nlohmann::json; COCO panoptic files are in panoptic_io.cpp.
#include "dslam/plugins/detectors/label_io.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "dslam/core/atomic_file.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/json_layout.h"
#include "dslam/core/paths.h"
#include "dslam/core/png.h"
#include "label_json.h"

namespace fs = std::filesystem;

namespace dslam::labels {

namespace detail {


std::string describe(const json& v) {
  std::string t = v.dump();
  if (t.size() > 60) t = t.substr(0, 60) + "...";
  return t;
}

double number(const At& at, const json& v) {
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    throw DataError(at.str() + ": must be a number, got " + describe(v));
  return v.get<double>();
}

int integer(const At& at, const json& v) {
  const double d = number(at, v);
  if (d != std::floor(d) || std::abs(d) > 2147483647.0)
    throw DataError(at.str() + ": must be an integer, got " + describe(v));
  return static_cast<int>(d);
}

std::vector<double> numberList(const At& at, const json& v, size_t len) {
  if (!v.is_array() || v.size() != len)
    throw DataError(at.str() + ": must be a list of " + std::to_string(len) + " numbers, got " + describe(v));
  std::vector<double> out;
  for (size_t i = 0; i < len; i++) out.push_back(number(at.index(i), v[i]));
  return out;
}

const json& need(const At& at, const json& obj, const char* key, const char* what) {
  auto it = obj.find(key);
  if (it == obj.end()) throw DataError(at.str() + ": " + what + " lacks '" + key + "'");
  return *it;
}

const json* optional(const json& obj, const char* key) {
  auto it = obj.find(key);
  return it == obj.end() || it->is_null() ? nullptr : &*it;
}

bool truthy(const At& at, const json& v) {
  if (v.is_boolean()) return v.get<bool>();
  return number(at, v) != 0;
}

void writeText(const std::string& file, const std::string& text) {
  const fs::path p(file);
  if (p.has_parent_path()) fs::create_directories(p.parent_path());
  writeTextFile(file, text);
}

void writePng(const std::string& file, const cv::Mat& m) {
  const fs::path p(file);
  if (p.has_parent_path()) fs::create_directories(p.parent_path());
  writeImageFile(file, m);
}

/** Label images are PNG (docs/detectors.md). The header is checked before
 *  OpenCV sees the file: cv::imread decodes any format it knows by its
 *  content and allocates whatever size the header announces (up to 2^30
 *  pixels), so a 20-byte PPM header named .png would cost gigabytes. */
void checkPngHeader(const std::string& file, const std::string& what) {
  constexpr uint64_t kMaxPixels = uint64_t(1) << 26;  // 64 Mpx, e.g. 8192 x 8192
  static const unsigned char kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  unsigned char h[24] = {};
  std::ifstream f(file, std::ios::binary);
  f.read(reinterpret_cast<char*>(h), sizeof h);
  if (f.gcount() < static_cast<std::streamsize>(sizeof h) || std::memcmp(h, kSig, 8) != 0 ||
      std::memcmp(h + 12, "IHDR", 4) != 0)
    throw DataError(file + ": " + what + " is not a PNG file (label images are PNG, see docs/detectors.md)");
  auto be32 = [](const unsigned char* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
  };
  const uint32_t w = be32(h + 16), hh = be32(h + 20);
  if (w == 0 || hh == 0 || uint64_t(w) * hh > kMaxPixels)
    throw DataError(file + ": " + what + " of " + std::to_string(w) + "x" + std::to_string(hh) +
                    " pixels (PNG header): not in 1.." + std::to_string(kMaxPixels) + " pixels");
}

cv::Mat readImage(const std::string& file, int flags, const std::string& what) {
  if (!fileExists(file)) throw DataError(what + " not found: " + file);
  checkPngHeader(file, what);
  std::string damage;
  cv::Mat m = readImageFile(file, flags, &damage);
  if (m.empty())
    throw DataError("cannot read " + what + " " + file +
                    " (" + unreadableImageReason(damage) + ")");
  return m;
}

nlohmann::ordered_json boxObject(const BoundingBox& b) {
  nlohmann::ordered_json j = {
      {"category_id", b.class_id}, {"bbox", {b.box.x, b.box.y, b.box.width, b.box.height}}, {"score", b.score}};
  if (b.instance_id >= 0) j["instance_id"] = b.instance_id;
  return j;
}

nlohmann::ordered_json segmentObject(const PanopticSegment& s, bool with_kind) {
  nlohmann::ordered_json j = {{"id", s.id},
                              {"category_id", s.category_id},
                              {"iscrowd", 0},
                              {"bbox", {s.bbox.x, s.bbox.y, s.bbox.width, s.bbox.height}},
                              {"area", s.area}};
  if (s.instance_id >= 0) j["instance_id"] = s.instance_id;
  if (s.score != 1.f) j["score"] = s.score;
  if (with_kind) j["kind"] = toString(s.kind);
  return j;
}

}  // namespace detail

using namespace detail;

// ---------------------------------------------------------------- box JSON

std::vector<BoundingBox> readBoxJson(const std::string& file, bool index80, cv::Size* size) {
  const json root = parseJsonFile(file);
  const At top{file, ""};
  const json* list = nullptr;
  At at = top;
  if (size) *size = {};
  if (root.is_array()) {
    list = &root;
  } else if (root.is_object()) {
    list = optional(root, "boxes");
    at = top.key("boxes");
    if (!list && !root.contains("boxes"))
      throw DataError(file + ": expected a JSON object with a \"boxes\" list (see docs/detectors.md, box JSON)");
    const json* w = optional(root, "width");
    const json* h = optional(root, "height");
    if (size && w && h) *size = cv::Size(integer(top.key("width"), *w), integer(top.key("height"), *h));
  } else {
    throw DataError(file + ": expected a JSON object {\"boxes\": [...]}, got " + describe(root));
  }
  std::vector<BoundingBox> out;
  if (!list) return out;  // "boxes": null
  if (!list->is_array()) throw DataError(at.str() + ": must be a list, got " + describe(*list));
  for (size_t i = 0; i < list->size(); i++) {
    const json& e = (*list)[i];
    const At ai = at.index(i);
    if (!e.is_object()) throw DataError(ai.str() + ": a box must be an object, got " + describe(e));
    BoundingBox b;
    b.class_id = integer(ai.key("category_id"), need(ai, e, "category_id", "box"));
    if (index80) {
      const int id = coco::cocoIdFromIndex80(b.class_id);
      if (id < 0)
        throw DataError(ai.key("category_id").str() + ": " + std::to_string(b.class_id) + " is not a 0..79 index");
      b.class_id = id;
    }
    const auto bb = numberList(ai.key("bbox"), need(ai, e, "bbox", "box"), 4);
    if (bb[2] < 0 || bb[3] < 0) throw DataError(ai.key("bbox").str() + ": width/height must be >= 0 ([x, y, w, h])");
    b.box = cv::Rect2f(float(bb[0]), float(bb[1]), float(bb[2]), float(bb[3]));
    const json* s = optional(e, "score");
    b.score = s ? float(number(ai.key("score"), *s)) : 1.f;
    if (const json* id = optional(e, "instance_id")) b.instance_id = integer(ai.key("instance_id"), *id);
    out.push_back(b);
  }
  return out;
}

std::string boxJsonText(const std::vector<BoundingBox>& boxes, cv::Size size, const std::string& image) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  if (!image.empty()) j["image"] = image;
  if (size.area() > 0) {
    j["width"] = size.width;
    j["height"] = size.height;
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const auto& b : boxes) list.push_back(boxObject(b));
  j["boxes"] = std::move(list);
  return layoutJson(j, 2);
}

void writeBoxJson(const std::string& file, const std::vector<BoundingBox>& boxes, cv::Size size,
                  const std::string& image) {
  writeText(file, boxJsonText(boxes, size, image));
}

// ------------------------------------------------------- semantic label PNG

cv::Mat readSemanticPng(const std::string& file) {
  cv::Mat m = readImage(file, cv::IMREAD_UNCHANGED, "semantic label image");
  if (m.channels() != 1)
    throw DataError(file + ": semantic label image must be single-channel (COCO id per pixel), has " +
                    std::to_string(m.channels()) + " channels");
  if (m.depth() == CV_8U) return m;
  if (m.depth() == CV_16U) {
    double mx = 0;
    cv::minMaxLoc(m, nullptr, &mx);
    if (mx > 255) throw DataError(file + ": semantic label value " + std::to_string(int(mx)) + " > 255");
    cv::Mat o;
    m.convertTo(o, CV_8U);
    return o;
  }
  throw DataError(file + ": semantic label image must be 8-bit (or 16-bit) PNG");
}

void writeSemanticPng(const std::string& file, const cv::Mat& labels) {
  if (labels.type() != CV_8UC1) throw Error("writeSemanticPng: labels must be CV_8UC1 (" + file + ")");
  writePng(file, labels);
}

// ------------------------------------------------------ dslam detect --json

std::string detectionsJsonText(const Detections& d) {
  nlohmann::ordered_json j = {{"frame_index", d.frame_index}, {"timestamp", d.timestamp}, {"valid", d.valid}};
  nlohmann::ordered_json boxes = nlohmann::ordered_json::array();
  for (const auto& b : d.boxes) {
    nlohmann::ordered_json o = boxObject(b);
    o["name"] = coco::name(b.class_id);
    boxes.push_back(std::move(o));
  }
  j["boxes"] = std::move(boxes);
  if (!d.semantic.empty()) {
    std::map<int, int> hist;  // pixel count per class
    for (int r = 0; r < d.semantic.rows; r++) {
      const uint8_t* p = d.semantic.ptr<uint8_t>(r);
      for (int c = 0; c < d.semantic.cols; c++) hist[p[c]]++;
    }
    nlohmann::ordered_json px = nlohmann::ordered_json::object();
    for (const auto& [k, v] : hist) px[k == coco::kNone ? "none" : coco::name(k)] = v;
    j["semantic"] = {{"width", d.semantic.cols}, {"height", d.semantic.rows}, {"pixels", std::move(px)}};
  }
  if (!d.panoptic.empty()) {
    nlohmann::ordered_json segs = nlohmann::ordered_json::array();
    for (const auto& s : d.segments) segs.push_back(segmentObject(s, true));
    j["segments"] = std::move(segs);
  }
  return j.dump();
}

}  // namespace dslam::labels
