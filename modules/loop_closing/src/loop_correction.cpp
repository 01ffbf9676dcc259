// LoopCloser, correction: map-point fusion, essential-graph optimisation,
// map merging and global bundle adjustment.
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

#include "dslam/core/log.h"
#include "dslam/loop_closing/loop_closer.h"
#include "dslam/tracking/matcher.h"

namespace dslam {

void LoopCloser::correctLoop(KeyFrame* cur, Candidate& c, LoopEvent::Type type, const std::shared_ptr<Map>& other) {
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
  ev.position_sigma_m = c.position_sigma;

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
  {
    StageTimer::Scope t(timer_, "essential_graph", cur->frame_index);
    essentialGraph(map, c.kf, cur, non_corrected, new_links);
  }
  cur->loop_edges[c.kf->id] = c.kf;
  c.kf->loop_edges[cur->id] = cur;
  cur->not_erase = true;
  c.kf->not_erase = true;
  last_loop_kf_ = cur->id;
  map.big_change++;
  (type == LoopEvent::Type::Merge ? merges_ : loops_)++;
  DSLAM_LOG(Info, toString(type) << " closed: keyframe " << cur->id << " (frame " << cur->frame_index << ") with keyframe "
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

void LoopCloser::globalBundleAdjustment(Map& map, const char* stage, int frame) {
  StageTimer::Scope timed(timer_, stage, frame);
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
  opt.reject_outliers = p_.global_ba_reject_outliers;
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
