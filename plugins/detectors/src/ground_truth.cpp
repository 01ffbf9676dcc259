#include "dslam/plugins/detectors/ground_truth.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "common.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"

IMPLEMENTS_MRPT_OBJECT(GroundTruthDetector, Detector, dslam)

namespace dslam {

namespace {

uint64_t splitmix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

enum Salt : uint64_t {
  kMiss = 1,
  kSwap = 2,
  kSwapTo = 3,
  kJitter = 10,  // 10..13
  kFpCount = 20,
  kFp = 30,  // 30 + 8 k .. : per false positive
};

}  // namespace

double hashUniform(uint64_t seed, int64_t frame, int64_t object, uint64_t salt) {
  uint64_t h = splitmix(seed);
  h = splitmix(h ^ uint64_t(frame));
  h = splitmix(h ^ uint64_t(object));
  h = splitmix(h ^ salt);
  return double(h >> 11) * (1.0 / 9007199254740992.0);  // 2^-53
}

namespace {

/** One frame's degradation (degrade()): the steps share the inputs, the
 *  output and whether the semantic image was copied yet. */
struct Degrader {
  const Detections& truth;
  const Degradation& d;
  uint64_t seed;
  int64_t frame;
  cv::Size image;
  std::vector<int> swap_to;
  Detections out;
  bool have_pan = false, sem_cloned = false;

  bool missed(int64_t key) const { return d.miss_rate > 0 && hashUniform(seed, frame, key, kMiss) < d.miss_rate; }
  /** New class of an object, or -1 if not swapped. */
  int swapped(int64_t key, int old_class) const {
    if (d.swap_rate <= 0 || swap_to.empty() || hashUniform(seed, frame, key, kSwap) >= d.swap_rate) return -1;
    size_t k = size_t(hashUniform(seed, frame, key, kSwapTo) * double(swap_to.size())) % swap_to.size();
    if (swap_to[k] == old_class) {
      if (swap_to.size() == 1) return -1;
      k = (k + 1) % swap_to.size();
    }
    return swap_to[k];
  }
  void cloneSemantic() {
    if (!sem_cloned) {
      out.semantic = truth.semantic.clone();
      sem_cloned = true;
    }
  }

  /** Panoptic segments: per segment keep / remove / new class, pixels too. */
  void segments() {
    std::map<int, int> seg_action;  // segment id -> 0 remove, >0 new class, absent = unchanged
    for (const auto& s : truth.segments) {
      PanopticSegment ns = s;
      if (s.kind == SegmentKind::Thing && s.instance_id >= 0) {
        if (missed(s.instance_id)) {
          seg_action[s.id] = 0;
          continue;
        }
        if (int c = swapped(s.instance_id, s.category_id); c > 0) {
          seg_action[s.id] = c;
          ns.category_id = c;
          ns.kind = coco::isThing(c) ? SegmentKind::Thing : SegmentKind::Stuff;
        }
      }
      out.segments.push_back(ns);
    }
    if (!have_pan || seg_action.empty()) return;
    out.panoptic = truth.panoptic.clone();
    if (!truth.semantic.empty()) out.semantic = truth.semantic.clone();
    sem_cloned = true;
    const bool sem = !out.semantic.empty() && out.semantic.size() == out.panoptic.size();
    for (int r = 0; r < out.panoptic.rows; r++) {
      int32_t* p = out.panoptic.ptr<int32_t>(r);
      uint8_t* q = sem ? out.semantic.ptr<uint8_t>(r) : nullptr;
      for (int c = 0; c < out.panoptic.cols; c++) {
        auto it = seg_action.find(p[c]);
        if (it == seg_action.end()) continue;
        if (it->second == 0) {
          p[c] = 0;
          if (q) q[c] = uint8_t(coco::kNone);
        } else if (q) {
          q[c] = uint8_t(std::min(it->second, 255));
        }
      }
    }
  }

  void semEdit(const cv::Rect2f& box, int from, int to) {
    if (have_pan || truth.semantic.empty()) return;  // panoptic pixels already handled
    cloneSemantic();
    const cv::Rect r = cv::Rect(box) & cv::Rect(0, 0, out.semantic.cols, out.semantic.rows);
    cv::Mat roi = out.semantic(r);
    roi.setTo(cv::Scalar(to), roi == from);
  }

