#include "dslam/tracking/tracker.h"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <set>

#include "dslam/core/log.h"
#include "dslam/tracking/pose_optimizer.h"

namespace dslam {

const char* toString(TrackState s) {
  switch (s) {
    case TrackState::NotInitialized: return "not_initialized";
    case TrackState::Ok: return "ok";
    case TrackState::Lost: return "lost";
  }
  return "?";
}

std::vector<ParamSpec> TrackerParams::specs() {
  TrackerParams d;
  return {
      P_int("init_min_points", d.init_min_points, "usable keypoints needed to initialise the map (ORB-SLAM2: N > 500)", 1),
      P_int("init_min_depth_points", d.init_min_depth_points,
            "of which with depth: each becomes a map point (guards against frames without depth)", 1),
      P_int("min_frames", d.min_frames, "min frames between keyframes when mapping is idle (ORB-SLAM2 mMinFrames)", 0),
      P_int("max_frames", -1, "frames after which a keyframe is due (ORB-SLAM2 mMaxFrames; -1: camera fps)", -1),
      P_double("ref_ratio", d.ref_ratio, "keyframe when tracked points < ratio x reference keyframe points (thRefRatio)", 0, 1),
      P_int("close_tracked_min", d.close_tracked_min, "keyframe if fewer close points are tracked than this... (ORB-SLAM2: 100)", 0),
      P_int("close_untracked_min", d.close_untracked_min, "...and more close points are untracked than this (ORB-SLAM2: 70)", 0),
      P_int("motion_th_rgbd", d.motion_th_rgbd, "motion-model search window in pixels, RGB-D (ORB-SLAM2: 15)", 1),
      P_int("motion_th_stereo", d.motion_th_stereo, "motion-model search window in pixels, stereo (ORB-SLAM2: 7)", 1),
      P_int("local_map_th", d.local_map_th, "local-map search window factor (ORB-SLAM2: 1; 3 is used for RGB-D)", 1),
      P_int("min_inliers", d.min_inliers, "inliers needed for tracking to be OK (ORB-SLAM2: 30)", 1),
      P_int("min_inliers_after_reloc", d.min_inliers_after_reloc, "inliers needed right after relocalisation (ORB-SLAM2: 50)", 1),
      P_int("max_local_keyframes", d.max_local_keyframes, "size limit of the local keyframe set (ORB-SLAM2: 80)", 1),
      P_int("reloc_candidates", d.reloc_candidates, "keyframes tried when relocalising without a vocabulary", 1),
      P_bool("localization_only", d.localization_only, "track against a fixed (loaded) map without creating keyframes"),
      P_int("young_frames", d.young_frames,
            "map points made from keyframes of the last N frames are first checked against the pose from the older "
            "points (0: off)", 0),
      P_int("young_min_older", d.young_min_older, "older matched points needed for that check", 1),
  };
}

TrackerParams TrackerParams::fromParams(const Params& p) {
  TrackerParams t;
  t.init_min_points = static_cast<int>(p.getInt("init_min_points"));
  t.init_min_depth_points = static_cast<int>(p.getInt("init_min_depth_points"));
  t.min_frames = static_cast<int>(p.getInt("min_frames"));
  t.max_frames = static_cast<int>(p.getInt("max_frames"));
  t.ref_ratio = static_cast<float>(p.getDouble("ref_ratio"));
  t.close_tracked_min = static_cast<int>(p.getInt("close_tracked_min"));
  t.close_untracked_min = static_cast<int>(p.getInt("close_untracked_min"));
  t.motion_th_rgbd = static_cast<int>(p.getInt("motion_th_rgbd"));
  t.motion_th_stereo = static_cast<int>(p.getInt("motion_th_stereo"));
  t.local_map_th = static_cast<int>(p.getInt("local_map_th"));
  t.min_inliers = static_cast<int>(p.getInt("min_inliers"));
  t.min_inliers_after_reloc = static_cast<int>(p.getInt("min_inliers_after_reloc"));
  t.max_local_keyframes = static_cast<int>(p.getInt("max_local_keyframes"));
  t.reloc_candidates = static_cast<int>(p.getInt("reloc_candidates"));
  t.localization_only = p.getBool("localization_only");
  t.young_frames = static_cast<int>(p.getInt("young_frames"));
  t.young_min_older = static_cast<int>(p.getInt("young_min_older"));
  return t;
}

Tracker::Tracker(const TrackerParams& p, const CameraIntrinsics& cam, std::shared_ptr<const ScaleLevels> scale,
                 KeyFrameSink* sink)
    : p_(p), cam_(cam), scale_(std::move(scale)), sink_(sink) {}

void Tracker::reset() {
  state_ = TrackState::NotInitialized;
  cur_ = TrackedFrame();
  last_ = TrackedFrame();
  velocity_.reset();
  ref_kf_ = nullptr;
  last_kf_ = nullptr;
  local_kfs_.clear();
  local_points_.clear();
}

void Tracker::forgetMap(const Map* m) {
  for (auto& r : records_)
    if (r.ref && r.ref->map == m) {
      r.ref = nullptr;
      r.lost = true;
    }
}

const char* toString(TrackMethod m) {
  switch (m) {
    case TrackMethod::Init: return "init";
    case TrackMethod::Motion: return "motion";
    case TrackMethod::Reference: return "reference";
    case TrackMethod::Reloc: return "reloc";
    case TrackMethod::None: break;
  }
  return "none";
}

TrackResult Tracker::track(Frame frame) {
  frame_id_++;
  cur_ = TrackedFrame(std::move(frame), cam_, scale_);
  TrackResult res;
  std::unique_lock<std::recursive_mutex> lock(map_->update_mutex);

  if (state_ == TrackState::NotInitialized && p_.localization_only) {
    // A loaded map: the first frames are localised by relocalisation.
    if (map_->numKeyFrames() > 0 && relocalize() && trackLocalMap()) {
      state_ = TrackState::Ok;
      res.method = TrackMethod::Reloc;
      res.relocalized = true;
      velocity_.reset();
      for (size_t i = 0; i < cur_.size(); i++)
        if (cur_.points[i] && cur_.outlier[i]) cur_.points[i].reset();
    }
  } else if (state_ == TrackState::NotInitialized) {
    if (initialize()) {
      res.initialized = true;
      res.keyframe = true;
      res.method = TrackMethod::Init;
      state_ = TrackState::Ok;
    }
  } else {
    bool ok = false;
    if (state_ == TrackState::Ok) {
      // Points fused by local mapping replace the ones matched in the last frame.
      for (auto& p : last_.points)
        if (p && p->replaced) p = MapPoint::resolve(p);
      if (!velocity_ || frame_id_ < last_reloc_frame_ + 2) {
        ok = trackReferenceKeyFrame();
        res.method = TrackMethod::Reference;
      } else {
        ok = trackWithMotionModel();
        res.method = TrackMethod::Motion;
        if (!ok) {
          ok = trackReferenceKeyFrame();
          res.method = TrackMethod::Reference;
        }
      }
    } else {
      ok = relocalize();
      res.method = TrackMethod::Reloc;
      res.relocalized = ok;
    }
    cur_.ref_kf = ref_kf_;
    if (ok) ok = trackLocalMap();
    if (!ok && state_ == TrackState::Ok) {
      const size_t usable = cur_.size() - cur_.f.countLabel(KpLabel::Dynamic);
      DSLAM_LOG(Info, "tracking lost at frame " << cur_.f.index() << ": " << fail_reason_ << " (" << usable << " of "
                                                << cur_.size() << " keypoints usable)");
    }
    state_ = ok ? TrackState::Ok : TrackState::Lost;
    if (ok) {
      velocity_ = (last_.T_cw && cur_.T_cw) ? std::optional<SE3>(*cur_.T_cw * last_.T_cw->inverse()) : std::nullopt;
      // Keypoints without observations are discarded (ORB-SLAM "clean VO matches").
      for (size_t i = 0; i < cur_.size(); i++)
        if (cur_.points[i] && cur_.points[i]->numObservations() < 1) {
          cur_.outlier[i] = 0;
          cur_.points[i].reset();
        }
      if (needNewKeyFrame()) {
        createNewKeyFrame();
        res.keyframe = true;
      }
      // Outliers are not passed to the next frame's motion model.
      for (size_t i = 0; i < cur_.size(); i++)
        if (cur_.points[i] && cur_.outlier[i]) cur_.points[i].reset();
    } else {
      velocity_.reset();
    }
  }

  if (!cur_.ref_kf) cur_.ref_kf = ref_kf_;
  if (state_ == TrackState::Ok && cur_.T_cw && cur_.ref_kf) {
    DSLAM_LOG(Trace, "tracking: frame " << cur_.f.index() << " (" << toString(res.method) << "): " << matches_inliers_
                                        << " inliers, reference keyframe " << cur_.ref_kf->id << ", camera at "
                                        << cur_.T_cw->inverse().translation().transpose() << ", reference at "
                                        << cur_.ref_kf->T_wc().translation().transpose());
    records_.push_back({cur_.f.index(), cur_.f.timestamp(), cur_.ref_kf, *cur_.T_cw * cur_.ref_kf->T_wc(), false});
  } else {
    records_.push_back({cur_.f.index(), cur_.f.timestamp(), nullptr, SE3(), true});
  }
  res.state = state_;
  res.T_cw = state_ == TrackState::Ok ? cur_.T_cw : std::nullopt;
  res.matches = state_ == TrackState::Ok ? matches_inliers_ : 0;
  // The frame's heavy image buffers are not needed by the next frame.
  cur_.f.input.image.release();
  cur_.f.input.image_right.release();
  cur_.f.input.depth.release();
  cur_.f.gray.release();
  cur_.f.gray_right.release();
  last_ = std::move(cur_);
  return res;
}

bool Tracker::createPointFromDepth(KeyFrame* kf, size_t i) {
  Eigen::Vector3d Xw;
  if (!cur_.unprojectStereo(i, Xw)) return false;
  auto mp = std::make_shared<MapPoint>(Map::nextPointId(), Xw, kf, map_.get());
  const auto& m = cur_.f.meta.empty() ? KeypointMeta{} : cur_.f.meta[i];
  mp->class_id = m.class_id;
  mp->object_id = m.object_id;
  mp->label = m.label;
  mp->addObservation(kf, static_cast<int>(i));
  kf->addPoint(mp, static_cast<int>(i));
  mp->computeDistinctiveDescriptor();
  mp->updateNormalAndDepth();
  map_->addPoint(mp);
  cur_.points[i] = mp;
  return true;
}

bool Tracker::initialize() {
  int usable = 0, with_depth = 0;
  for (size_t i = 0; i < cur_.size(); i++) {
    if (!cur_.usable(i)) continue;
    usable++;
    with_depth += cur_.f.depth.size() > i && cur_.f.depth[i] > 0;
  }
  if (usable <= p_.init_min_points || with_depth < p_.init_min_depth_points) return false;
  cur_.T_cw = SE3();
  auto kf = std::make_shared<KeyFrame>(Map::nextKeyFrameId(), cur_.f, *cur_.T_cw, cam_, scale_, map_.get());
  kf_frame_[kf->id] = frame_id_;
  map_->addKeyFrame(kf);
  for (size_t i = 0; i < cur_.size(); i++) {
    if (!cur_.usable(i) || cur_.f.depth[i] <= 0) continue;
    createPointFromDepth(kf.get(), i);
  }
  DSLAM_LOG(Info, "map " << map_->id << " initialised with " << map_->numPoints() << " points at frame "
                         << cur_.f.index());
  sink_->insertKeyFrame(kf);
  last_kf_frame_ = frame_id_;
  last_kf_ = kf.get();
  ref_kf_ = kf.get();
  cur_.ref_kf = kf.get();
  local_kfs_ = {kf.get()};
  local_points_.clear();
  for (auto& [id, p] : map_->points()) local_points_.push_back(p);
  matches_inliers_ = static_cast<int>(map_->numPoints());
  return true;
}

void Tracker::updateLastFrame() {
  // The last frame's pose relative to its reference keyframe (which local
  // mapping may have moved).
  if (!last_.T_cw || records_.empty()) return;
  const Record& r = records_.back();
  if (r.lost || !r.ref || r.ref->bad) return;
  last_.T_cw = r.T_cr * r.ref->T_cw();
}

int Tracker::optimizePose() {
  std::vector<PoseObservation> obs;
  std::vector<size_t> idx;
  obs.reserve(cur_.size());
  for (size_t i = 0; i < cur_.size(); i++) {
    const auto& mp = cur_.points[i];
    if (!mp) continue;
    PoseObservation o;
    o.Xw = mp->pos;
    o.uv = {cur_.f.keypoints_un[i].pt.x, cur_.f.keypoints_un[i].pt.y};
    o.u_right = cur_.hasStereo(i) ? cur_.f.u_right[i] : -1.0;
    o.information = scale_->inv_sigma2[cur_.f.keypoints_un[i].octave];
    obs.push_back(o);
    idx.push_back(i);
  }
  if (obs.size() < 3) return 0;
  PoseOptimizerParams pp;
  pp.fx = cam_.fx;
  pp.fy = cam_.fy;
  pp.cx = cam_.cx;
  pp.cy = cam_.cy;
  pp.bf = cam_.bf;
  std::vector<char> out;
  SE3 T = *cur_.T_cw;
  std::vector<char> young(obs.size(), 0);
  if (p_.young_frames > 0)  // points of the keyframes of the last young_frames frames
    for (size_t k = 0; k < idx.size(); k++) {
      const auto it = kf_frame_.find(cur_.points[idx[k]]->first_kf_id);
      young[k] = it != kf_frame_.end() && it->second > frame_id_ - p_.young_frames;
    }
  const auto r = dslam::optimizePoseOlderFirst(T, obs, young, p_.young_min_older, out, pp);
  cur_.T_cw = T;
  for (size_t k = 0; k < idx.size(); k++) cur_.outlier[idx[k]] = out[k];
  return r.inliers;
}

int Tracker::discardOutliers() {
  int in_map = 0;
  for (size_t i = 0; i < cur_.size(); i++) {
    auto& mp = cur_.points[i];
    if (!mp) continue;
    if (cur_.outlier[i]) {
      mp->track_in_view = false;
      mp->last_frame_seen = frame_id_;
      mp.reset();
      cur_.outlier[i] = 0;
    } else if (mp->numObservations() > 0) {
      in_map++;
    }
  }
  return in_map;
}

bool Tracker::trackReferenceKeyFrame() {
  if (!ref_kf_ || ref_kf_->bad) return false;
  std::fill(cur_.points.begin(), cur_.points.end(), nullptr);
  if (bow_fn_ && cur_.bow.empty()) bow_fn_(cur_);
  Matcher m(0.7f, true);
  const int n = m.searchByBoW(ref_kf_, cur_);
  if (n < 15) return fail("reference keyframe: ", n, " BoW matches < 15");
  cur_.T_cw = last_.T_cw ? *last_.T_cw : ref_kf_->T_cw();
  optimizePose();
  const int in = discardOutliers();
  return in >= 10 || fail("reference keyframe: ", in, " inliers < 10");
}

bool Tracker::trackWithMotionModel() {
  updateLastFrame();
  if (!last_.T_cw) return false;
  cur_.T_cw = *velocity_ * *last_.T_cw;
  std::fill(cur_.points.begin(), cur_.points.end(), nullptr);
  const bool stereo = cam_.bf > 0;
  const int th = isStereoRig() ? p_.motion_th_stereo : p_.motion_th_rgbd;
  Matcher m(0.9f, true);
  int n = m.searchByProjection(cur_, last_, static_cast<float>(th), stereo);
  if (n < 20) {
    std::fill(cur_.points.begin(), cur_.points.end(), nullptr);
    n = m.searchByProjection(cur_, last_, static_cast<float>(2 * th), stereo);
  }
  if (n < 20) return fail("motion model: ", n, " projection matches < 20");
  optimizePose();
  const int in = discardOutliers();
  return in >= 10 || fail("motion model: ", in, " inliers < 10");
}

bool Tracker::isInFrustum(MapPoint& mp, float view_cos_limit) {
  mp.track_in_view = false;
  const Eigen::Vector3d Xc = *cur_.T_cw * mp.pos;
  if (Xc.z() < 0) return false;
  const float invz = static_cast<float>(1.0 / Xc.z());
  const float u = cam_.fx * Xc.x() * invz + cam_.cx;
  const float v = cam_.fy * Xc.y() * invz + cam_.cy;
  if (!cam_.bounds.contains(u, v)) return false;
  const Eigen::Vector3d PO = mp.pos - cur_.center();
  const float d = static_cast<float>(PO.norm());
  if (!mp.inScaleRange(d)) return false;
  const float view_cos = static_cast<float>(PO.dot(mp.normal)) / d;
  if (view_cos < view_cos_limit) return false;
  mp.track_in_view = true;
  mp.track_proj_x = u;
  mp.track_proj_y = v;
  mp.track_proj_xr = u - cam_.bf * invz;
  mp.track_scale_level = mp.predictScale(d, scale_->log_scale_factor, scale_->n_levels);
  mp.track_view_cos = view_cos;
  return true;
}

void Tracker::updateLocalMap() {
  // Keyframes observing the current matches, weighted by shared points.
  std::map<int64_t, std::pair<KeyFrame*, int>> counter;
  for (size_t i = 0; i < cur_.size(); i++) {
    auto& mp = cur_.points[i];
    if (!mp) continue;
    if (mp->bad) {
      mp.reset();
      continue;
    }
    for (const auto& [kid, o] : mp->observations()) {
      auto& c = counter[kid];
      c.first = o.first;
      c.second++;
    }
  }
  if (counter.empty()) return;
  local_kfs_.clear();
  int best = 0;
  KeyFrame* best_kf = nullptr;
  for (const auto& [kid, c] : counter) {
    if (c.first->bad) continue;
    if (c.second > best) {
      best = c.second;
      best_kf = c.first;
    }
    local_kfs_.push_back(c.first);
    c.first->track_reference_for_frame = frame_id_;
  }
  // Neighbours: best covisibles, children and parent of the first set.
  const size_t n0 = local_kfs_.size();
  for (size_t k = 0; k < n0 && static_cast<int>(local_kfs_.size()) < p_.max_local_keyframes; k++) {
    KeyFrame* kf = local_kfs_[k];
    for (KeyFrame* nb : kf->bestCovisibles(10)) {
      if (!nb->bad && nb->track_reference_for_frame != frame_id_) {
        local_kfs_.push_back(nb);
        nb->track_reference_for_frame = frame_id_;
        break;
      }
    }
    for (const auto& [cid, ch] : kf->children) {
      if (!ch->bad && ch->track_reference_for_frame != frame_id_) {
        local_kfs_.push_back(ch);
        ch->track_reference_for_frame = frame_id_;
        break;
      }
    }
    if (kf->parent && kf->parent->track_reference_for_frame != frame_id_) {
      local_kfs_.push_back(kf->parent);
      kf->parent->track_reference_for_frame = frame_id_;
    }
  }
  if (best_kf) {
    ref_kf_ = best_kf;
    cur_.ref_kf = best_kf;
  }
  // Local points.
  local_points_.clear();
  for (KeyFrame* kf : local_kfs_)
    for (const auto& mp : kf->points) {
      if (!mp || mp->bad || mp->track_reference_for_frame == frame_id_) continue;
      local_points_.push_back(mp);
      mp->track_reference_for_frame = frame_id_;
    }
}

void Tracker::searchLocalPoints() {
  for (auto& mp : cur_.points) {
    if (!mp) continue;
    if (mp->bad) {
      mp.reset();
      continue;
    }
    mp->n_visible++;
    mp->last_frame_seen = frame_id_;
    mp->track_in_view = false;
  }
  int to_match = 0;
  for (auto& mp : local_points_) {
    if (mp->last_frame_seen == frame_id_ || mp->bad || !mp->active) continue;
    if (isInFrustum(*mp, 0.5f)) {
      mp->n_visible++;
      to_match++;
    }
  }
  if (to_match == 0) return;
  float th = static_cast<float>(p_.local_map_th);
  if (cam_.bf > 0 && !isStereoRig()) th = 3;  // RGB-D (ORB-SLAM2)
  if (frame_id_ < last_reloc_frame_ + 2) th = 5;
  matcher_.searchByProjection(cur_, local_points_, th);
}

bool Tracker::trackLocalMap() {
  updateLocalMap();
  searchLocalPoints();
  optimizePose();
  matches_inliers_ = 0;
  for (size_t i = 0; i < cur_.size(); i++) {
    auto& mp = cur_.points[i];
    if (!mp) continue;
    if (!cur_.outlier[i]) {
      mp->n_found++;
      if (mp->numObservations() > 0) matches_inliers_++;
    } else if (isStereoRig()) {
      mp.reset();
      cur_.outlier[i] = 0;
    }
  }
  if (frame_id_ < last_reloc_frame_ + p_.max_frames && matches_inliers_ < p_.min_inliers_after_reloc)
    return fail("local map: ", matches_inliers_, " inliers < ", p_.min_inliers_after_reloc, " (just relocalised)");
  return matches_inliers_ >= p_.min_inliers ||
         fail("local map: ", matches_inliers_, " inliers < ", p_.min_inliers);
}

bool Tracker::relocalize() {
  std::vector<KeyFrame*> cands;
  if (bow_fn_ && cur_.bow.empty()) bow_fn_(cur_);
  if (reloc_fn_) cands = reloc_fn_(cur_);
  if (cands.empty()) {
    // Without a keyframe database: the most recent keyframes of the map.
    const auto& kfs = map_->keyframes();
    for (auto it = kfs.rbegin(); it != kfs.rend() && static_cast<int>(cands.size()) < p_.reloc_candidates; ++it)
      if (!it->second->bad) cands.push_back(it->second.get());
  }
  Matcher m(0.75f, true);
  for (KeyFrame* kf : cands) {
    if (kf->bad) continue;
    std::fill(cur_.points.begin(), cur_.points.end(), nullptr);
    std::fill(cur_.outlier.begin(), cur_.outlier.end(), 0);
    if (m.searchByBoW(kf, cur_) < 15) continue;
    std::vector<cv::Point3f> X;
    std::vector<cv::Point2f> x;
    std::vector<size_t> idx;
    for (size_t i = 0; i < cur_.size(); i++)
      if (cur_.points[i]) {
        const auto& p = cur_.points[i]->pos;
        X.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
        x.push_back(cur_.f.keypoints_un[i].pt);
        idx.push_back(i);
      }
    cv::Mat K = (cv::Mat_<double>(3, 3) << cam_.fx, 0, cam_.cx, 0, cam_.fy, cam_.cy, 0, 0, 1);
    cv::Mat rvec, tvec;
    std::vector<int> inl;
    if (!cv::solvePnPRansac(X, x, K, cv::noArray(), rvec, tvec, false, 300, 5.991f, 0.99, inl, cv::SOLVEPNP_EPNP) ||
        inl.size() < 10)
      continue;
    cv::Mat R;
    cv::Rodrigues(rvec, R);
    Eigen::Matrix3d Re;
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) Re(r, c) = R.at<double>(r, c);
    cur_.T_cw = SE3(Re, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
    std::vector<char> is_in(idx.size(), 0);
    for (int k : inl) is_in[k] = 1;
    for (size_t k = 0; k < idx.size(); k++)
      if (!is_in[k]) cur_.points[idx[k]].reset();
    int good = optimizePose();
    if (good < 10) continue;
    for (size_t i = 0; i < cur_.size(); i++)
      if (cur_.outlier[i]) cur_.points[i].reset();
    if (good < 50) {
      std::set<const MapPoint*> found;
      for (auto& p : cur_.points)
        if (p) found.insert(p.get());
      const int extra = matcher_.searchByProjection(cur_, kf, found, 10, 100);
      if (extra + good >= 50) good = optimizePose();
    }
    if (good >= 50) {
      for (size_t i = 0; i < cur_.size(); i++)
        if (cur_.outlier[i]) {
          cur_.points[i].reset();
          cur_.outlier[i] = 0;
        }
      ref_kf_ = kf;
      last_reloc_frame_ = frame_id_;
      DSLAM_LOG(Info, "relocalised frame " << cur_.f.index() << " against keyframe " << kf->id << " (" << good
                                           << " inliers)");
      return true;
    }
  }
  cur_.T_cw.reset();
  return false;
}

bool Tracker::needNewKeyFrame() {
  if (p_.localization_only || !sink_ || sink_->isStopped()) return false;
  const int nkfs = static_cast<int>(map_->numKeyFrames());
  if (frame_id_ < last_reloc_frame_ + p_.max_frames && nkfs > p_.max_frames) return false;
  const int min_obs = nkfs <= 2 ? 2 : 3;
  const int ref_matches = ref_kf_ ? ref_kf_->trackedPoints(min_obs) : 0;
  const bool idle = sink_->acceptsKeyFrames();
  int tracked_close = 0, untracked_close = 0;
  for (size_t i = 0; i < cur_.size(); i++) {
    const float z = i < cur_.f.depth.size() ? cur_.f.depth[i] : -1.f;
    if (z > 0 && z < cam_.close_depth && cur_.usable(i)) {
      if (cur_.points[i] && !cur_.outlier[i])
        tracked_close++;
      else
        untracked_close++;
    }
  }
  const bool need_close = tracked_close < p_.close_tracked_min && untracked_close > p_.close_untracked_min;
  const float th_ref = nkfs < 2 ? 0.4f : p_.ref_ratio;
  const bool c1a = frame_id_ >= last_kf_frame_ + p_.max_frames;
  const bool c1b = frame_id_ >= last_kf_frame_ + p_.min_frames && idle;
  const bool c1c = matches_inliers_ < ref_matches * 0.25f || need_close;
  const bool c2 = (matches_inliers_ < ref_matches * th_ref || need_close) && matches_inliers_ > 15;
  DSLAM_LOG(Trace, "kf decision frame " << cur_.f.index() << ": inliers " << matches_inliers_ << " ref " << ref_matches
                                        << " close tracked/untracked " << tracked_close << "/" << untracked_close);
  if (force_kf_ && matches_inliers_ > 15 && !sink_->isStopped()) {
    force_kf_ = false;
    return true;
  }
  if ((c1a || c1b || c1c) && c2) {
    if (idle) return true;
    sink_->interruptBA();
    return sink_->queuedKeyFrames() < 3;
  }
  return false;
}

void Tracker::createNewKeyFrame() {
  auto kf = std::make_shared<KeyFrame>(Map::nextKeyFrameId(), cur_.f, *cur_.T_cw, cam_, scale_, map_.get());
  kf_frame_[kf->id] = frame_id_;
  // Matched points become the keyframe's associations (observations are added by local mapping).
  for (size_t i = 0; i < cur_.size(); i++)
    if (cur_.points[i] && !cur_.outlier[i]) kf->points[i] = cur_.points[i];
  ref_kf_ = kf.get();
  cur_.ref_kf = kf.get();
  std::vector<std::pair<float, int>> by_depth;
  for (size_t i = 0; i < cur_.size(); i++)
    if (i < cur_.f.depth.size() && cur_.f.depth[i] > 0 && cur_.usable(i)) by_depth.emplace_back(cur_.f.depth[i], static_cast<int>(i));
  std::sort(by_depth.begin(), by_depth.end());
  int n = 0;
  for (const auto& [z, i] : by_depth) {
    bool create = !cur_.points[i] || cur_.outlier[i];
    if (!create && cur_.points[i]->numObservations() < 1) {
      create = true;
      cur_.points[i].reset();
    }
    if (create) {
      if (!createPointFromDepth(kf.get(), static_cast<size_t>(i))) continue;
      cur_.outlier[i] = 0;
    }
    n++;
    if (z > cam_.close_depth && n > 100) break;
  }
  map_->addKeyFrame(kf);
  sink_->insertKeyFrame(kf);
  last_kf_frame_ = frame_id_;
  last_kf_ = kf.get();
}

}  // namespace dslam
