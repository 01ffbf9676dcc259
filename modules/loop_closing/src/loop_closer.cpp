#include "dslam/loop_closing/loop_closer.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "dslam/core/log.h"
#include "dslam/tracking/matcher.h"

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
      P_int("keyframes_between_loops", d.keyframes_between_loops, "keyframes after a loop before the next detection (ORB-SLAM: 10)", 0),
      P_int("essential_min_weight", d.essential_min_weight, "covisibility weight of essential-graph edges (ORB-SLAM: 100)", 1),
      P_int("pose_graph_iterations", d.pose_graph_iterations, "essential-graph optimisation iterations (ORB-SLAM: 20)", 1),
      P_bool("global_ba", d.global_ba, "full bundle adjustment after each loop or merge (ORB-SLAM2: yes)"),
      P_int("global_ba_iterations", d.global_ba_iterations, "global BA iterations (ORB-SLAM2: 10)", 1),
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
  l.keyframes_between_loops = static_cast<int>(p.getInt("keyframes_between_loops"));
  l.essential_min_weight = static_cast<int>(p.getInt("essential_min_weight"));
  l.pose_graph_iterations = static_cast<int>(p.getInt("pose_graph_iterations"));
  l.global_ba = p.getBool("global_ba");
  l.global_ba_iterations = static_cast<int>(p.getInt("global_ba_iterations"));
  l.merge_maps = p.getBool("merge_maps");
  return l;
}

std::string LoopEvent::json() const {
  std::ostringstream o;
  o.precision(6);
  o << "{\"event\": \"" << type << "\", \"frame\": " << frame << ", \"keyframe\": " << kf << ", \"matched_keyframe\": "
    << other_kf << ", \"map\": " << map << ", \"other_map\": " << other_map << ", \"inliers\": " << inliers
    << ", \"matches\": " << matches << ", \"correction_m\": " << correction_m << ", \"correction_deg\": "
    << correction_deg << "}";
  return o.str();
}

LoopCloser::LoopCloser(const LoopClosingParams& p, std::shared_ptr<Backend> backend,
                       std::shared_ptr<KeyFrameDatabase> db, MapManager* maps, LocalMapper* mapper, StageTimer* timer)
    : p_(p), backend_(std::move(backend)), db_(std::move(db)), maps_(maps), mapper_(mapper), timer_(timer) {}

LoopCloser::~LoopCloser() { stop(); }

void LoopCloser::insertKeyFrame(const KeyFramePtr& kf) {
  {
    std::lock_guard<std::mutex> lk(mtx_);
    queue_.push_back(kf);
  }
  cv_.notify_all();
}

void LoopCloser::processAll() {
  for (;;) {
    KeyFramePtr kf;
    {
      std::lock_guard<std::mutex> lk(mtx_);
      if (queue_.empty()) return;
      kf = queue_.front();
      queue_.pop_front();
    }
    process(kf);
  }
}

void LoopCloser::start() {
  if (thread_.joinable()) return;
  finish_ = false;
  thread_ = std::thread([this] { run(); });
}

void LoopCloser::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lk(mtx_);
    finish_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void LoopCloser::waitIdle() {
  if (!thread_.joinable()) {
    processAll();
    return;
  }
  std::unique_lock<std::mutex> lk(mtx_);
  cv_.wait(lk, [this] { return queue_.empty() && !busy_; });
}

