// COCO panoptic PNG + JSON (docs/detectors.md): reading, writing, and the
// combination of an id image with its annotation into Detections.
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <map>
#include <set>

#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/json_layout.h"
#include "dslam/plugins/detectors/label_io.h"
#include "label_json.h"

namespace fs = std::filesystem;

namespace dslam::labels {

using namespace detail;

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

PanopticAnnotation readAnnotation(const At& at, const json& a, const PanopticJson& j) {
  if (!a.is_object()) throw DataError(at.str() + ": an annotation must be an object, got " + describe(a));
  PanopticAnnotation ann;
  auto text = [](const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
  if (const json* f = optional(a, "file_name")) ann.file_name = text(*f);
  if (const json* f = optional(a, "image_id")) ann.image_id = text(*f);
  const json& si = need(at, a, "segments_info", "annotation");
  if (si.is_null()) return ann;
  const At sat = at.key("segments_info");
  if (!si.is_array()) throw DataError(sat.str() + ": must be a list");
  std::set<int> ids;
  for (size_t k = 0; k < si.size(); k++) {
    const json& s = si[k];
    const At st = sat.index(k);
    if (!s.is_object()) throw DataError(st.str() + ": a segment must be an object");
    PanopticSegment seg;
    seg.id = integer(st.key("id"), need(st, s, "id", "segment"));
    if (seg.id <= 0 || seg.id >= (1 << 24))
      throw DataError(st.str() + ": segment id " + std::to_string(seg.id) + " out of 1..2^24-1 (0 is void)");
    if (!ids.insert(seg.id).second) throw DataError(st.str() + ": duplicate segment id " + std::to_string(seg.id));
    seg.category_id = integer(st.key("category_id"), need(st, s, "category_id", "segment"));
    if (const json* v = optional(s, "bbox")) {
      const auto b = numberList(st.key("bbox"), *v, 4);
      seg.bbox = cv::Rect(int(b[0]), int(b[1]), int(b[2]), int(b[3]));
    }
    if (const json* v = optional(s, "area")) seg.area = int(number(st.key("area"), *v));
    if (const json* v = optional(s, "score")) seg.score = float(number(st.key("score"), *v));
    if (const json* v = optional(s, "instance_id")) seg.instance_id = integer(st.key("instance_id"), *v);
    const PanopticCategory* c = j.category(seg.category_id);
    seg.kind = !c ? SegmentKind::Unknown : c->isthing ? SegmentKind::Thing : SegmentKind::Stuff;
    if (seg.kind == SegmentKind::Thing && seg.instance_id < 0) seg.instance_id = seg.id;
    if (seg.kind != SegmentKind::Thing) seg.instance_id = -1;
    ann.segments.push_back(seg);
  }
  return ann;
}

std::vector<PanopticCategory> readCategories(const At& at, const json& cats) {
  std::vector<PanopticCategory> out;
  for (size_t i = 0; i < cats.size(); i++) {
    const json& c = cats[i];
    const At ct = at.index(i);
    if (!c.is_object()) throw DataError(ct.str() + ": a category must be an object");
    PanopticCategory pc;
    pc.id = integer(ct.key("id"), need(ct, c, "id", "category"));
    if (const json* n = optional(c, "name"); n && n->is_string()) pc.name = n->get<std::string>();
    const json* t = optional(c, "isthing");
    pc.isthing = t ? truthy(ct.key("isthing"), *t) : coco::isThing(pc.id);
    out.push_back(pc);
  }
  return out;
}

}  // namespace

PanopticJson readPanopticJson(const std::string& file) {
  const json root = parseJsonFile(file);
  const At top{file, ""};
  if (!root.is_object())
    throw DataError(file + ": expected a COCO panoptic JSON object ({\"annotations\": [...], \"categories\": [...]})");
  PanopticJson j;
  j.file = file;
  if (const json* cats = optional(root, "categories"); cats && cats->is_array()) {
    j.has_categories = true;
    j.categories = readCategories(top.key("categories"), *cats);
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
  if (root.contains("annotations")) {
    const json& anns = root["annotations"];
    if (!anns.is_array() && !anns.is_null()) throw DataError(top.key("annotations").str() + ": must be a list");
    if (anns.is_array())
      for (size_t i = 0; i < anns.size(); i++) add(readAnnotation(top.key("annotations").index(i), anns[i], j));
  } else if (root.contains("segments_info")) {
    add(readAnnotation(top, root, j));
  } else {
    throw DataError(file + ": COCO panoptic JSON needs an 'annotations' list (or 'segments_info' for a per-frame file)");
  }
  return j;
}

std::string panopticJsonText(const std::vector<PanopticAnnotation>& annotations,
                             const std::vector<PanopticCategory>& categories) {
  using ojson = nlohmann::ordered_json;
  ojson anns = ojson::array(), cats = ojson::array();
  for (const auto& a : annotations) {
    ojson o = {{"file_name", a.file_name}};
    if (!a.image_id.empty()) o["image_id"] = a.image_id;
    ojson segs = ojson::array();
    for (const auto& s : a.segments) segs.push_back(segmentObject(s, false));
    o["segments_info"] = std::move(segs);
    anns.push_back(std::move(o));
  }
  for (const auto& c : categories) cats.push_back({{"id", c.id}, {"name", c.name}, {"isthing", c.isthing ? 1 : 0}});
  return layoutJson(ojson{{"annotations", std::move(anns)}, {"categories", std::move(cats)}}, 2);
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

}  // namespace dslam::labels
