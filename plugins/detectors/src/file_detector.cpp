#include "dslam/plugins/detectors/file_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "common.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"

IMPLEMENTS_MRPT_OBJECT(FileDetector, Detector, dslam)

namespace fs = std::filesystem;

namespace dslam {

namespace {

std::string join(const std::string& a, const std::string& b) { return (fs::path(a) / b).lexically_normal().string(); }

/** Checks a printf pattern with exactly one integer conversion. */
void checkIndexFormat(const std::string& f) {
  int convs = 0;
  for (size_t i = 0; i < f.size(); i++) {
    if (f[i] != '%') continue;
    if (i + 1 < f.size() && f[i + 1] == '%') {
      i++;
      continue;
    }
    size_t j = i + 1;
    while (j < f.size() && (std::isdigit(static_cast<unsigned char>(f[j])) || f[j] == '-' || f[j] == '+' || f[j] == ' '))
      j++;
    if (j >= f.size() || (f[j] != 'd' && f[j] != 'i'))
      throw ConfigError("index_format '" + f + "': only one %d conversion (e.g. %06d) is allowed");
    convs++;
    i = j;
  }
  if (convs != 1) throw ConfigError("index_format '" + f + "': needs exactly one %d conversion (e.g. %06d)");
}

}  // namespace

// ---------------------------------------------------------------- LabelSource

void LabelSource::open(const Options& o) {
  o_ = o;
  if (o_.root.empty()) throw ConfigError("label folder is empty (no 'dir'/'root' given and no dataset root)");
  requireDir(o_.root, "label folder", "expected boxes/, semantic/ and/or panoptic/ inside, see docs/detectors.md");
  if (o_.naming != "stem" && o_.naming != "index") throw ConfigError("naming must be stem or index, got " + o_.naming);
  if (o_.naming == "index") checkIndexFormat(o_.index_format);
  auto sub = [&](const std::string& d, bool required, const char* what) -> std::string {
    if (d.empty()) return "";
    const std::string p = resolvePath(d, o_.root);
    if (dirExists(p)) return p;
    if (required) throw DataError(std::string(what) + " folder not found: " + p);
    return "";
  };
  boxes_ = sub(o_.boxes_dir, o_.require_boxes, "box JSON");
  semantic_ = sub(o_.semantic_dir, o_.require_semantic, "semantic label");
  panoptic_ = sub(o_.panoptic_dir, o_.require_panoptic, "panoptic PNG");
  if (boxes_.empty() && semantic_.empty() && panoptic_.empty())
    throw DataError("no label folder in " + o_.root + " (expected " +
                    (o_.boxes_dir.empty() ? std::string() : o_.boxes_dir + "/ ") +
                    (o_.semantic_dir.empty() ? std::string() : o_.semantic_dir + "/ ") +
                    (o_.panoptic_dir.empty() ? std::string() : o_.panoptic_dir + "/ ") +
                    "with per-frame files, see docs/detectors.md)");
  pjson_.reset();
  if (!panoptic_.empty()) {
    std::string jf;
    if (!o_.panoptic_json.empty()) {
      jf = resolvePath(o_.panoptic_json, o_.root);
      requireFile(jf, "panoptic JSON", "COCO panoptic annotations, see docs/detectors.md");
    } else if (fileExists(join(o_.root, "panoptic.json"))) {
      jf = join(o_.root, "panoptic.json");
    } else if (fileExists(join(panoptic_, "panoptic.json"))) {
      jf = join(panoptic_, "panoptic.json");
    }
    if (!jf.empty()) pjson_ = std::make_shared<labels::PanopticJson>(labels::readPanopticJson(jf));
  }
}

unsigned LabelSource::outputs() const {
  unsigned f = 0;
  if (!boxes_.empty()) f |= kBoxes;
  if (!semantic_.empty() || (!panoptic_.empty() && o_.semantic_from_panoptic)) f |= kSemantic;
  if (!panoptic_.empty()) f |= kPanoptic;
  return f;
}

std::string LabelSource::key(const SensorFrame& frame) const {
  if (o_.naming == "index") {
    char buf[128];
    std::snprintf(buf, sizeof buf, o_.index_format.c_str(), frame.index + o_.index_offset);
    return buf;
  }
  if (!frame.image_path.empty()) return fs::path(frame.image_path).stem().string();
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", frame.timestamp);
  return buf;
}

std::vector<std::string> LabelSource::keys() const {
  std::string dir = boxes_;
  std::string ext = ".json";
  if (dir.empty()) {
    dir = !panoptic_.empty() ? panoptic_ : semantic_;
    ext = ".png";
  }
  std::vector<std::string> k;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ext && e.path().filename() != "panoptic.json")
      k.push_back(e.path().stem().string());
  bool numeric = true;
  for (const auto& s : k) numeric &= yamlu::parseDouble(s).has_value();
  if (numeric)
    std::sort(k.begin(), k.end(), [](const std::string& a, const std::string& b) {
      return *yamlu::parseDouble(a) < *yamlu::parseDouble(b);
    });
  else
    std::sort(k.begin(), k.end());
  return k;
}