void LoopCloser::run() {
  for (;;) {
    KeyFramePtr kf;
    {
      std::unique_lock<std::mutex> lk(mtx_);
      cv_.wait(lk, [this] { return finish_ || !queue_.empty(); });
      if (queue_.empty()) break;
      kf = queue_.front();
      queue_.pop_front();
      busy_ = true;
    }
    process(kf);
    {
      std::lock_guard<std::mutex> lk(mtx_);
      busy_ = false;
    }
    cv_.notify_all();
  }
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
  std::string type;
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
      type = "loop";
    }
  }
  if (!found && p_.enabled && p_.merge_maps && maps_ && maps_->maps().size() > 1) {
    const auto cands = db_->detectLoopCandidates(kf, 0.0, false);
    if (!cands.empty() && verify(kf, cands, cand)) {
      found = true;
      type = "merge";
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
    if (p_.global_ba) {
      const double tb = nowSeconds();
      globalBundleAdjustment(*map);
      if (timer_) timer_->add("global_ba", kf->frame_index, (nowSeconds() - tb) * 1e3);
    }
    if (mapper_) mapper_->resume();
  }
  {
    std::lock_guard<std::recursive_mutex> lk(map->update_mutex);
    if (!kf->bad) db_->add(kf);
  }
  if (timer_) timer_->add("loop_closing", kf->frame_index, (nowSeconds() - t0) * 1e3);
}

int LoopCloser::countInliers(KeyFrame* cur, KeyFrame* cand, const std::vector<MapPointPtr>& matches, const SE3& T12,
                             std::vector<char>* inlier) const {
  const SE3 T21 = T12.inverse();
  int n = 0;
  if (inlier) inlier->assign(matches.size(), 0);
  auto reprojOk = [](const KeyFrame* kf, const Eigen::Vector3d& Xc, const cv::KeyPoint& kp) {
    if (Xc.z() <= 0) return false;
    const double u = kf->cam.fx * Xc.x() / Xc.z() + kf->cam.cx, v = kf->cam.fy * Xc.y() / Xc.z() + kf->cam.cy;
    const double e2 = (u - kp.pt.x) * (u - kp.pt.x) + (v - kp.pt.y) * (v - kp.pt.y);
    return e2 <= 9.21 * kf->scale->sigma2[kp.octave];
  };
  for (size_t i = 0; i < matches.size(); i++) {
    const MapPointPtr& m2 = matches[i];
    const MapPointPtr& m1 = cur->points[i];
    if (!m2 || !m1 || m1->bad || m2->bad) continue;
    const int j = m2->indexIn(cand);
    if (j < 0) continue;
    const Eigen::Vector3d P1 = cur->T_cw() * m1->pos, P2 = cand->T_cw() * m2->pos;
    if (reprojOk(cur, T12 * P2, cur->keys_un[i]) && reprojOk(cand, T21 * P1, cand->keys_un[j])) {
      n++;
      if (inlier) (*inlier)[i] = 1;
    }
  }
  return n;
}

namespace {
SE3 umeyamaSE3(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  Eigen::Matrix3Xd A(3, src.size()), B(3, dst.size());
  for (size_t i = 0; i < src.size(); i++) {
    A.col(static_cast<Eigen::Index>(i)) = src[i];
    B.col(static_cast<Eigen::Index>(i)) = dst[i];
  }
  const Eigen::Matrix4d T = Eigen::umeyama(A, B, false);
  return SE3(T);
}
}  // namespace

bool LoopCloser::ransacSE3(KeyFrame* cur, KeyFrame* cand, const std::vector<MapPointPtr>& matches, SE3& T12,
                           std::vector<char>& inlier) {
  std::vector<size_t> idx;
  std::vector<Eigen::Vector3d> P1, P2;
  for (size_t i = 0; i < matches.size(); i++) {
    const MapPointPtr& m2 = matches[i];
    const MapPointPtr& m1 = cur->points[i];
    if (!m2 || !m1 || m1->bad || m2->bad || m2->indexIn(cand) < 0) continue;
    idx.push_back(i);
    P1.push_back(cur->T_cw() * m1->pos);
    P2.push_back(cand->T_cw() * m2->pos);
  }
  if (static_cast<int>(idx.size()) < p_.min_inliers) return false;
  std::mt19937 rng(static_cast<uint32_t>(p_.seed ^ static_cast<uint64_t>(cur->id * 7919 + cand->id)));
  std::uniform_int_distribution<size_t> pick(0, idx.size() - 1);
  int best = -1;
  SE3 best_T;
  for (int it = 0; it < p_.ransac_iterations; it++) {
    size_t a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    const SE3 T = umeyamaSE3({P2[a], P2[b], P2[c]}, {P1[a], P1[b], P1[c]});
    const int n = countInliers(cur, cand, matches, T, nullptr);
    if (n > best) {
      best = n;
      best_T = T;
    }
  }
  if (best < p_.min_inliers) return false;
  // Refit on the inliers.
  countInliers(cur, cand, matches, best_T, &inlier);
  std::vector<Eigen::Vector3d> s, d;
  for (size_t k = 0; k < idx.size(); k++)
    if (inlier[idx[k]]) {
      s.push_back(P2[k]);
      d.push_back(P1[k]);
    }
  T12 = s.size() >= 3 ? umeyamaSE3(s, d) : best_T;
  return countInliers(cur, cand, matches, T12, &inlier) >= p_.min_inliers;
}

