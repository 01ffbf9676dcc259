// Box JSON, semantic PNG and COCO panoptic PNG + JSON (docs/detectors.md).
// JSON is parsed with MRPT's YAML parser (JSON is valid YAML 1.2 flow
// syntax; it handles null, escapes and gives line numbers).
#include "dslam/plugins/detectors/label_io.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"

namespace fs = std::filesystem;
using node_t = mrpt::containers::yaml::node_t;

namespace dslam::labels {

namespace {

std::string readText(const std::string& file) {
  std::ifstream f(file, std::ios::binary);
  if (!f) throw DataError("cannot open " + file + (fileExists(file) ? " (permission?)" : " (missing)"));
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

mrpt::containers::yaml parseJson(const std::string& file) {
  const std::string text = readText(file);
  try {
    return mrpt::containers::yaml::FromText(text);
  } catch (const std::exception& e) {
    throw DataError(file + ": invalid JSON: " + e.what());
  }
}

/** "file:line" of a node. */
std::string at(const std::string& file, const node_t& n) {
  return file + ":" + std::to_string(n.marks.line + 1);
}

double number(const std::string& file, const node_t& n, const std::string& key) {
  auto t = yamlu::scalarText(n);
  auto v = t ? yamlu::parseDouble(*t) : std::nullopt;
  if (!v || !std::isfinite(*v))
    throw DataError(at(file, n) + ": '" + key + "' must be a number, got " + yamlu::describe(n));
  return *v;
}

int integer(const std::string& file, const node_t& n, const std::string& key) {
  const double v = number(file, n, key);
  if (v != std::floor(v) || std::abs(v) > 2147483647.0)
    throw DataError(at(file, n) + ": '" + key + "' must be an integer, got " + yamlu::describe(n));
  return static_cast<int>(v);
}

const node_t& need(const std::string& file, const node_t& m, const std::string& key, const std::string& what) {
  const node_t* v = yamlu::findValue(m, key);
  if (!v) throw DataError(at(file, m) + ": " + what + " lacks '" + key + "'");
  return *v;
}

std::vector<double> numberList(const std::string& file, const node_t& n, const std::string& key, size_t len) {
  if (!n.isSequence() || n.asSequence().size() != len)
    throw DataError(at(file, n) + ": '" + key + "' must be a list of " + std::to_string(len) + " numbers, got " +
                    yamlu::describe(n));
  std::vector<double> v;
  for (const auto& e : n.asSequence()) v.push_back(number(file, e, key));
  return v;
}

std::string str(const node_t& n) { return yamlu::scalarText(n).value_or(""); }

bool truthy(const std::string& file, const node_t& n, const std::string& key) {
  const std::string t = str(n);
  if (auto b = yamlu::parseBool(t)) return *b;
  return number(file, n, key) != 0;
}

std::string jsonEscape(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\t': o += "\\t"; break;
      case '\r': o += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char b[8];
          std::snprintf(b, sizeof b, "\\u%04x", c);
          o += b;
        } else {
          o += c;
        }
    }
  }
  return o + "\"";
}

std::string num(double v) {
  if (v == std::floor(v) && std::abs(v) < 1e15) return std::to_string(static_cast<long long>(v));
  std::ostringstream o;
  o.precision(9);
  o << v;
  return o.str();
}

void writeText(const std::string& file, const std::string& text) {
  const fs::path p(file);
  if (p.has_parent_path()) fs::create_directories(p.parent_path());
  std::ofstream f(file, std::ios::binary);
  if (!f) throw DataError("cannot write " + file);
  f << text;
  if (!f) throw DataError("error writing " + file);
}

void writePng(const std::string& file, const cv::Mat& m) {
  const fs::path p(file);
  if (p.has_parent_path()) fs::create_directories(p.parent_path());
  bool ok = false;
  try {
    ok = cv::imwrite(file, m);
  } catch (const cv::Exception& e) {
    throw DataError("cannot write " + file + ": " + e.what());
  }
  if (!ok) throw DataError("cannot write " + file);
}

cv::Mat readImage(const std::string& file, int flags, const std::string& what) {
  if (!fileExists(file)) throw DataError(what + " not found: " + file);
  cv::Mat m = cv::imread(file, flags);
  if (m.empty()) throw DataError("cannot read " + what + " " + file + " (corrupt or unsupported)");
  return m;
}

