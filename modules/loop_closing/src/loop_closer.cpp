#include "dslam/loop_closing/loop_closer.h"

#include <Eigen/Geometry>

#include <nlohmann/json.hpp>

#include <algorithm>

#include "dslam/core/log.h"

namespace dslam {

std::vector<ParamSpec> LoopClosingParams::specs() {
  LoopClosingParams d;
  return {
      P_bool("enabled", d.enabled, "detect and close loops (needs a vocabulary, place_recognition section)"),
      P_int("consistency", d.consistency,
            "keyframes that must confirm a loop: the current one and its covisible keyframes agreeing on the "
            "same correction (ORB-SLAM3-style; ORB-SLAM mnCovisibilityConsistencyTh = 3)", 1),
      P_int("strong_inliers", d.strong_inliers,
            "a candidate with this many SE(3) inliers is accepted without the covisibility confirmation (keyframes "
            "are sparse on well-textured scenes; 0 = always require it)", 0),
      P_int("min_bow_matches", d.min_bow_matches, "BoW matches with a candidate keyframe (ORB-SLAM: 20)", 3),
      P_int("min_inliers", d.min_inliers, "inliers of the SE(3) RANSAC and guided matching (ORB-SLAM: 20)", 3),
      P_int("min_total_matches", d.min_total_matches, "matches with the loop keyframe's covisible points (ORB-SLAM: 40)", 3),
      P_int("ransac_iterations", d.ransac_iterations, "3D-3D RANSAC iterations (ORB-SLAM Sim3Solver: 300)", 1),
      P_bool("refine_correction", d.refine_correction,
             "refine the correction of the 3D-3D RANSAC (both keyframes' depths) by the reprojection errors of "
             "the current keyframe's keypoints on the matched points of the loop keyframe and its neighbours "
             "(ORB-SLAM OptimizeSim3 after the Sim3Solver; the depth of a new map's few-frame points is noisy)"),
      P_int("keyframes_between_loops", d.keyframes_between_loops, "keyframes after a loop before the next detection (ORB-SLAM: 10)", 0),
      P_int("essential_min_weight", d.essential_min_weight, "covisibility weight of essential-graph edges (ORB-SLAM: 100)", 1),
      P_int("pose_graph_iterations", d.pose_graph_iterations, "essential-graph optimisation iterations (ORB-SLAM: 20)", 1),
      P_bool("global_ba", d.global_ba, "full bundle adjustment after each loop or merge (ORB-SLAM2: yes)"),
      P_int("global_ba_iterations", d.global_ba_iterations, "global BA iterations (ORB-SLAM2: 10)", 1),
      P_bool("global_ba_reject_outliers", d.global_ba_reject_outliers,
             "global BA in two passes: optimise, drop the observations over the chi2 95% bound, optimise again (as "
             "local BA and ORB-SLAM3's merge BA; ORB-SLAM2's global BA keeps every observation: false). Points fused "
             "wrongly across a merge otherwise pull the two maps apart (docs/slam.md)"),
      P_int("global_ba_again_after", d.global_ba_again_after,
            "a second global BA this many keyframes after a loop or merge (0 = none, as ORB-SLAM). The first one "
            "welds the two parts with the closing keyframe's view only; where that view is far structure at one "
            "depth its height and pitch trade against each other (on shift_dark 2-4 cm predicted from the "
            "matches at one pixel, event position_sigma_m) and the keyframes after it add the links that "
            "separate them (docs/changing.md)", 0),
      P_bool("global_ba_at_end", d.global_ba_at_end,
             "a run that closed a loop or merge ends with a global BA of the current map, so that the trajectory and "
             "map it writes use the keyframes after the last event too (an offline result; the poses given while "
             "running are not changed by it; ORB-SLAM: no)"),
      P_bool("merge_maps", d.merge_maps, "a candidate in another map of the atlas merges that map into the current one"),
  };
}

LoopClosingParams LoopClosingParams::fromParams(const Params& p) {
  LoopClosingParams l;
  l.enabled = p.getBool("enabled");
  l.consistency = static_cast<int>(p.getInt("consistency"));
  l.strong_inliers = static_cast<int>(p.getInt("strong_inliers"));
  l.min_bow_matches = static_cast<int>(p.getInt("min_bow_matches"));
  l.min_inliers = static_cast<int>(p.getInt("min_inliers"));
  l.min_total_matches = static_cast<int>(p.getInt("min_total_matches"));
  l.ransac_iterations = static_cast<int>(p.getInt("ransac_iterations"));
  l.refine_correction = p.getBool("refine_correction");
  l.keyframes_between_loops = static_cast<int>(p.getInt("keyframes_between_loops"));
  l.essential_min_weight = static_cast<int>(p.getInt("essential_min_weight"));
  l.pose_graph_iterations = static_cast<int>(p.getInt("pose_graph_iterations"));
  l.global_ba = p.getBool("global_ba");
  l.global_ba_iterations = static_cast<int>(p.getInt("global_ba_iterations"));
  l.global_ba_reject_outliers = p.getBool("global_ba_reject_outliers");
  l.global_ba_again_after = static_cast<int>(p.getInt("global_ba_again_after"));
  l.global_ba_at_end = p.getBool("global_ba_at_end");
  l.merge_maps = p.getBool("merge_maps");
  return l;
}

const char* toString(LoopEvent::Type t) { return t == LoopEvent::Type::Merge ? "merge" : "loop"; }

std::string LoopEvent::json() const {
  nlohmann::ordered_json j;
  j["event"] = toString(type);
  j["frame"] = frame;
  j["keyframe"] = kf;
  j["matched_keyframe"] = other_kf;
  j["map"] = map;
  j["other_map"] = other_map;
  j["inliers"] = inliers;
  j["matches"] = matches;
  j["correction_m"] = correction_m;
  j["correction_deg"] = correction_deg;
  j["position_sigma_m"] = position_sigma_m;
  return j.dump();
}

LoopCloser::LoopCloser(const LoopClosingParams& p, std::shared_ptr<Backend> backend,
                       std::shared_ptr<KeyFrameDatabase> db, MapManager* maps, LocalMapper* mapper, StageTimer* timer)
    : p_(p),
      backend_(std::move(backend)),
      db_(std::move(db)),
      maps_(maps),
      mapper_(mapper),
      timer_(timer),
      worker_([this](KeyFramePtr& kf) { process(kf); }) {}

LoopCloser::~LoopCloser() { stop(); }

void LoopCloser::insertKeyFrame(const KeyFramePtr& kf) { worker_.push(kf); }

void LoopCloser::processAll() { worker_.drain(); }

void LoopCloser::start() { worker_.start(); }

void LoopCloser::stop() { worker_.stop(); }

void LoopCloser::waitIdle() { worker_.waitIdle(); }

void LoopCloser::finish(Map& current, int frame) {
  if (!p_.global_ba_at_end || loops_ + merges_ == 0) return;
  DSLAM_LOG(Info, "global BA at the end of the run (" << loops_ << " loops, " << merges_ << " merges closed)");
  globalBundleAdjustment(current, "global_ba_at_end", frame);
}

// ---------------------------------------------------------------------------
// Detection
// ---------------------------------------------------------------------------

void LoopCloser::process(const KeyFramePtr& kfp) {
  KeyFrame* kf = kfp.get();
  Map* map = kf->map;
  if (!map) return;
  const double t0 = nowSeconds();
  std::unique_lock<std::recursive_mutex> lock(map->update_mutex);
  if (kf->bad) return;
  db_->computeBow(kf);
  Candidate cand;
  bool found = false;
  LoopEvent::Type type = LoopEvent::Type::Loop;
  std::shared_ptr<Map> other;
  if (p_.enabled && kf->id - last_loop_kf_ > p_.keyframes_between_loops && map->numKeyFrames() > 10) {
    double min_score = 1.0;
    for (KeyFrame* c : kf->covisibles())
      if (!c->bad && !c->bow.empty()) min_score = std::min(min_score, db_->vocabulary().score(kf->bow, c->bow));
    if (kf->covisibles().empty()) min_score = 0;
    const auto cands = db_->detectLoopCandidates(kf, min_score, true);
    DSLAM_LOG(Debug, "loop detection, keyframe " << kf->id << " (frame " << kf->frame_index << "): min score "
                                                 << min_score << ", " << cands.size() << " candidates");
    if (!cands.empty() && verify(kf, cands, cand)) {
      found = true;
      type = LoopEvent::Type::Loop;
    }
  }
  if (!found && p_.enabled && p_.merge_maps && maps_ && maps_->maps().size() > 1) {
    const auto cands = db_->detectLoopCandidates(kf, 0.0, false);
    if (!cands.empty() && verify(kf, cands, cand)) {
      found = true;
      type = LoopEvent::Type::Merge;
      for (const auto& m : maps_->maps())
        if (m.get() == cand.kf->map) other = m;
    }
  }
  lock.unlock();
  if (found) {
    if (other) {
      // Lock both maps in a fixed order (ids) to avoid deadlocks with tracking.
      Map* a = map;
      Map* b = other.get();
      if (b->id < a->id) std::swap(a, b);
      if (mapper_) mapper_->requestPause();
      {
        std::scoped_lock both(a->update_mutex, b->update_mutex);
        correctLoop(kf, cand, type, other);
      }
    } else {
      if (mapper_) mapper_->requestPause();
      std::lock_guard<std::recursive_mutex> lk(map->update_mutex);
      correctLoop(kf, cand, type, nullptr);
    }
    if (p_.global_ba) globalBundleAdjustment(*map, "global_ba", kf->frame_index);
    if (mapper_) mapper_->resume();
    keyframes_to_second_ba_ = p_.global_ba && p_.global_ba_again_after > 0 ? p_.global_ba_again_after : -1;
    second_ba_map_ = map->id;
  } else if (keyframes_to_second_ba_ > 0 && map->id == second_ba_map_ && --keyframes_to_second_ba_ == 0) {
    keyframes_to_second_ba_ = -1;
    DSLAM_LOG(Info, "second global BA, " << p_.global_ba_again_after << " keyframes after the last loop or merge (keyframe "
                                         << kf->id << ", frame " << kf->frame_index << ")");
    if (mapper_) mapper_->requestPause();
    globalBundleAdjustment(*map, "global_ba", kf->frame_index);
    if (mapper_) mapper_->resume();
  }
  {
    std::lock_guard<std::recursive_mutex> lk(map->update_mutex);
    if (!kf->bad) db_->add(kf);
  }
  if (timer_) timer_->add("loop_closing", kf->frame_index, (nowSeconds() - t0) * 1e3);
}

}  // namespace dslam