bool LoopCloser::verify(KeyFrame* cur, const std::vector<KeyFrame*>& cands, Candidate& out) {
  Matcher bow_matcher(0.75f, true);
  Matcher guided;
  for (KeyFrame* cand : cands) {
    if (cand->bad) continue;
    Candidate c;
    c.kf = cand;
    const int nbow = bow_matcher.searchByBoW(cur, cand, c.matches);
    DSLAM_LOG(Debug, "  candidate " << cand->id << " (frame " << cand->frame_index << "): " << nbow << " BoW matches");
    if (nbow < p_.min_bow_matches) continue;
    std::vector<char> inl;
    if (!ransacSE3(cur, cand, c.matches, c.T12, inl)) {
      DSLAM_LOG(Debug, "  candidate " << cand->id << ": RANSAC failed");
      continue;
    }
    for (size_t i = 0; i < c.matches.size(); i++)
      if (!inl[i]) c.matches[i].reset();
    guided.searchBySE3(cur, cand, c.matches, c.T12, 7.5f);
    if (!ransacSE3(cur, cand, c.matches, c.T12, inl)) continue;
    for (size_t i = 0; i < c.matches.size(); i++)
      if (!inl[i]) c.matches[i].reset();
    c.inliers = static_cast<int>(std::count(inl.begin(), inl.end(), 1));
    // The loop keyframe and its neighbours' points, projected with the corrected pose.
    std::set<int64_t> seen;
    std::vector<KeyFrame*> group = cand->covisibles();
    group.push_back(cand);
    for (KeyFrame* k : group)
      for (const auto& mp : k->points)
        if (mp && !mp->bad && mp->active && seen.insert(mp->id).second) c.loop_points.push_back(mp);
    const SE3 Tcw_corr = c.T12 * cand->T_cw();
    std::vector<MapPointPtr> matched = c.matches;
    guided.searchByProjection(cur, Tcw_corr, c.loop_points, matched, 10);
    c.total = static_cast<int>(std::count_if(matched.begin(), matched.end(), [](const MapPointPtr& p) { return p != nullptr; }));
    DSLAM_LOG(Debug, "  candidate " << cand->id << ": " << c.inliers << " inliers, " << c.total << " matches with its neighbourhood");
    if (c.total < p_.min_total_matches) continue;
    // Consistency: covisible keyframes of the current one must agree with the
    // same correction (ORB-SLAM3 covisibility check instead of waiting for
    // consecutive keyframes).
    int agree = 1;
    const SE3 T_wc_cur = cur->T_wc();
    for (KeyFrame* k : cur->bestCovisibles(5)) {
      if (agree >= p_.consistency) break;
      if (k->bad || k->map != cur->map) continue;
      const SE3 Tkw_corr = k->T_cw() * T_wc_cur * Tcw_corr;
      std::vector<MapPointPtr> mk(k->size());
      const int n = guided.searchByProjection(k, Tkw_corr, c.loop_points, mk, 10);
      if (n >= p_.min_total_matches / 2) agree++;
    }
    DSLAM_LOG(Debug, "  candidate " << cand->id << ": " << agree << " keyframes agree");
    if (agree < p_.consistency && !(p_.strong_inliers > 0 && c.inliers >= p_.strong_inliers)) continue;
    c.matches = matched;
    out = std::move(c);
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------
// Correction
// ---------------------------------------------------------------------------

void LoopCloser::correctLoop(KeyFrame* cur, Candidate& c, const std::string& type, const std::shared_ptr<Map>& other) {
  Map& map = *cur->map;
  LoopEvent ev;
  ev.type = type;
  ev.frame = cur->frame_index;
  ev.kf = cur->id;
  ev.other_kf = c.kf->id;
  ev.map = map.id;
  ev.other_map = c.kf->map->id;
  ev.inliers = c.inliers;
  ev.matches = c.total;

  SE3 Tcw_corr;
  if (other) {
    // Bring the other map into this map's frame so that the candidate's pose
    // agrees with the current keyframe through T12. The event reports the
    // transform between the two maps' frames.
    const SE3 T_wA_wB = cur->T_wc() * c.T12 * c.kf->T_cw();
    map.absorb(*other, T_wA_wB);
    if (maps_) maps_->eraseMap(other);
    Tcw_corr = cur->T_cw();
    ev.correction_m = T_wA_wB.translation().norm();
    ev.correction_deg = T_wA_wB.angle() * 180.0 / M_PI;
  } else {
    Tcw_corr = c.T12 * c.kf->T_cw();
    const SE3 old_Tcw = cur->T_cw();
    ev.correction_m = (Tcw_corr.inverse().translation() - old_Tcw.inverse().translation()).norm();
    ev.correction_deg = (Tcw_corr * old_Tcw.inverse()).angle() * 180.0 / M_PI;
  }

  cur->updateConnections();
  std::vector<KeyFrame*> group = cur->covisibles();
  group.push_back(cur);
  std::sort(group.begin(), group.end(), [](KeyFrame* a, KeyFrame* b) { return a->id < b->id; });
  std::map<int64_t, SE3> non_corrected, corrected;
  const SE3 T_wc_cur = cur->T_wc();
  for (KeyFrame* k : group) {
    non_corrected[k->id] = k->T_cw();
    corrected[k->id] = k->T_cw() * T_wc_cur * Tcw_corr;
  }
  // Points seen by the group move with their reference keyframe of the group.
  std::map<int64_t, int64_t> corrected_ref;
  for (KeyFrame* k : group)
    for (const auto& mp : k->points) {
      if (!mp || mp->bad || mp->corrected_by_kf == cur->id) continue;
      mp->pos = corrected[k->id].inverse() * (non_corrected[k->id] * mp->pos);
      mp->corrected_by_kf = cur->id;
      corrected_ref[mp->id] = k->id;
      mp->updateNormalAndDepth();
    }
  for (KeyFrame* k : group) k->setPose(corrected[k->id]);
  for (KeyFrame* k : group) k->updateConnections();

  // Fuse the loop matches into the current keyframe.
  for (size_t i = 0; i < c.matches.size(); i++) {
    const MapPointPtr& loop_mp = c.matches[i];
    if (!loop_mp || loop_mp->bad) continue;
    MapPointPtr cur_mp = cur->points[i];
    if (cur_mp && !cur_mp->bad) {
      if (cur_mp != loop_mp) cur_mp->replaceWith(loop_mp);
    } else {
      loop_mp->addObservation(cur, static_cast<int>(i));
      cur->addPoint(loop_mp, static_cast<int>(i));
      loop_mp->computeDistinctiveDescriptor();
    }
  }
  // Fuse the loop points into the whole group (ORB-SLAM SearchAndFuse).
  Matcher fuser(0.8f, true);
  for (KeyFrame* k : group) {
    if (k->bad) continue;
    std::vector<MapPointPtr> replace;
    fuser.fuse(k, k->T_cw(), c.loop_points, 4, replace);
    for (size_t j = 0; j < replace.size(); j++)
      if (replace[j] && !replace[j]->bad && !c.loop_points[j]->bad) replace[j]->replaceWith(c.loop_points[j]);
  }
  // New links created by the loop.
  std::map<int64_t, std::set<int64_t>> new_links;
  std::set<int64_t> group_ids;
  for (KeyFrame* k : group) group_ids.insert(k->id);
  for (KeyFrame* k : group) {
    if (k->bad) continue;
    std::set<int64_t> before;
    for (KeyFrame* n : k->covisibles()) before.insert(n->id);
    k->updateConnections();
    for (KeyFrame* n : k->covisibles())
      if (!before.count(n->id) && !group_ids.count(n->id)) new_links[k->id].insert(n->id);
  }
  const double tp = nowSeconds();
  essentialGraph(map, c.kf, cur, non_corrected, new_links);
  if (timer_) timer_->add("essential_graph", cur->frame_index, (nowSeconds() - tp) * 1e3);
  cur->loop_edges[c.kf->id] = c.kf;
  c.kf->loop_edges[cur->id] = cur;
  cur->not_erase = true;
  c.kf->not_erase = true;
  last_loop_kf_ = cur->id;
  map.big_change++;
  (type == "merge" ? merges_ : loops_)++;
  DSLAM_LOG(Info, type << " closed: keyframe " << cur->id << " (frame " << cur->frame_index << ") with keyframe "
                       << c.kf->id << ", " << c.inliers << " inliers, " << c.total << " matches, correction "
                       << ev.correction_m << " m / " << ev.correction_deg << " deg");
  if (on_event_) on_event_(ev);
}

void LoopCloser::essentialGraph(Map& map, KeyFrame* fixed_kf, KeyFrame* cur, const std::map<int64_t, SE3>& non_corrected,
                                const std::map<int64_t, std::set<int64_t>>& new_links) {
  PoseGraph g;
  std::map<int64_t, int> node;
  std::vector<KeyFrame*> kfs;
  std::vector<SE3> init_cw;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf->bad) continue;
    node[id] = static_cast<int>(g.nodes.size());
    g.nodes.push_back({id, kf->T_wc(), kf.get() == fixed_kf});
    kfs.push_back(kf.get());
    init_cw.push_back(kf->T_cw());
  }
  // Pose used for measurements: the non-corrected one where it exists.
  auto measPose = [&](KeyFrame* k) {
    auto it = non_corrected.find(k->id);
    return it != non_corrected.end() ? it->second : k->T_cw();
  };
  std::set<std::pair<int64_t, int64_t>> inserted;
  auto addEdge = [&](KeyFrame* a, KeyFrame* b, const SE3& Taw, const SE3& Tbw) {
    if (!node.count(a->id) || !node.count(b->id) || a == b) return;
    const auto key = std::minmax(a->id, b->id);
    if (!inserted.insert(key).second) return;
    PoseGraphEdge e;
    e.from = node[a->id];
    e.to = node[b->id];
    e.T_from_to = Taw * Tbw.inverse();  // T_wc(a)^-1 T_wc(b)
    g.edges.push_back(e);
  };
  // Loop connections: measured with the corrected poses.
  for (const auto& [i, js] : new_links) {
    KeyFrame* ki = map.keyframe(i).get();
    if (!ki || ki->bad) continue;
    for (int64_t j : js) {
      KeyFrame* kj = map.keyframe(j).get();
      if (!kj || kj->bad) continue;
      if (!(ki == cur && kj == fixed_kf) && ki->weight(kj) < p_.essential_min_weight) continue;
      addEdge(ki, kj, ki->T_cw(), kj->T_cw());
    }
  }
  for (KeyFrame* k : kfs) {
    if (k->parent && !k->parent->bad) addEdge(k, k->parent, measPose(k), measPose(k->parent));
    for (const auto& [lid, l] : k->loop_edges)
      if (!l->bad) addEdge(k, l, measPose(k), measPose(l));
    for (KeyFrame* n : k->covisiblesByWeight(p_.essential_min_weight))
      if (!n->bad) addEdge(k, n, measPose(k), measPose(n));
  }
  // The new loop edge itself.
  addEdge(cur, fixed_kf, cur->T_cw(), fixed_kf->T_cw());
  PoseGraphOptions opt;
  opt.max_iterations = p_.pose_graph_iterations;
  const PoseGraphResult r = backend_->optimizePoseGraph(g, opt);
  if (!r.success) {
    DSLAM_LOG(Warn, "essential graph optimisation failed: " << r.message);
    return;
  }
  std::map<int64_t, std::pair<SE3, SE3>> change;  // kf id -> (initial T_cw, new T_wc)
  for (size_t i = 0; i < kfs.size(); i++) {
    change[kfs[i]->id] = {init_cw[i], g.nodes[i].T_wc};
    kfs[i]->setPose(g.nodes[i].T_wc.inverse());
  }
  for (const auto& [pid, mp] : map.points()) {
    if (mp->bad) continue;
    KeyFrame* ref = mp->ref_kf;
    if (!ref || !change.count(ref->id)) continue;
    const auto& [Tcw0, Twc1] = change[ref->id];
    mp->pos = Twc1 * (Tcw0 * mp->pos);
    mp->updateNormalAndDepth();
  }
}