  /** Boxes: misses, class swaps, jitter, clipping. */
  void boxes() {
    for (size_t i = 0; i < truth.boxes.size(); i++) {
      BoundingBox b = truth.boxes[i];
      const int64_t key = b.instance_id >= 0 ? int64_t(b.instance_id) : -int64_t(i) - 1;
      if (missed(key)) {
        semEdit(b.box, b.class_id, coco::kNone);
        continue;
      }
      if (int c = swapped(key, b.class_id); c > 0) {
        semEdit(b.box, b.class_id, std::min(c, 255));
        b.class_id = c;
      }
      if (d.jitter > 0) {
        const auto u = [&](int k) { return 2.0 * hashUniform(seed, frame, key, kJitter + uint64_t(k)) - 1.0; };
        const double w = b.box.width, h = b.box.height;
        const double cx = b.box.x + 0.5 * w + d.jitter * w * u(0), cy = b.box.y + 0.5 * h + d.jitter * h * u(1);
        const double nw = w * (1.0 + d.jitter * u(2)), nh = h * (1.0 + d.jitter * u(3));
        b.box = cv::Rect2f(float(cx - 0.5 * nw), float(cy - 0.5 * nh), float(nw), float(nh));
      }
      if (image.area() > 0) b.box = det::clipBox(b.box, image);
      if (b.box.width <= 0 || b.box.height <= 0) continue;
      out.boxes.push_back(b);
    }
  }

  /** False-positive boxes, painted into the masks when asked. */
  void falsePositives() {
    if (d.false_positive_rate <= 0) return;
    if (image.area() <= 0)
      throw DataError("frame " + std::to_string(frame) + ": image size unknown, cannot place false positives");
    const double fl = std::floor(d.false_positive_rate);
    const int n = int(fl) + (hashUniform(seed, frame, -1, kFpCount) < d.false_positive_rate - fl ? 1 : 0);
    int next_id = 1;
    for (const auto& s : out.segments) next_id = std::max(next_id, s.id + 1);
    for (int k = 0; k < n; k++) {
      const auto u = [&](int j) { return hashUniform(seed, frame, -1, kFp + 8 * uint64_t(k) + uint64_t(j)); };
      const double w = (d.fp_min_size + (d.fp_max_size - d.fp_min_size) * u(0)) * image.width;
      const double h = (d.fp_min_size + (d.fp_max_size - d.fp_min_size) * u(1)) * image.height;
      BoundingBox b;
      b.box = det::clipBox(cv::Rect2f(float(u(2) * (image.width - w)), float(u(3) * (image.height - h)), float(w),
                                      float(h)),
                           image);
      b.class_id = d.fp_class;
      b.score = float(0.5 + 0.5 * u(4));
      if (b.box.area() <= 0) continue;
      out.boxes.push_back(b);
      if (d.fp_in_masks) paintFalsePositive(b, next_id);
    }
    if (d.fp_in_masks && have_pan) recomputeSegmentStats();
  }

  void paintFalsePositive(const BoundingBox& b, int& next_id) {
    const cv::Point ctr(int(b.box.x + b.box.width / 2), int(b.box.y + b.box.height / 2));
    const cv::Size ax(std::max(1, int(b.box.width / 2)), std::max(1, int(b.box.height / 2)));
    if (!truth.semantic.empty()) {
      cloneSemantic();
      cv::ellipse(out.semantic, ctr, ax, 0, 0, 360, cv::Scalar(std::min(d.fp_class, 255)), cv::FILLED);
    }
    if (!have_pan) return;
    if (out.panoptic.data == truth.panoptic.data) out.panoptic = truth.panoptic.clone();
    PanopticSegment s;
    s.id = next_id++;
    s.category_id = d.fp_class;
    s.kind = coco::isThing(d.fp_class) ? SegmentKind::Thing : SegmentKind::Stuff;
    s.instance_id = -1;
    s.score = b.score;
    cv::ellipse(out.panoptic, ctr, ax, 0, 0, 360, cv::Scalar(s.id), cv::FILLED);
    out.segments.push_back(s);
  }