std::string boxObject(const BoundingBox& b) {
  std::string s = "{\"category_id\": " + std::to_string(b.class_id) + ", \"bbox\": [" + num(b.box.x) + ", " +
                  num(b.box.y) + ", " + num(b.box.width) + ", " + num(b.box.height) + "], \"score\": " + num(b.score);
  if (b.instance_id >= 0) s += ", \"instance_id\": " + std::to_string(b.instance_id);
  return s + "}";
}

std::string segmentObject(const PanopticSegment& s, bool with_kind) {
  std::string o = "{\"id\": " + std::to_string(s.id) + ", \"category_id\": " + std::to_string(s.category_id) +
                  ", \"iscrowd\": 0, \"bbox\": [" + std::to_string(s.bbox.x) + ", " + std::to_string(s.bbox.y) +
                  ", " + std::to_string(s.bbox.width) + ", " + std::to_string(s.bbox.height) +
                  "], \"area\": " + std::to_string(s.area);
  if (s.instance_id >= 0) o += ", \"instance_id\": " + std::to_string(s.instance_id);
  if (s.score != 1.f) o += ", \"score\": " + num(s.score);
  if (with_kind) o += std::string(", \"kind\": \"") + toString(s.kind) + "\"";
  return o + "}";
}

}  // namespace

// ---------------------------------------------------------------- box JSON

std::vector<BoundingBox> readBoxJson(const std::string& file, bool index80, cv::Size* size) {
  const auto y = parseJson(file);
  const node_t& root = y.node();
  const node_t* list = nullptr;
  if (size) *size = {};
  if (root.isSequence()) {
    list = &root;
  } else if (root.isMap()) {
    list = yamlu::findValue(root, "boxes");
    if (!list)
      throw DataError(file + ": expected a JSON object with a \"boxes\" list (see docs/detectors.md, box JSON)");
    if (size) {
      const node_t* w = yamlu::findValue(root, "width");
      const node_t* h = yamlu::findValue(root, "height");
      if (w && h) *size = cv::Size(integer(file, *w, "width"), integer(file, *h, "height"));
    }
  } else {
    throw DataError(file + ": expected a JSON object {\"boxes\": [...]}, got " + yamlu::describe(root));
  }
  std::vector<BoundingBox> out;
  if (list->isNullNode()) return out;
  if (!list->isSequence()) throw DataError(at(file, *list) + ": \"boxes\" must be a list, got " + yamlu::describe(*list));
  for (const auto& e : list->asSequence()) {
    if (!e.isMap()) throw DataError(at(file, e) + ": a box must be an object, got " + yamlu::describe(e));
    BoundingBox b;
    const node_t& c = need(file, e, "category_id", "box");
    b.class_id = integer(file, c, "category_id");
    if (index80) {
      const int id = coco::cocoIdFromIndex80(b.class_id);
      if (id < 0) throw DataError(at(file, c) + ": category_id " + std::to_string(b.class_id) + " is not a 0..79 index");
      b.class_id = id;
    }
    const auto bb = numberList(file, need(file, e, "bbox", "box"), "bbox", 4);
    if (bb[2] < 0 || bb[3] < 0) throw DataError(at(file, e) + ": bbox width/height must be >= 0 ([x, y, w, h])");
    b.box = cv::Rect2f(float(bb[0]), float(bb[1]), float(bb[2]), float(bb[3]));
    if (const node_t* s = yamlu::findValue(e, "score"); s && !s->isNullNode()) b.score = float(number(file, *s, "score"));
    else b.score = 1.f;
    if (const node_t* s = yamlu::findValue(e, "instance_id"); s && !s->isNullNode())
      b.instance_id = integer(file, *s, "instance_id");
    out.push_back(b);
  }
  return out;
}