void LoopCloser::globalBundleAdjustment(Map& map) {
  BAProblem prob;
  std::vector<KeyFrame*> kfs;
  std::vector<MapPointPtr> pts;
  {
    std::lock_guard<std::recursive_mutex> lk(map.update_mutex);
    std::map<int64_t, int> kidx;
    const int64_t origin = map.origin() ? map.origin()->id : -1;
    for (const auto& [id, kf] : map.keyframes()) {
      if (kf->bad) continue;
      kidx[id] = static_cast<int>(kfs.size());
      kfs.push_back(kf.get());
      prob.keyframes.push_back({id, kf->T_cw(), id == origin});
    }
    if (kfs.empty()) return;
    const auto& c = kfs.front()->cam;
    prob.camera = {c.fx, c.fy, c.cx, c.cy, c.bf};
    for (const auto& [pid, mp] : map.points()) {
      if (mp->bad) continue;
      const int pi = static_cast<int>(pts.size());
      bool any = false;
      for (const auto& [kid, o] : mp->observations()) {
        auto it = kidx.find(kid);
        if (it == kidx.end()) continue;
        const auto& kp = o.first->keys_un[o.second];
        BAObservation ob;
        ob.kf = it->second;
        ob.pt = pi;
        ob.uv = {kp.pt.x, kp.pt.y};
        ob.u_right = o.first->u_right[o.second];
        ob.information = o.first->scale->inv_sigma2[kp.octave];
        prob.observations.push_back(ob);
        any = true;
      }
      if (!any) continue;
      pts.push_back(mp);
      prob.points.push_back({pid, mp->pos, false});
    }
  }
  BAOptions opt;
  opt.max_iterations = p_.global_ba_iterations;
  opt.reject_outliers = false;
  const BAResult r = backend_->bundleAdjust(prob, opt);
  if (!r.success) {
    DSLAM_LOG(Warn, "global BA failed: " << r.message);
    return;
  }
  std::lock_guard<std::recursive_mutex> lk(map.update_mutex);
  for (size_t i = 0; i < kfs.size(); i++)
    if (!kfs[i]->bad) kfs[i]->setPose(prob.keyframes[i].T_cw);
  for (size_t i = 0; i < pts.size(); i++)
    if (!pts[i]->bad) {
      pts[i]->pos = prob.points[i].X_w;
      pts[i]->updateNormalAndDepth();
    }
  map.big_change++;
  DSLAM_LOG(Debug, "global BA: " << kfs.size() << " keyframes, " << pts.size() << " points, cost " << r.initial_cost
                                 << " -> " << r.final_cost);
}

}  // namespace dslam
