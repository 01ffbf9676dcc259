#include "dslam/plugins/classifiers/panoptic_classifier.h"

#include <algorithm>
#include <set>
#include <tuple>
#include <unordered_map>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"

IMPLEMENTS_MRPT_OBJECT(PanopticClassifier, KeypointClassifier, dslam)

namespace dslam {

struct PanopticClassifier::MatchCfg {
  cls::MatchParams m;
  cls::RansacParams r;
};

std::string PanopticClassifier::description() const {
  return "Panoptic-SLAM: people dropped a priori, things tracked by mask IoU and kept only if epipolar-consistent, "
         "unknown regions checked, stuff static";
}

std::vector<ParamSpec> PanopticClassifier::paramSpecs() const {
  std::vector<ParamSpec> s = {
      P_list("prior_classes", ParamType::IntList, "[1]", "thing classes dropped a priori (Panoptic-SLAM: person)"),
      P_double("association_iou", 0.15,
               "mask IoU above which a thing continues a previous one of the same category (ShortTerm_DA: 0.15)", 0,
               1),
      P_double("threshold", 0.1,
               "epipolar distance (px) above which a thing/unknown keypoint is dynamic (Panoptic-SLAM code: 0.1)", 0,
               1000),
      P_bool("drop_new_things", true, "things without a previous association are dropped (code: new objects filtered)"),
      P_bool("drop_unmatched_unknown", true, "unknown-region keypoints without a match are dropped (Panoptic-SLAM)"),
      P_enum("thing_decision", "keypoint", {"keypoint", "object"},
             "keypoint: each outlier is dropped (public code); object: the whole thing is dropped when the outlier "
             "share reaches moving_ratio"),
      P_double("moving_ratio", 0.5, "thing_decision object: outlier share of a thing's matches that drops it", 0, 1),
  };
  for (auto& m : cls::ransacParamSpecs(0.1, "Panoptic-SLAM code")) s.push_back(m);
  for (auto& m : cls::matchParamSpecs()) s.push_back(m);
  return s;
}

void PanopticClassifier::configure(const Params& p, const PluginContext& ctx) {
  KeypointClassifier::configure(p, ctx);
  prior_classes_ = cls::cocoIdList(p, "prior_classes");
  association_iou_ = p.getDouble("association_iou");
  threshold_ = p.getDouble("threshold");
  drop_new_ = p.getBool("drop_new_things");
  drop_unmatched_ = p.getBool("drop_unmatched_unknown");
  object_mode_ = p.getString("thing_decision") == "object";
  moving_ratio_ = p.getDouble("moving_ratio");
  match_ = std::make_shared<MatchCfg>();
  match_->m = cls::matchParams(p);
  match_->r = cls::ransacParams(p);
  reset();
}

void PanopticClassifier::reset() {
  stats_ = {};
  frame_index_ = -1;
  seg_track_.clear();
  seg_stats_.clear();
  next_track_ = 1;
}

struct PanopticClassifier::Work {
  const Detections* det = nullptr;
  const CameraModel* cam = nullptr;
  const Frame* prev = nullptr;
  const Detections* pdet = nullptr;
  bool have_prev = false;
  cls::KeypointRegions reg;
  std::map<int, SegStat> cur_stats;
  std::map<int, int> new_track;  // current segment -> track id
  std::map<int, bool> is_new;
  std::vector<int> cur_stuff, cur_unknown, prev_stuff, prev_unknown;
  std::map<int, std::vector<int>> cur_thing, prev_thing;  // track -> keypoints
  cls::FundamentalFit ff;
  cls::MotionPrior prior;  ///< the motion model's prediction (motion_prior)
};

std::map<int, PanopticClassifier::SegStat> PanopticClassifier::thingStats(const Detections& det) {
  std::map<int, SegStat> cur_stats;
  for (const auto& s : det.segments)
    if (s.kind == SegmentKind::Thing) cur_stats[s.id] = SegStat{0, cv::Rect(), s.category_id};
  std::unordered_map<int, SegStat*> ptr;
  for (auto& [id, st] : cur_stats) ptr[id] = &st;
  int last_id = 0;
  SegStat* last = nullptr;
  for (int r = 0; r < det.panoptic.rows; r++) {
    const int32_t* row = det.panoptic.ptr<int32_t>(r);
    for (int c = 0; c < det.panoptic.cols; c++) {
      const int id = row[c];
      if (id == 0) continue;
      if (id != last_id) {
        auto it = ptr.find(id);
        last = it == ptr.end() ? nullptr : it->second;
        last_id = id;
      }
      if (!last) continue;
      if (last->area == 0)
        last->bbox = cv::Rect(c, r, 1, 1);
      else
        last->bbox |= cv::Rect(c, r, 1, 1);
      last->area++;
    }
  }
  return cur_stats;
}

void PanopticClassifier::associate(Work& w, const Detections& det) const {
  std::vector<std::tuple<double, int, int>> pairs;  // (-iou, cur id, prev id)
  if (w.have_prev)
    for (const auto& [a, sa] : w.cur_stats) {
      if (sa.area == 0) continue;
      for (const auto& [b, sb] : seg_stats_) {
        if (sb.category != sa.category || sb.area == 0 || !seg_track_.count(b)) continue;
        const cv::Rect x = sa.bbox & sb.bbox;
        if (x.area() == 0) continue;
        int inter = 0;
        for (int r = x.y; r < x.y + x.height; r++) {
          const int32_t* pa = det.panoptic.ptr<int32_t>(r);
          const int32_t* pb = w.pdet->panoptic.ptr<int32_t>(r);
          for (int c = x.x; c < x.x + x.width; c++) inter += (pa[c] == a) & (pb[c] == b);
        }
        const double iou = static_cast<double>(inter) / (sa.area + sb.area - inter);
        if (iou > association_iou_) pairs.emplace_back(-iou, a, b);
      }
    }
  std::sort(pairs.begin(), pairs.end());
  std::set<int> used_prev;
  for (const auto& [niou, a, b] : pairs) {
    if (w.new_track.count(a) || used_prev.count(b)) continue;
    w.new_track[a] = seg_track_.at(b);
    w.is_new[a] = false;
    used_prev.insert(b);
  }
}

void PanopticClassifier::labelAndGroup(Frame& frame, Work& w) const {
  const size_t n = frame.size();
  for (size_t i = 0; i < n; i++) {
    KeypointMeta& m = frame.meta[i];
    if (w.reg.category[i] > 0) m.class_id = static_cast<int16_t>(w.reg.category[i]);
    if (w.reg.region[i] != cls::Region::Thing) continue;
    auto it = w.new_track.find(w.reg.segment[i]);
    if (it != w.new_track.end()) m.object_id = it->second;
    if (cls::contains(prior_classes_, w.reg.category[i])) cls::raise(m, KpLabel::Dynamic, KpReason::PersonPrior);
  }
  for (size_t i = 0; i < n; i++) {
    if (frame.meta[i].label == KpLabel::Dynamic) continue;
    const int ii = static_cast<int>(i);
    switch (w.reg.region[i]) {
      case cls::Region::Stuff: w.cur_stuff.push_back(ii); break;
      case cls::Region::Unknown: w.cur_unknown.push_back(ii); break;
      case cls::Region::Thing: {
        auto it = w.new_track.find(w.reg.segment[i]);
        if (it != w.new_track.end()) w.cur_thing[it->second].push_back(ii);
        break;
      }
      default: break;
    }
  }
}

void PanopticClassifier::groupPrevious(const Frame& frame, Work& w) const {
  const Frame* prev = w.prev;
  const cls::KeypointRegions preg =
      cls::panopticRegions(prev->keypoints, *w.pdet, cls::imageSize(*prev, w.cam, w.pdet->panoptic.size()));
  const bool pm = prev->meta.size() == prev->size();
  for (size_t j = 0; j < prev->size(); j++) {
    if (pm && prev->meta[j].label == KpLabel::Dynamic) continue;
    const int jj = static_cast<int>(j);
    switch (preg.region[j]) {
      case cls::Region::Stuff: w.prev_stuff.push_back(jj); break;
      case cls::Region::Unknown: w.prev_unknown.push_back(jj); break;
      case cls::Region::Thing: {
        auto it = seg_track_.find(preg.segment[j]);
        if (it != seg_track_.end()) w.prev_thing[it->second].push_back(jj);
        break;
      }
      default: break;
    }
  }
  if (frame.descriptors.rows != static_cast<int>(frame.size()) ||
      prev->descriptors.rows != static_cast<int>(prev->size()))
    throw DataError("frame " + std::to_string(frame.index()) +
                    ": PanopticClassifier needs one descriptor row per keypoint (current and previous frame)");
}

void PanopticClassifier::fitStuff(const Frame& frame, Work& w) {
  const Frame* prev = w.prev;
  const auto m = cls::matchDescriptors(frame.keypoints, frame.descriptors, w.cur_stuff, prev->keypoints,
                                       prev->descriptors, w.prev_stuff, match_->m);
  std::vector<cv::Point2f> p0, p1;
  for (size_t k = 0; k < w.cur_stuff.size(); k++)
    if (m[k] >= 0) {
      p0.push_back(cls::undistorted(*prev, static_cast<size_t>(m[k]), w.cam));
      p1.push_back(cls::undistorted(frame, static_cast<size_t>(w.cur_stuff[k]), w.cam));
    }
  stats_.stuff_matches = static_cast<int>(p0.size());
  w.ff = cls::fitFundamental(p0, p1, match_->r, &w.prior);
  stats_.fitted = w.ff.ok;
  stats_.fit_inliers = w.ff.inliers;
}

void PanopticClassifier::classifyThings(Frame& frame, Work& w) {
  const Frame* prev = w.prev;
  for (const auto& [track, idx] : w.cur_thing) {
    int seg = 0;
    for (const auto& [s, t] : w.new_track)
      if (t == track) seg = s;
    if (w.is_new[seg]) {
      const bool drop = drop_new_ && w.have_prev;  // the first frame cannot tell (as the public code)
      for (int i : idx) {
        if (drop)
          cls::raise(frame.meta[i], KpLabel::Dynamic, KpReason::NewObject);
        else
          cls::raise(frame.meta[i], KpLabel::Movable, KpReason::OnObject);
      }
      continue;
    }
    std::vector<char> out(idx.size(), 0);
    int matched = 0, outliers = 0;
    if (w.ff.ok) {
      auto pit = w.prev_thing.find(track);
      const std::vector<int> empty;
      const std::vector<int>& pidx = pit == w.prev_thing.end() ? empty : pit->second;
      const auto m = cls::matchDescriptors(frame.keypoints, frame.descriptors, idx, prev->keypoints, prev->descriptors,
                                           pidx, match_->m);
      for (size_t k = 0; k < idx.size(); k++)
        if (m[k] >= 0) {
          matched++;
          if (cls::epipolarDistance(w.ff.F, cls::undistorted(*prev, static_cast<size_t>(m[k]), w.cam),
                                    cls::undistorted(frame, static_cast<size_t>(idx[k]), w.cam)) > threshold_) {
            out[k] = 1;
            outliers++;
          }
        }
    }
    const bool whole = object_mode_ && matched > 0 && outliers >= moving_ratio_ * matched;
    for (size_t k = 0; k < idx.size(); k++) {
      KeypointMeta& mm = frame.meta[idx[k]];
      if (whole || (!object_mode_ && out[k])) {
        cls::raise(mm, KpLabel::Dynamic, KpReason::EpipolarOutlier);
        stats_.thing_outliers++;
      } else {
        cls::raise(mm, KpLabel::Movable, KpReason::OnObject);
      }
    }
  }
}

void PanopticClassifier::classifyUnknown(Frame& frame, Work& w) {
  if (!w.ff.ok || w.cur_unknown.empty()) return;
  const Frame* prev = w.prev;
  const auto m = cls::matchDescriptors(frame.keypoints, frame.descriptors, w.cur_unknown, prev->keypoints,
                                       prev->descriptors, w.prev_unknown, match_->m);
  for (size_t k = 0; k < w.cur_unknown.size(); k++) {
    KeypointMeta& mm = frame.meta[w.cur_unknown[k]];
    if (m[k] < 0) {
      if (drop_unmatched_) {
        cls::raise(mm, KpLabel::Dynamic, KpReason::UnmatchedUnknown);
        stats_.unknown_unmatched++;
      }
    } else if (cls::epipolarDistance(w.ff.F, cls::undistorted(*prev, static_cast<size_t>(m[k]), w.cam),
                                     cls::undistorted(frame, static_cast<size_t>(w.cur_unknown[k]), w.cam)) >
               threshold_) {
      cls::raise(mm, KpLabel::Dynamic, KpReason::EpipolarOutlier);
      stats_.unknown_outliers++;
    }
  }
}

void PanopticClassifier::classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) {
  cls::ensureMeta(frame);
  if (!match_) throw Error("PanopticClassifier: classify() before configure()");
  stats_ = {};
  if (!det.valid || det.panoptic.empty()) {
    frame_index_ = -1;  // no segments: the next frame starts afresh
    seg_track_.clear();
    seg_stats_.clear();
    return;
  }
  if (det.panoptic.type() != CV_32S)
    throw DataError("frame " + std::to_string(frame.index()) + ": panoptic image must be CV_32S, got type " +
                    std::to_string(det.panoptic.type()));
  Work w;
  w.det = &det;
  w.cam = ctx.camera;
  w.reg = cls::panopticRegions(frame.keypoints, det, cls::imageSize(frame, w.cam, det.panoptic.size()));
  w.cur_stats = thingStats(det);
  w.prev = ctx.previous;
  w.pdet = ctx.previous_detections;
  if (match_->r.motion_prior) w.prior = cls::motionPrior(ctx);
  w.have_prev = w.prev && w.pdet && w.pdet->valid && !w.pdet->panoptic.empty() && w.pdet->panoptic.type() == CV_32S &&
                w.pdet->panoptic.size() == det.panoptic.size() && frame_index_ >= 0 &&
                frame_index_ == w.prev->index();
  associate(w, det);
  for (const auto& [a, sa] : w.cur_stats)
    if (!w.new_track.count(a)) {
      w.new_track[a] = next_track_++;
      w.is_new[a] = true;
      stats_.new_things++;
    }
  stats_.things = static_cast<int>(w.cur_stats.size());
  labelAndGroup(frame, w);
  if (w.have_prev) {
    groupPrevious(frame, w);
    fitStuff(frame, w);
  }
  classifyThings(frame, w);
  classifyUnknown(frame, w);
  // State for the next frame.
  frame_index_ = frame.index();
  seg_track_ = std::move(w.new_track);
  seg_stats_ = std::move(w.cur_stats);
}

}  // namespace dslam