  /** Areas and boxes of segments changed by painting, from the pixels. */
  void recomputeSegmentStats() {
    std::map<int, std::pair<int, cv::Rect>> st;
    for (int r = 0; r < out.panoptic.rows; r++) {
      const int32_t* p = out.panoptic.ptr<int32_t>(r);
      for (int c = 0; c < out.panoptic.cols; c++) {
        if (!p[c]) continue;
        auto& e = st[p[c]];
        e.first++;
        e.second = e.first == 1 ? cv::Rect(c, r, 1, 1) : (e.second | cv::Rect(c, r, 1, 1));
      }
    }
    std::vector<PanopticSegment> segs;
    for (auto s : out.segments) {
      auto it = st.find(s.id);
      if (it == st.end()) continue;  // fully covered
      s.area = it->second.first;
      s.bbox = it->second.second;
      segs.push_back(s);
    }
    out.segments = segs;
  }
};

}  // namespace

Detections degrade(const Detections& truth, const Degradation& d, uint64_t seed, int64_t frame, cv::Size image) {
  Degrader g{truth, d, seed, frame, image, d.swap_classes, truth, false, false};
  g.out.boxes.clear();
  g.out.segments.clear();
  if (g.swap_to.empty())
    for (int i = 0; i < 80; i++) g.swap_to.push_back(coco::cocoIdFromIndex80(i));
  g.have_pan = !truth.panoptic.empty();
  g.segments();
  g.boxes();
  g.falsePositives();
  return g.out;
}

// ------------------------------------------------------------ the plugin

std::string GroundTruthDetector::description() const {
  return "ground-truth labels of synthetic scenes (boxes/, semantic/, panoptic/), degraded on purpose: misses, "
         "jitter, false positives, label swaps, latency";
}

std::vector<ParamSpec> GroundTruthDetector::paramSpecs() const {
  auto v = labelSourceParamSpecs("folder holding boxes/, semantic/, panoptic/ ('' = the dataset folder)");
  v.push_back(P_double("miss_rate", 0, "probability to drop an object (box and mask) in a frame", 0, 1));
  v.push_back(P_double("jitter", 0, "max box centre shift and size change, fraction of the box size", 0, 1));
  v.push_back(P_double("false_positive_rate", 0, "expected false-positive boxes per frame", 0, 100));
  v.push_back(P_int("fp_class", 1, "COCO id of false positives (person = 1)", 1, 200));
  v.push_back(P_double("fp_min_size", 0.1, "min false-positive box size, fraction of the image", 0.001, 1));
  v.push_back(P_double("fp_max_size", 0.4, "max false-positive box size, fraction of the image", 0.001, 1));
  v.push_back(P_bool("fp_in_masks", false, "also paint false positives (ellipses) into semantic/panoptic"));
  v.push_back(P_double("swap_rate", 0, "probability to change an object's class", 0, 1));
  v.push_back(P_list("swap_classes", ParamType::IntList, "[]", "classes to swap to (empty = the 80 COCO things)"));
  v.push_back(P_int("latency", 0, "output the labels of the frame N positions earlier (first N: valid = false)", 0,
                    100000));
  v.push_back(P_list("classes", ParamType::IntList, "[]", "COCO ids of boxes to keep (empty = all)"));
  return v;
}

void GroundTruthDetector::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  src_.open(labelSourceOptions(p, ctx, "GroundTruthDetector"));
  keys_ = src_.keys();
  key_pos_.clear();
  for (size_t i = 0; i < keys_.size(); i++) key_pos_[keys_[i]] = int64_t(i);
  deg_ = Degradation{};
  deg_.miss_rate = p.getDouble("miss_rate");
  deg_.jitter = p.getDouble("jitter");
  deg_.false_positive_rate = p.getDouble("false_positive_rate");
  deg_.fp_class = int(p.getInt("fp_class"));
  if (!coco::find(deg_.fp_class)) throw ConfigError("GroundTruthDetector: fp_class " + std::to_string(deg_.fp_class) + " is not a COCO id");
  deg_.fp_min_size = p.getDouble("fp_min_size");
  deg_.fp_max_size = p.getDouble("fp_max_size");
  if (deg_.fp_max_size < deg_.fp_min_size) throw ConfigError("GroundTruthDetector: fp_max_size < fp_min_size");
  deg_.fp_in_masks = p.getBool("fp_in_masks");
  deg_.swap_rate = p.getDouble("swap_rate");
  deg_.swap_classes = det::classFilter(p, "swap_classes");
  latency_ = int(p.getInt("latency"));
  seed_ = ctx.seed;
  fail_on_missing_ = p.getString("on_missing") == "fail";
  keep_ = det::classFilter(p);
  missing_ = 0;
}

Detections GroundTruthDetector::detect(const SensorFrame& frame) {
  Detections d = det::emptyDetections(frame);
  const std::string key = src_.key(frame);
  auto it = key_pos_.find(key);
  if (it == key_pos_.end()) {
    if (fail_on_missing_)
      throw DataError("frame " + std::to_string(frame.index) + ": no ground-truth labels named '" + key + "' in " +
                      src_.options().root + " (GroundTruthDetector on_missing: fail)");
    if (missing_ % 100 == 0)
      DSLAM_LOG(Warn, "GroundTruthDetector: frame " << frame.index << ": no labels named '" << key << "' ("
                                                    << missing_ + 1 << " frame(s) so far)");
    missing_++;
    return d;
  }
  const int64_t pos = it->second;
  const int64_t src = pos - latency_;
  if (src < 0) {
    d.valid = false;
    return d;
  }
  Detections truth;
  const auto missing = src_.read(keys_[size_t(src)], truth, frame.image.size());
  if (!missing.empty() && fail_on_missing_)
    throw DataError("frame " + std::to_string(frame.index) + ": label file missing: " + missing.front());
  cv::Size size = frame.image.size();
  if (size.area() <= 0) size = !truth.semantic.empty() ? truth.semantic.size() : truth.panoptic.size();
  Detections out = degrade(truth, deg_, seed_, src, size);
  out.frame_index = frame.index;
  out.timestamp = frame.timestamp;
  out.valid = true;
  if (!keep_.empty())
    out.boxes.erase(std::remove_if(out.boxes.begin(), out.boxes.end(),
                                   [&](const BoundingBox& b) {
                                     return !std::binary_search(keep_.begin(), keep_.end(), b.class_id);
                                   }),
                    out.boxes.end());
  return out;
}

}  // namespace dslam