std::vector<std::string> LabelSource::read(const std::string& key, Detections& out, cv::Size image_size) const {
  std::vector<std::string> missing;
  auto checkSize = [&](const std::string& file, cv::Size s) {
    if (image_size.area() > 0 && s.area() > 0 && s != image_size)
      throw DataError(file + ": label size " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                      " differs from the frame's " + std::to_string(image_size.width) + "x" +
                      std::to_string(image_size.height));
  };
  if (!boxes_.empty()) {
    const std::string f = join(boxes_, key + ".json");
    if (fileExists(f)) {
      cv::Size s;
      out.boxes = labels::readBoxJson(f, o_.box_index80, &s);
      checkSize(f, s);
    } else {
      missing.push_back(f);
    }
  }
  if (!panoptic_.empty()) {
    const std::string f = join(panoptic_, key + ".png");
    if (fileExists(f)) {
      cv::Mat ids = labels::readPanopticPng(f);
      checkSize(f, ids.size());
      const labels::PanopticAnnotation* ann = nullptr;
      std::shared_ptr<labels::PanopticJson> per_frame;
      if (pjson_) {
        ann = pjson_->find(key + ".png");
        if (!ann) ann = pjson_->find(key);
        if (!ann)
          throw DataError(pjson_->file + ": no annotation with file_name '" + key + ".png' (for " + f + ")");
        labels::fillPanoptic(ids, ann, *pjson_, out);
      } else {
        const std::string jf = join(panoptic_, key + ".json");
        if (!fileExists(jf))
          throw DataError("no COCO panoptic JSON for " + f + ": expected " + join(o_.root, "panoptic.json") + ", " +
                          join(panoptic_, "panoptic.json") + " or " + jf);
        per_frame = std::make_shared<labels::PanopticJson>(labels::readPanopticJson(jf));
        if (per_frame->annotations.empty()) throw DataError(jf + ": no annotation");
        labels::fillPanoptic(ids, &per_frame->annotations.front(), *per_frame, out);
      }
    } else {
      missing.push_back(f);
    }
  }
  if (!semantic_.empty()) {
    const std::string f = join(semantic_, key + ".png");
    if (fileExists(f)) {
      out.semantic = labels::readSemanticPng(f);
      checkSize(f, out.semantic.size());
      if (!o_.semantic_map.empty()) {
        cv::Mat lut(1, 256, CV_8U);
        for (int v = 0; v < 256; v++) {
          auto it = o_.semantic_map.find(v);
          lut.at<uint8_t>(v) = uint8_t(it == o_.semantic_map.end() ? v : it->second);
        }
        cv::LUT(out.semantic, lut, out.semantic);
      }
    } else {
      missing.push_back(f);
    }
  } else if (!out.panoptic.empty() && o_.semantic_from_panoptic) {
    out.semantic = labels::semanticFromPanoptic(out);
  }
  return missing;
}

std::vector<ParamSpec> labelSourceParamSpecs(const std::string& root_doc) {
  return {
      P_path("dir", "", root_doc),
      P_string("boxes_dir", "boxes", "box JSON folder relative to dir ('' = no boxes)"),
      P_string("semantic_dir", "semantic", "semantic label PNG folder relative to dir ('' = none)"),
      P_string("panoptic_dir", "panoptic", "COCO panoptic PNG folder relative to dir ('' = none)"),
      P_string("panoptic_json", "",
               "COCO panoptic JSON relative to dir ('' = dir/panoptic.json, <panoptic_dir>/panoptic.json or per-frame "
               "<panoptic_dir>/<key>.json)"),
      P_enum("naming", "stem", {"stem", "index"}, "file key of a frame: stem of its image file, or its index"),
      P_string("index_format", "'%06d'", "printf pattern of the key for naming: index"),
      P_int("index_offset", 0, "added to the frame index for naming: index"),
      P_enum("on_missing", "skip", {"skip", "fail"},
             "frame without label file: skip = no detections (valid, logged every 100), fail = DataError"),
      P_bool("semantic_from_panoptic", true, "derive the semantic image from panoptic when there is no semantic folder"),
  };
}