std::string boxJsonText(const std::vector<BoundingBox>& boxes, cv::Size size, const std::string& image) {
  std::string s = "{";
  if (!image.empty()) s += "\"image\": " + jsonEscape(image) + ", ";
  if (size.area() > 0) s += "\"width\": " + std::to_string(size.width) + ", \"height\": " + std::to_string(size.height) + ", ";
  s += "\"boxes\": [";
  for (size_t i = 0; i < boxes.size(); i++) s += std::string(i ? ",\n  " : "\n  ") + boxObject(boxes[i]);
  s += boxes.empty() ? "]}\n" : "\n]}\n";
  return s;
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

// --------------------------------------------------------- COCO panoptic

cv::Mat readPanopticPng(const std::string& file) {
  cv::Mat m = readImage(file, cv::IMREAD_UNCHANGED, "panoptic PNG");
  if (m.depth() != CV_8U || (m.channels() != 3 && m.channels() != 4))
    throw DataError(file + ": panoptic PNG must be 8-bit RGB (id = R + 256 G + 256^2 B)");
  cv::Mat ids(m.size(), CV_32S);
  const int ch = m.channels();
  for (int r = 0; r < m.rows; r++) {
    const uint8_t* p = m.ptr<uint8_t>(r);
    int32_t* o = ids.ptr<int32_t>(r);
    for (int c = 0; c < m.cols; c++, p += ch) o[c] = p[2] + 256 * p[1] + 65536 * p[0];  // BGR in memory
  }
  return ids;
}

void writePanopticPng(const std::string& file, const cv::Mat& ids) {
  if (ids.type() != CV_32SC1) throw Error("writePanopticPng: ids must be CV_32SC1 (" + file + ")");
  cv::Mat m(ids.size(), CV_8UC3);
  for (int r = 0; r < ids.rows; r++) {
    const int32_t* p = ids.ptr<int32_t>(r);
    uint8_t* o = m.ptr<uint8_t>(r);
    for (int c = 0; c < ids.cols; c++, o += 3) {
      const int32_t v = p[c];
      if (v < 0 || v >= (1 << 24)) throw Error("writePanopticPng: id " + std::to_string(v) + " out of 0..2^24-1");
      o[2] = uint8_t(v & 255);
      o[1] = uint8_t((v >> 8) & 255);
      o[0] = uint8_t((v >> 16) & 255);
    }
  }
  writePng(file, m);
}

std::vector<PanopticCategory> cocoPanopticCategories() {
  std::vector<PanopticCategory> v;
  for (const auto& c : coco::categories()) v.push_back({c.id, c.name, c.isthing});
  return v;
}

const PanopticCategory* PanopticJson::category(int id) const {
  for (const auto& c : categories)
    if (c.id == id) return &c;
  return nullptr;
}

const PanopticAnnotation* PanopticJson::find(const std::string& key) const {
  auto it = by_file.find(key);
  if (it == by_file.end()) it = by_file.find(fs::path(key).stem().string());
  return it == by_file.end() ? nullptr : &annotations[it->second];
}

namespace {

PanopticAnnotation readAnnotation(const std::string& file, const node_t& a, const PanopticJson& j) {
  if (!a.isMap()) throw DataError(at(file, a) + ": an annotation must be an object, got " + yamlu::describe(a));
  PanopticAnnotation ann;
  if (const node_t* f = yamlu::findValue(a, "file_name")) ann.file_name = str(*f);
  if (const node_t* f = yamlu::findValue(a, "image_id")) ann.image_id = str(*f);
  const node_t& si = need(file, a, "segments_info", "annotation");
  if (si.isNullNode()) return ann;
  if (!si.isSequence()) throw DataError(at(file, si) + ": 'segments_info' must be a list");
  std::set<int> ids;
  for (const auto& s : si.asSequence()) {
    if (!s.isMap()) throw DataError(at(file, s) + ": a segment must be an object");
    PanopticSegment seg;
    seg.id = integer(file, need(file, s, "id", "segment"), "id");
    if (seg.id <= 0 || seg.id >= (1 << 24))
      throw DataError(at(file, s) + ": segment id " + std::to_string(seg.id) + " out of 1..2^24-1 (0 is void)");
    if (!ids.insert(seg.id).second) throw DataError(at(file, s) + ": duplicate segment id " + std::to_string(seg.id));
    seg.category_id = integer(file, need(file, s, "category_id", "segment"), "category_id");
    if (const node_t* v = yamlu::findValue(s, "bbox"); v && !v->isNullNode()) {
      const auto b = numberList(file, *v, "bbox", 4);
      seg.bbox = cv::Rect(int(b[0]), int(b[1]), int(b[2]), int(b[3]));
    }
    if (const node_t* v = yamlu::findValue(s, "area"); v && !v->isNullNode()) seg.area = int(number(file, *v, "area"));
    if (const node_t* v = yamlu::findValue(s, "score"); v && !v->isNullNode()) seg.score = float(number(file, *v, "score"));
    if (const node_t* v = yamlu::findValue(s, "instance_id"); v && !v->isNullNode())
      seg.instance_id = integer(file, *v, "instance_id");
    const PanopticCategory* c = j.category(seg.category_id);
    seg.kind = !c ? SegmentKind::Unknown : c->isthing ? SegmentKind::Thing : SegmentKind::Stuff;
    if (seg.kind == SegmentKind::Thing && seg.instance_id < 0) seg.instance_id = seg.id;
    if (seg.kind != SegmentKind::Thing) seg.instance_id = -1;
    ann.segments.push_back(seg);
  }
  return ann;
}

}  // namespace

PanopticJson readPanopticJson(const std::string& file) {
  const auto y = parseJson(file);
  const node_t& root = y.node();
  if (!root.isMap())
    throw DataError(file + ": expected a COCO panoptic JSON object ({\"annotations\": [...], \"categories\": [...]})");
  PanopticJson j;
  j.file = file;
  if (const node_t* cats = yamlu::findValue(root, "categories"); cats && cats->isSequence()) {
    j.has_categories = true;
    for (const auto& c : cats->asSequence()) {
      if (!c.isMap()) throw DataError(at(file, c) + ": a category must be an object");
      PanopticCategory pc;
      pc.id = integer(file, need(file, c, "id", "category"), "id");
      if (const node_t* n = yamlu::findValue(c, "name")) pc.name = str(*n);
      if (const node_t* t = yamlu::findValue(c, "isthing"); t && !t->isNullNode()) pc.isthing = truthy(file, *t, "isthing");
      else pc.isthing = coco::isThing(pc.id);
      j.categories.push_back(pc);
    }
  } else {
    j.categories = cocoPanopticCategories();
  }
  auto add = [&](PanopticAnnotation a) {
    const size_t idx = j.annotations.size();
    if (!a.file_name.empty()) {
      j.by_file[a.file_name] = idx;
      j.by_file.emplace(fs::path(a.file_name).stem().string(), idx);
    }
    if (!a.image_id.empty()) j.by_file.emplace(a.image_id, idx);
    j.annotations.push_back(std::move(a));
  };
  if (const node_t* anns = yamlu::findValue(root, "annotations")) {
    if (!anns->isSequence() && !anns->isNullNode()) throw DataError(at(file, *anns) + ": 'annotations' must be a list");
    if (anns->isSequence())
      for (const auto& a : anns->asSequence()) add(readAnnotation(file, a, j));
  } else if (yamlu::findValue(root, "segments_info")) {
    add(readAnnotation(file, root, j));
  } else {
    throw DataError(file + ": COCO panoptic JSON needs an 'annotations' list (or 'segments_info' for a per-frame file)");
  }
  return j;
}

std::string panopticJsonText(const std::vector<PanopticAnnotation>& annotations,
                             const std::vector<PanopticCategory>& categories) {
  std::string s = "{\"annotations\": [";
  for (size_t i = 0; i < annotations.size(); i++) {
    const auto& a = annotations[i];
    s += i ? ",\n  " : "\n  ";
    s += "{\"file_name\": " + jsonEscape(a.file_name);
    if (!a.image_id.empty()) s += ", \"image_id\": " + jsonEscape(a.image_id);
    s += ", \"segments_info\": [";
    for (size_t k = 0; k < a.segments.size(); k++) s += (k ? ",\n    " : "\n    ") + segmentObject(a.segments[k], false);
    s += a.segments.empty() ? "]}" : "\n  ]}";
  }
  s += annotations.empty() ? "],\n\"categories\": [" : "\n],\n\"categories\": [";
  for (size_t i = 0; i < categories.size(); i++)
    s += (i ? ",\n  " : "\n  ") + std::string("{\"id\": ") + std::to_string(categories[i].id) +
         ", \"name\": " + jsonEscape(categories[i].name) + ", \"isthing\": " + (categories[i].isthing ? "1" : "0") + "}";
  s += categories.empty() ? "]}\n" : "\n]}\n";
  return s;
}

void writePanopticJson(const std::string& file, const std::vector<PanopticAnnotation>& annotations,
                       const std::vector<PanopticCategory>& categories) {
  writeText(file, panopticJsonText(annotations, categories));
}

void fillPanoptic(const cv::Mat& ids, const PanopticAnnotation* ann, const PanopticJson& label_set, Detections& out) {
  out.panoptic = ids;
  out.segments.clear();
  // Pixel statistics per id present in the image.
  struct Stat {
    int area = 0, x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1;
  };
  std::map<int, Stat> st;
  for (int r = 0; r < ids.rows; r++) {
    const int32_t* p = ids.ptr<int32_t>(r);
    for (int c = 0; c < ids.cols; c++) {
      if (p[c] == 0) continue;
      Stat& s = st[p[c]];
      s.area++;
      s.x0 = std::min(s.x0, c);
      s.x1 = std::max(s.x1, c);
      s.y0 = std::min(s.y0, r);
      s.y1 = std::max(s.y1, r);
    }
  }
  std::set<int> listed;
  if (ann) {
    for (PanopticSegment seg : ann->segments) {
      listed.insert(seg.id);
      if (!label_set.category(seg.category_id)) {
        seg.kind = SegmentKind::Unknown;
        seg.instance_id = -1;
      }
      auto it = st.find(seg.id);
      if (it != st.end()) {
        if (seg.area <= 0) seg.area = it->second.area;
        if (seg.bbox.area() <= 0)
          seg.bbox = cv::Rect(it->second.x0, it->second.y0, it->second.x1 - it->second.x0 + 1, it->second.y1 - it->second.y0 + 1);
      }
      out.segments.push_back(seg);
    }
  }
  for (const auto& [id, s] : st) {
    if (listed.count(id)) continue;
    PanopticSegment seg;
    seg.id = id;
    seg.category_id = 0;
    seg.kind = SegmentKind::Unknown;
    seg.area = s.area;
    seg.bbox = cv::Rect(s.x0, s.y0, s.x1 - s.x0 + 1, s.y1 - s.y0 + 1);
    out.segments.push_back(seg);
  }
}

cv::Mat semanticFromPanoptic(const Detections& d) {
  cv::Mat sem(d.panoptic.size(), CV_8U, cv::Scalar(coco::kNone));
  if (d.panoptic.empty()) return sem;
  std::map<int, uint8_t> lut;
  for (const auto& s : d.segments)
    lut[s.id] = (s.kind == SegmentKind::Unknown || s.category_id <= 0 || s.category_id > 254) ? uint8_t(coco::kNone)
                                                                                               : uint8_t(s.category_id);
  for (int r = 0; r < sem.rows; r++) {
    const int32_t* p = d.panoptic.ptr<int32_t>(r);
    uint8_t* o = sem.ptr<uint8_t>(r);
    int last = -1;
    uint8_t lv = uint8_t(coco::kNone);
    for (int c = 0; c < sem.cols; c++) {
      if (p[c] != last) {
        last = p[c];
        auto it = lut.find(last);
        lv = it == lut.end() ? uint8_t(coco::kNone) : it->second;
      }
      o[c] = lv;
    }
  }
  return sem;
}

std::string detectionsJsonText(const Detections& d) {
  std::string s = "{\"frame_index\": " + std::to_string(d.frame_index) + ", \"timestamp\": " + num(d.timestamp) +
                  ", \"valid\": " + (d.valid ? "true" : "false") + ", \"boxes\": [";
  for (size_t i = 0; i < d.boxes.size(); i++) {
    std::string b = boxObject(d.boxes[i]);
    b.insert(b.size() - 1, ", \"name\": " + jsonEscape(coco::name(d.boxes[i].class_id)));
    s += (i ? ", " : "") + b;
  }
  s += "]";
  if (!d.semantic.empty()) {
    // Pixel count per class.
    std::map<int, int> hist;
    for (int r = 0; r < d.semantic.rows; r++) {
      const uint8_t* p = d.semantic.ptr<uint8_t>(r);
      for (int c = 0; c < d.semantic.cols; c++) hist[p[c]]++;
    }
    s += ", \"semantic\": {\"width\": " + std::to_string(d.semantic.cols) + ", \"height\": " +
         std::to_string(d.semantic.rows) + ", \"pixels\": {";
    bool first = true;
    for (const auto& [k, v] : hist) {
      s += (first ? "" : ", ") + jsonEscape(k == coco::kNone ? "none" : coco::name(k)) + ": " + std::to_string(v);
      first = false;
    }
    s += "}}";
  }
  if (!d.panoptic.empty()) {
    s += ", \"segments\": [";
    for (size_t i = 0; i < d.segments.size(); i++) s += (i ? ", " : "") + segmentObject(d.segments[i], true);
    s += "]";
  }
  return s + "}";
}

}  // namespace dslam::labels
