#include "common.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"

namespace dslam::det {

const char* kModelHint =
    "put the models in the shared folder (DSLAM_SHARED_DIR, default ../shared beside the checkout: "
    "../shared/models) or fetch them with scripts/download_models.sh <dir> and point the parameter there";

std::string modelFile(const std::string& value, const std::string& default_rel, const std::string& what) {
  const std::string f = value.empty() ? (std::filesystem::path(sharedDir()) / default_rel).lexically_normal().string()
                                      : value;
  requireFile(f, what, kModelHint);
  return f;
}

cv::dnn::Net loadNet(const std::string& what, const std::string& model, const std::string& config,
                     const std::string& framework) {
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNet(model, config, framework);
  } catch (const cv::Exception& e) {
    throw DataError("cannot load " + what + " from " + model + (config.empty() ? "" : " + " + config) + ": " + e.what());
  }
  if (net.empty()) throw DataError("cannot load " + what + " from " + model + (config.empty() ? "" : " + " + config));
  return net;
}

cv::Mat toBgr8(const SensorFrame& f) {
  if (f.image.empty()) throw DataError("frame " + std::to_string(f.index) + ": empty image given to a detector");
  if (f.image.depth() != CV_8U)
    throw DataError("frame " + std::to_string(f.index) + ": detectors need an 8-bit image (" +
                    (f.image_path.empty() ? std::string("in memory") : f.image_path) + ")");
  cv::Mat out;
  switch (f.image.channels()) {
    case 1: cv::cvtColor(f.image, out, cv::COLOR_GRAY2BGR); return out;
    case 3: return f.image;
    case 4: cv::cvtColor(f.image, out, cv::COLOR_BGRA2BGR); return out;
    default:
      throw DataError("frame " + std::to_string(f.index) + ": unsupported image with " +
                      std::to_string(f.image.channels()) + " channels");
  }
}

std::vector<std::string> readNames(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw DataError("class-names file not found: " + file + " (" + kModelHint + ")");
  std::vector<std::string> v;
  std::string s;
  while (std::getline(in, s)) {
    while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.pop_back();
    size_t b = s.find_first_not_of(" \t");
    if (b == std::string::npos) continue;
    v.push_back(s.substr(b));
  }
  if (v.empty()) throw DataError("class-names file " + file + " is empty");
  return v;
}

namespace {
int cocoIdForName(std::string n) {
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  static const std::pair<const char*, int> aliases[] = {
      {"body", 1},         {"people", 1},       {"pedestrian", 1},   {"human", 1},        {"rider", 1},
      {"motorbike", 4},    {"aeroplane", 5},    {"sofa", 63},        {"pottedplant", 64}, {"diningtable", 67},
      {"tvmonitor", 72},   {"bike", 2},         {"tv monitor", 72},  {"potted plant", 64}, {"dining table", 67},
  };
  for (const auto& [a, id] : aliases)
    if (n == a) return id;
  return coco::idFromName(n);
}
}  // namespace

std::vector<int> cocoIdsForNames(const std::vector<std::string>& names, const std::vector<int>& override_ids,
                                 const std::string& names_file) {
  if (!override_ids.empty()) {
    if (!names.empty() && override_ids.size() != names.size())
      throw ConfigError("class_ids has " + std::to_string(override_ids.size()) + " entries but " + names_file +
                        " lists " + std::to_string(names.size()) + " classes");
    for (int id : override_ids)
      if (!coco::find(id)) throw ConfigError("class_ids: " + std::to_string(id) + " is not a COCO category id");
    return override_ids;
  }
  std::vector<int> ids;
  if (names.size() == 80) {
    for (int i = 0; i < 80; i++) ids.push_back(coco::cocoIdFromIndex80(i));
    return ids;
  }
  for (size_t i = 0; i < names.size(); i++) {
    const int id = cocoIdForName(names[i]);
    if (id < 0)
      throw ConfigError(names_file + ":" + std::to_string(i + 1) + ": class '" + names[i] +
                        "' is not a COCO category name; give the COCO id of every model class in 'class_ids'");
    ids.push_back(id);
  }
  return ids;
}

std::vector<int> classFilter(const Params& p, const std::string& key) {
  std::vector<int> v = p.getIntList(key);
  for (int id : v)
    if (!coco::find(id))
      p.fail(key, std::to_string(id) + " is not a COCO category id (person = 1, see dslam/core/coco.h)");
  std::sort(v.begin(), v.end());
  return v;
}

void filterRaw(std::vector<RawBox>& raw, const std::vector<int>& coco_ids, const std::vector<int>& keep) {
  if (keep.empty()) return;
  raw.erase(std::remove_if(raw.begin(), raw.end(),
                           [&](const RawBox& b) {
                             const int id = b.class_index >= 0 && size_t(b.class_index) < coco_ids.size()
                                                ? coco_ids[size_t(b.class_index)]
                                                : -1;
                             return !std::binary_search(keep.begin(), keep.end(), id);
                           }),
            raw.end());
}

std::vector<BoundingBox> toBoxes(const std::vector<RawBox>& raw, const std::vector<int>& coco_ids,
                                 const std::vector<int>& keep, cv::Size image) {
  std::vector<BoundingBox> out;
  for (const auto& r : raw) {
    if (r.class_index < 0 || size_t(r.class_index) >= coco_ids.size()) continue;
    const int id = coco_ids[size_t(r.class_index)];
    if (!keep.empty() && !std::binary_search(keep.begin(), keep.end(), id)) continue;
    BoundingBox b;
    b.box = clipBox(r.box, image);
    if (b.box.width <= 0 || b.box.height <= 0) continue;
    b.class_id = id;
    b.score = r.score;
    out.push_back(b);
  }
  return out;
}

Detections emptyDetections(const SensorFrame& f) {
  Detections d;
  d.frame_index = f.index;
  d.timestamp = f.timestamp;
  return d;
}

std::vector<cv::Mat> forward(cv::dnn::Net& net, const std::vector<std::string>& names, const std::string& what,
                             int frame_index) {
  std::vector<cv::Mat> outs;
  try {
    net.forward(outs, names);
  } catch (const cv::Exception& e) {
    throw DataError("frame " + std::to_string(frame_index) + ": " + what + " inference failed: " + e.what());
  }
  return outs;
}

}  // namespace dslam::det