LabelSource::Options labelSourceOptions(const Params& p, const PluginContext& ctx, const std::string& who) {
  std::string root = p.getString("dir");
  if (root.empty()) root = ctx.dataset_root;
  if (root.empty())
    p.fail("dir", "empty, and " + who + " has no dataset folder to read labels from");
  LabelSource::Options o;
  o.root = root;
  o.boxes_dir = p.getString("boxes_dir");
  o.semantic_dir = p.getString("semantic_dir");
  o.panoptic_dir = p.getString("panoptic_dir");
  o.require_boxes = p.isGiven("boxes_dir");
  o.require_semantic = p.isGiven("semantic_dir");
  o.require_panoptic = p.isGiven("panoptic_dir");
  o.panoptic_json = p.getString("panoptic_json");
  o.naming = p.getString("naming");
  o.index_format = p.getString("index_format");
  o.index_offset = int(p.getInt("index_offset"));
  o.semantic_from_panoptic = p.getBool("semantic_from_panoptic");
  return o;
}

// ---------------------------------------------------------------- FileDetector

std::string FileDetector::description() const {
  return "precomputed detections from files: box JSON, semantic label PNG, COCO panoptic PNG + JSON (any network)";
}

std::vector<ParamSpec> FileDetector::paramSpecs() const {
  auto v = labelSourceParamSpecs("folder holding boxes/, semantic/, panoptic/ ('' = the dataset folder)");
  v.push_back(P_enum("box_ids", "coco", {"coco", "index80"},
                     "box category_id: official COCO ids, or YOLO 0..79 indices"));
  v.push_back(P_map("semantic_map", "{}", "semantic PNG raw value -> COCO id (values not listed are kept)"));
  v.push_back(P_double("min_score", 0, "drop boxes scoring below this", 0, 1));
  v.push_back(P_list("classes", ParamType::IntList, "[]", "COCO ids of boxes to keep (empty = all)"));
  return v;
}

void FileDetector::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  auto o = labelSourceOptions(p, ctx, "FileDetector");
  o.box_index80 = p.getString("box_ids") == "index80";
  for (const auto& [k, v] : p.getDoubleMap("semantic_map")) {
    auto kv = yamlu::parseInt(k);
    if (!kv || *kv < 0 || *kv > 255 || v < 0 || v > 255 || v != std::floor(v))
      throw ConfigError("FileDetector: semantic_map entry '" + k + "': expected 0..255 -> 0..255");
    o.semantic_map[int(*kv)] = int(v);
  }
  src_.open(o);
  fail_on_missing_ = p.getString("on_missing") == "fail";
  min_score_ = float(p.getDouble("min_score"));
  keep_ = det::classFilter(p);
  missing_ = 0;
}

Detections FileDetector::detect(const SensorFrame& frame) {
  Detections d = det::emptyDetections(frame);
  const std::string key = src_.key(frame);
  const auto missing = src_.read(key, d, frame.image.size());
  if (!missing.empty()) {
    if (fail_on_missing_)
      throw DataError("frame " + std::to_string(frame.index) + ": label file missing: " + missing.front() +
                      " (FileDetector on_missing: fail)");
    if (missing_ % 100 == 0)
      DSLAM_LOG(Warn, "FileDetector: frame " << frame.index << ": label file missing: " << missing.front()
                                             << " (no detections; " << missing_ + 1 << " frame(s) so far)");
    missing_++;
  }
  d.boxes.erase(std::remove_if(d.boxes.begin(), d.boxes.end(),
                               [&](const BoundingBox& b) {
                                 return b.score < min_score_ ||
                                        (!keep_.empty() && !std::binary_search(keep_.begin(), keep_.end(), b.class_id));
                               }),
                d.boxes.end());
  return d;
}

}  // namespace dslam
