#include "dslam/mapping/local_mapper.h"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>

#include "dslam/core/log.h"
#include "dslam/tracking/matcher.h"

namespace dslam {

std::vector<ParamSpec> LocalMapperParams::specs() {
  LocalMapperParams d;
  return {
      P_int("triangulation_neighbours", d.triangulation_neighbours, "covisible keyframes used to triangulate new points (ORB-SLAM2: 10 stereo/RGB-D)", 1),
      P_double("kf_culling_redundancy", d.kf_culling_redundancy, "cull a keyframe when more than this fraction of its points is seen by kf_culling_min_obs others (ORB-SLAM2: 0.9)", 0, 1),
      P_int("kf_culling_min_obs", d.kf_culling_min_obs, "observations that make a point redundant (ORB-SLAM2: 3)", 1),
      P_double("found_ratio_min", d.found_ratio_min, "cull a recent point found in less than this fraction of the frames predicting it (ORB-SLAM2: 0.25)", 0, 1),
      P_bool("local_ba", d.local_ba, "run local bundle adjustment after each keyframe"),
      P_int("ba_iterations", d.ba_iterations, "local BA iterations after outlier removal (ORB-SLAM2: 10)", 1),
      P_int("ba_max_keyframes", d.ba_max_keyframes,
            "keyframes optimised by local BA: the new keyframe and its most covisible neighbours (ORB-SLAM2 takes "
            "every covisible keyframe, which grows without bound when a scene makes keyframes pile up)", 2),
      P_int("ba_max_fixed_keyframes", d.ba_max_fixed_keyframes,
            "keyframes held fixed in local BA: of those that see the optimised points, the ones with the most "
            "observations of them (ORB-SLAM2: all)", 1),
      P_double("ba_max_ms", d.ba_max_ms,
               "parallel mode: a local BA that has run this long (wall clock, ms) stops with its best estimate, as "
               "when a new keyframe arrives (ORB-SLAM's abort), so that mapping keeps up when tracking and detection "
               "share the cores; 0 = no limit. Sequential mode never stops a BA early (results do not depend on timing)",
               0),
      P_enum("ba_inactive_points", d.ba_inactive_points_fixed ? "fixed" : "skip", {"fixed", "skip"},
             "map points the persistence filters made inactive (objects gone or dormant): 'fixed' = constant in "
             "local BA, so the observations older keyframes made of them while they were there keep those keyframes "
             "in place, and they are never moved; 'skip' = left out (a keyframe that saw mostly inactive points is "
             "then held by the few others: a plain room whose texture is on the objects bends after a merge)"),
  };
}

LocalMapperParams LocalMapperParams::fromParams(const Params& p) {
  LocalMapperParams m;
  m.triangulation_neighbours = static_cast<int>(p.getInt("triangulation_neighbours"));
  m.kf_culling_redundancy = static_cast<float>(p.getDouble("kf_culling_redundancy"));
  m.kf_culling_min_obs = static_cast<int>(p.getInt("kf_culling_min_obs"));
  m.found_ratio_min = static_cast<float>(p.getDouble("found_ratio_min"));
  m.local_ba = p.getBool("local_ba");
  m.ba_iterations = static_cast<int>(p.getInt("ba_iterations"));
  m.ba_max_keyframes = static_cast<int>(p.getInt("ba_max_keyframes"));
  m.ba_max_fixed_keyframes = static_cast<int>(p.getInt("ba_max_fixed_keyframes"));
  m.ba_max_ms = p.getDouble("ba_max_ms");
  m.ba_inactive_points_fixed = p.getString("ba_inactive_points") == "fixed";
  return m;
}

LocalMapper::LocalMapper(const LocalMapperParams& p, std::shared_ptr<Backend> backend, StageTimer* timer)
    : p_(p), backend_(std::move(backend)), timer_(timer), worker_([this](KeyFramePtr& kf) { processOne(kf); }) {}

LocalMapper::~LocalMapper() { stop(); }

void LocalMapper::insertKeyFrame(const KeyFramePtr& kf) {
  abort_ba_ = true;
  worker_.push(kf);
}

void LocalMapper::processAll() { worker_.drain(); }

void LocalMapper::start() { worker_.start(); }

void LocalMapper::stop() { worker_.stop(); }

void LocalMapper::requestPause() {
  if (!worker_.running()) return;
  std::lock_guard<std::mutex> lk(pause_mtx_);
  if (pauses_++ > 0) return;  // already held
  pause_req_ = true;
  abort_ba_ = true;
  worker_.pause();
}

void LocalMapper::resume() {
  std::lock_guard<std::mutex> lk(pause_mtx_);
  if (pauses_ == 0 || --pauses_ > 0) return;
  pause_req_ = false;
  worker_.resume();
}

void LocalMapper::reset() {
  worker_.clear();
  recent_points_.clear();
  cur_.reset();
}

void LocalMapper::processOne(const KeyFramePtr& kf) {
  cur_ = kf;
  map_ = kf->map;
  if (!map_) return;
  if (gate_fn_) gate_fn_(*kf);
  const int fr = kf->frame_index;
  const double t0 = nowSeconds();
  abort_ba_ = false;
  {
    std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
    if (kf->bad) return;
    if (bow_fn_) bow_fn_(kf.get());
    {
      StageTimer::Scope t(timer_, "keyframe", fr);
      processNewKeyFrame();
    }
    mapPointCulling();
  }
  createNewMapPoints();
  if (queuedKeyFrames() == 0) {
    std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
    searchInNeighbors();
  }
  abort_ba_ = false;
  if (queuedKeyFrames() == 0 && !pause_req_) {
    if (p_.local_ba && map_->numKeyFrames() > 2) {
      StageTimer::Scope t(timer_, "local_ba", fr);
      localBundleAdjustment();
    }
    std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
    keyFrameCulling();
  }
  if (timer_) timer_->add("local_map", fr, (nowSeconds() - t0) * 1e3);
  if (on_kf_) on_kf_(kf);
}

void LocalMapper::processNewKeyFrame() {
  KeyFrame* kf = cur_.get();
  for (size_t i = 0; i < kf->points.size(); i++) {
    MapPointPtr mp = kf->points[i];
    if (!mp) continue;
    if (mp->bad) {
      kf->points[i].reset();
      continue;
    }
    if (!mp->isIn(kf)) {
      mp->addObservation(kf, static_cast<int>(i));
      mp->updateNormalAndDepth();
      mp->computeDistinctiveDescriptor();
    } else {
      recent_points_.push_back(mp);  // created by tracking in this keyframe
    }
  }
  kf->updateConnections();
  map_->addKeyFrame(cur_);
}

void LocalMapper::mapPointCulling() {
  const int64_t kfid = cur_->id;
  const int th_obs = p_.monocular ? 2 : 3;
  for (auto it = recent_points_.begin(); it != recent_points_.end();) {
    MapPointPtr mp = *it;
    if (mp->bad) {
      it = recent_points_.erase(it);
    } else if (mp->foundRatio() < p_.found_ratio_min) {
      mp->setBad();
      it = recent_points_.erase(it);
    } else if (kfid - mp->first_kf_id >= 2 && mp->numObservations() <= th_obs) {
      mp->setBad();
      it = recent_points_.erase(it);
    } else if (kfid - mp->first_kf_id >= 3) {
      it = recent_points_.erase(it);
    } else {
      ++it;
    }
  }
}

namespace {
bool triangulate(const Eigen::Vector3d& xn1, const Eigen::Vector3d& xn2, const Eigen::Matrix<double, 3, 4>& T1,
                 const Eigen::Matrix<double, 3, 4>& T2, Eigen::Vector3d& X) {
  Eigen::Matrix4d A;
  A.row(0) = xn1.x() * T1.row(2) - T1.row(0);
  A.row(1) = xn1.y() * T1.row(2) - T1.row(1);
  A.row(2) = xn2.x() * T2.row(2) - T2.row(0);
  A.row(3) = xn2.y() * T2.row(2) - T2.row(1);
  Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d v = svd.matrixV().col(3);
  if (std::abs(v(3)) < 1e-12) return false;
  X = v.head<3>() / v(3);
  return true;
}
}  // namespace

void LocalMapper::createNewMapPoints() {
  // Snapshot of what we need under the lock; matching runs unlocked (only this
  // thread changes keyframe poses and points; tracking only adds).
  std::vector<KeyFrame*> neighbours;
  {
    std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
    neighbours = cur_->bestCovisibles(static_cast<size_t>(p_.triangulation_neighbours));
  }
  KeyFrame* kf1 = cur_.get();
  Matcher matcher(0.6f, false);
  const auto& sc = *kf1->scale;
  const float ratio_factor = 1.5f * sc.scale_factor;
  for (KeyFrame* kf2 : neighbours) {
    if (queuedKeyFrames() > 0 && kf2 != neighbours.front()) break;
    std::vector<std::pair<int, int>> pairs;
    SE3 T1, T2;
    {
      std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
      if (kf2->bad) continue;
      T1 = kf1->T_cw();
      T2 = kf2->T_cw();
      const double baseline = (kf2->center() - kf1->center()).norm();
      if (!p_.monocular) {
        if (baseline < kf2->cam.bf / kf2->cam.fx) continue;
      } else {
        const float med = kf2->sceneMedianDepth();
        if (med <= 0 || baseline / med < 0.01) continue;
      }
      matcher.searchForTriangulation(kf1, kf2, fundamental12(kf1, kf2), pairs, false);
    }
    const Eigen::Matrix3d R1w = T1.rotation(), R2w = T2.rotation();
    const Eigen::Matrix3d Rw1 = R1w.transpose(), Rw2 = R2w.transpose();
    const Eigen::Matrix<double, 3, 4> P1 = T1.matrix3x4(), P2 = T2.matrix3x4();
    const Eigen::Vector3d O1 = T1.inverse().translation(), O2 = T2.inverse().translation();
    const auto& c1 = kf1->cam;
    const auto& c2 = kf2->cam;
    const float b1 = c1.bf / c1.fx, b2 = c2.bf / c2.fx;
    std::vector<std::tuple<MapPointPtr, int, int>> fresh;
    for (auto [i1, i2] : pairs) {
      const auto& kp1 = kf1->keys_un[i1];
      const auto& kp2 = kf2->keys_un[i2];
      const float ur1 = kf1->u_right[i1], ur2 = kf2->u_right[i2];
      const bool st1 = ur1 >= 0, st2 = ur2 >= 0;
      const Eigen::Vector3d xn1 = backProject(c1, kp1.pt, 1.f), xn2 = backProject(c2, kp2.pt, 1.f);
      const Eigen::Vector3d ray1 = Rw1 * xn1, ray2 = Rw2 * xn2;
      const double cos_rays = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
      double cos_st1 = cos_rays + 1, cos_st2 = cos_rays + 1;
      if (st1) cos_st1 = std::cos(2 * std::atan2(b1 / 2, kf1->depth[i1]));
      if (st2) cos_st2 = std::cos(2 * std::atan2(b2 / 2, kf2->depth[i2]));
      const double cos_st = std::min(cos_st1, cos_st2);
      Eigen::Vector3d X;
      if (cos_rays < cos_st && cos_rays > 0 && (st1 || st2 || cos_rays < 0.9998)) {
        if (!triangulate(xn1, xn2, P1, P2, X)) continue;
      } else if (st1 && cos_st1 < cos_st2) {
        X = Rw1 * (xn1 * kf1->depth[i1]) + O1;
      } else if (st2 && cos_st2 < cos_st1) {
        X = Rw2 * (xn2 * kf2->depth[i2]) + O2;
      } else {
        continue;
      }
      const Eigen::Vector3d X1 = T1 * X, X2 = T2 * X;
      if (X1.z() <= 0 || X2.z() <= 0) continue;
      auto reproj_ok = [&](const Eigen::Vector3d& Xc, const cv::KeyPoint& kp, float ur, bool st,
                           const CameraIntrinsics& c) {
        const double iz = 1.0 / Xc.z();
        const double u = c.fx * Xc.x() * iz + c.cx, v = c.fy * Xc.y() * iz + c.cy;
        double e2 = (u - kp.pt.x) * (u - kp.pt.x) + (v - kp.pt.y) * (v - kp.pt.y);
        const double s2 = sc.sigma2[kp.octave];
        if (!st) return e2 <= 5.991 * s2;
        const double urp = u - c.bf * iz;
        e2 += (urp - ur) * (urp - ur);
        return e2 <= 7.8 * s2;
      };
      if (!reproj_ok(X1, kp1, ur1, st1, c1) || !reproj_ok(X2, kp2, ur2, st2, c2)) continue;
      const double d1 = (X - O1).norm(), d2 = (X - O2).norm();
      if (d1 == 0 || d2 == 0) continue;
      const double ratio_dist = d2 / d1;
      const double ratio_oct = sc.scale[kp1.octave] / sc.scale[kp2.octave];
      if (ratio_dist * ratio_factor < ratio_oct || ratio_dist > ratio_oct * ratio_factor) continue;
      auto mp = std::make_shared<MapPoint>(Map::nextPointId(), X, kf1, map_);
      const auto& m = kf1->meta.empty() ? KeypointMeta{} : kf1->meta[i1];
      mp->class_id = m.class_id;
      mp->object_id = m.object_id;
      mp->label = m.label;
      fresh.emplace_back(mp, i1, i2);
    }
    std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
    if (kf2->bad) continue;
    for (auto& [mp, i1, i2] : fresh) {
      if (kf1->points[i1] || kf2->points[i2]) continue;  // taken meanwhile
      mp->addObservation(kf1, i1);
      mp->addObservation(kf2, i2);
      kf1->addPoint(mp, i1);
      kf2->addPoint(mp, i2);
      mp->computeDistinctiveDescriptor();
      mp->updateNormalAndDepth();
      map_->addPoint(mp);
      recent_points_.push_back(mp);
    }
  }
}

void LocalMapper::searchInNeighbors() {
  KeyFrame* kf = cur_.get();
  const size_t nn = p_.monocular ? 20 : 10;
  std::vector<KeyFrame*> targets;
  for (KeyFrame* k : kf->bestCovisibles(nn)) {
    if (k->bad || k->fuse_target_for_kf == kf->id) continue;
    targets.push_back(k);
    k->fuse_target_for_kf = kf->id;
  }
  const size_t n1 = targets.size();
  for (size_t i = 0; i < n1; i++)
    for (KeyFrame* k2 : targets[i]->bestCovisibles(5)) {
      if (k2->bad || k2->fuse_target_for_kf == kf->id || k2->id == kf->id) continue;
      targets.push_back(k2);
      k2->fuse_target_for_kf = kf->id;
    }
  Matcher matcher;
  for (KeyFrame* t : targets) matcher.fuse(t, kf->validPoints());
  std::vector<MapPointPtr> cands;
  for (KeyFrame* t : targets)
    for (const auto& mp : t->points) {
      if (!mp || mp->bad || mp->fuse_candidate_for_kf == kf->id) continue;
      mp->fuse_candidate_for_kf = kf->id;
      cands.push_back(mp);
    }
  matcher.fuse(kf, cands);
  for (const auto& mp : kf->points)
    if (mp && !mp->bad) {
      mp->computeDistinctiveDescriptor();
      mp->updateNormalAndDepth();
    }
  kf->updateConnections();
}

void LocalMapper::localBundleAdjustment() {
  const double t_start = nowSeconds();  // the time limit counts from here (building the problem included)
  BAProblem prob;
  size_t fixed_count = 0;
  std::vector<KeyFrame*> kfs;
  std::vector<MapPointPtr> pts;
  {
    std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
    KeyFrame* kf = cur_.get();
    if (kf->bad) return;
    std::vector<KeyFrame*> local = {kf};
    kf->ba_local_for_kf = kf->id;
    for (KeyFrame* k : kf->covisibles()) {  // ordered by covisibility weight
      if (static_cast<int>(local.size()) >= p_.ba_max_keyframes) break;
      if (!k->bad) {
        k->ba_local_for_kf = kf->id;
        local.push_back(k);
      }
    }
    for (KeyFrame* k : local)
      for (const auto& mp : k->points)
        if (mp && !mp->bad && (mp->active || p_.ba_inactive_points_fixed) && mp->ba_local_for_kf != kf->id) {
          mp->ba_local_for_kf = kf->id;
          pts.push_back(mp);
        }
    // Fixed keyframes: those seeing local points, the ones with the most such observations first.
    std::map<KeyFrame*, int> seen;
    for (const auto& mp : pts)
      for (const auto& [kid, o] : mp->observations())
        if (o.first->ba_local_for_kf != kf->id && !o.first->bad) seen[o.first]++;
    std::vector<std::pair<int, KeyFrame*>> by_obs;
    for (const auto& [k, n] : seen) by_obs.push_back({n, k});
    std::sort(by_obs.begin(), by_obs.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second->id < b.second->id;
    });
    std::vector<KeyFrame*> fixed;
    for (const auto& [n, k] : by_obs) {
      if (static_cast<int>(fixed.size()) >= p_.ba_max_fixed_keyframes) break;
      k->ba_fixed_for_kf = kf->id;
      fixed.push_back(k);
    }
    std::sort(fixed.begin(), fixed.end(), [](KeyFrame* a, KeyFrame* b) { return a->id < b->id; });
    const int64_t origin_id = map_->origin() ? map_->origin()->id : -1;
    std::map<int64_t, int> kf_index;
    for (KeyFrame* k : local) {
      kf_index[k->id] = static_cast<int>(prob.keyframes.size());
      prob.keyframes.push_back({k->id, k->T_cw(), k->id == origin_id});
      kfs.push_back(k);
    }
    fixed_count = fixed.size();
    for (KeyFrame* k : fixed) {
      kf_index[k->id] = static_cast<int>(prob.keyframes.size());
      prob.keyframes.push_back({k->id, k->T_cw(), true});
      kfs.push_back(k);
    }
    const auto& c = kf->cam;
    prob.camera = {c.fx, c.fy, c.cx, c.cy, c.bf};
    for (size_t pi = 0; pi < pts.size(); pi++) {
      prob.points.push_back({pts[pi]->id, pts[pi]->pos, !pts[pi]->active});
      for (const auto& [kid, o] : pts[pi]->observations()) {
        auto it = kf_index.find(kid);
        if (it == kf_index.end()) continue;
        const auto& kp = o.first->keys_un[o.second];
        BAObservation ob;
        ob.kf = it->second;
        ob.pt = static_cast<int>(pi);
        ob.uv = {kp.pt.x, kp.pt.y};
        ob.u_right = o.first->u_right[o.second];
        ob.information = o.first->scale->inv_sigma2[kp.octave];
        prob.observations.push_back(ob);
      }
    }
  }
  if (prob.observations.empty()) return;
  BAOptions opt;
  opt.max_iterations = p_.ba_iterations;
  if (worker_.running()) {  // parallel: a new keyframe or the time limit stops it (sequential: never)
    opt.abort = &abort_ba_;
    if (p_.ba_max_ms > 0) opt.deadline = t_start + p_.ba_max_ms * 1e-3;
  }
  const BAResult r = backend_->bundleAdjust(prob, opt);
  last_ba_ = {cur_->id,          static_cast<int>(kfs.size() - fixed_count), static_cast<int>(fixed_count),
              static_cast<int>(pts.size()), static_cast<int>(prob.observations.size()), r.iterations,
              r.num_outliers, r.aborted, r.time_ms};
  DSLAM_LOG(Debug, "local BA keyframe " << cur_->id << ": " << kfs.size() - fixed_count << " optimised + " << fixed_count
                                        << " fixed keyframes, " << pts.size() << " points, " << prob.observations.size()
                                        << " observations, " << r.iterations << " iterations, " << r.num_outliers
                                        << " outliers, " << r.time_ms << " ms" << (r.aborted ? " (aborted)" : ""));
  if (!r.success) {
    DSLAM_LOG(Debug, "local BA failed: " << r.message);
    return;
  }
  std::lock_guard<std::recursive_mutex> lk(map_->update_mutex);
  // Outlier observations are removed from the map (ORB-SLAM).
  for (const auto& ob : prob.observations) {
    if (!ob.outlier) continue;
    KeyFrame* k = kfs[ob.kf];
    const MapPointPtr& mp = pts[ob.pt];
    if (mp->bad || k->bad) continue;
    const int idx = mp->indexIn(k);
    if (idx < 0) continue;
    k->erasePoint(idx);
    mp->eraseObservation(k);
  }
  for (size_t i = 0; i < prob.keyframes.size(); i++)
    if (!prob.keyframes[i].fixed && !kfs[i]->bad) kfs[i]->setPose(prob.keyframes[i].T_cw);
  for (size_t i = 0; i < pts.size(); i++) {
    if (pts[i]->bad) continue;
    pts[i]->pos = prob.points[i].X_w;
    pts[i]->updateNormalAndDepth();
  }
}

void LocalMapper::keyFrameCulling() {
  KeyFrame* cur = cur_.get();
  const int th_obs = p_.kf_culling_min_obs;
  const int64_t origin_id = map_->origin() ? map_->origin()->id : -1;
  for (KeyFrame* kf : std::vector<KeyFrame*>(cur->covisibles())) {
    if (kf->id == origin_id || kf->bad || kf->not_erase) continue;
    int redundant = 0, n = 0;
    for (size_t i = 0; i < kf->points.size(); i++) {
      const MapPointPtr& mp = kf->points[i];
      if (!mp || mp->bad) continue;
      if (!p_.monocular && (kf->depth[i] > kf->cam.close_depth || kf->depth[i] < 0)) continue;
      n++;
      if (mp->numObservations() > th_obs) {
        const int level = kf->keys_un[i].octave;
        int nobs = 0;
        for (const auto& [kid, o] : mp->observations()) {
          if (o.first == kf) continue;
          if (o.first->keys_un[o.second].octave <= level + 1 && ++nobs >= th_obs) break;
        }
        if (nobs >= th_obs) redundant++;
      }
    }
    if (n > 0 && redundant > p_.kf_culling_redundancy * n) {
      kf->setBad();
    }
  }
}

}  // namespace dslam
