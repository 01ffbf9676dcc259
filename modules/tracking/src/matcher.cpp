#include "dslam/tracking/matcher.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "dslam/core/descriptor.h"
#include "dslam/features/rotation_histogram.h"
#include "dslam/map/map.h"

namespace dslam {

namespace {

inline int dist(const Descriptor& a, const cv::Mat& d, size_t row) {
  return descriptorDistance(a.data(), d.ptr<uint8_t>(static_cast<int>(row)));
}

/** Pixel (u, v) and 1/z of camera point Xc (ORB-SLAM's SearchByProjection
 *  arithmetic); false when it is behind the camera or outside the image. */
bool project(const CameraIntrinsics& cam, const Eigen::Vector3d& Xc, float& invz, float& u, float& v) {
  if (Xc.z() <= 0) return false;
  invz = static_cast<float>(1.0 / Xc.z());
  u = cam.fx * Xc.x() * invz + cam.cx;
  v = cam.fy * Xc.y() * invz + cam.cy;
  return cam.bounds.contains(u, v);
}

}  // namespace

int Matcher::dropByOrientation(const std::vector<float>& rot_diff, std::vector<int>& ids,
                               std::vector<MapPointPtr>& points) const {
  std::vector<bool> keep;
  orientationFilter(rot_diff, ids, keep);
  int dropped = 0;
  for (size_t k = 0; k < ids.size(); k++)
    if (!keep[k]) {
      points[ids[k]].reset();
      dropped++;
    }
  return dropped;
}

void Matcher::orientationFilter(const std::vector<float>& rot_diff, std::vector<int>& ids, std::vector<bool>& keep) const {
  keep.assign(ids.size(), true);
  if (!p_.check_orientation || ids.empty()) return;
  keep = rotationConsistent(std::vector<float>(rot_diff.begin(), rot_diff.begin() + static_cast<long>(ids.size())),
                            p_.histo_length);
}

int Matcher::searchByProjection(TrackedFrame& F, const std::vector<MapPointPtr>& pts, float th) const {
  int n = 0;
  std::vector<size_t> cand;
  const auto& sc = *F.scale;
  for (const MapPointPtr& mp : pts) {
    if (!mp->track_in_view || mp->bad || !mp->active) continue;
    const int level = mp->track_scale_level;
    float r = radiusByViewingCos(mp->track_view_cos) * th * sc.scale[level];
    F.grid.featuresInArea(mp->track_proj_x, mp->track_proj_y, r, level - 1, level, cand);
    if (cand.empty()) continue;
    int best = 256, best2 = 256, best_level = -1, best_level2 = -1, best_idx = -1;
    for (size_t idx : cand) {
      if (!F.usable(idx)) continue;
      if (F.points[idx] && F.points[idx]->numObservations() > 0) continue;
      if (F.hasStereo(idx)) {
        const float er = std::fabs(mp->track_proj_xr - F.f.u_right[idx]);
        if (er > r * sc.scale[level]) continue;
      }
      const int d = dist(mp->desc, F.f.descriptors, idx);
      if (d < best) {
        best2 = best;
        best_level2 = best_level;
        best = d;
        best_level = F.f.keypoints_un[idx].octave;
        best_idx = static_cast<int>(idx);
      } else if (d < best2) {
        best_level2 = F.f.keypoints_un[idx].octave;
        best2 = d;
      }
    }
    if (best <= p_.th_high) {
      if (best_level == best_level2 && best > p_.nn_ratio * best2) continue;
      F.points[best_idx] = mp;
      n++;
    }
  }
  return n;
}

int Matcher::searchByProjection(TrackedFrame& cur, const TrackedFrame& last, float th, bool stereo) const {
  int n = 0;
  const auto& sc = *cur.scale;
  const SE3& Tcw = *cur.T_cw;
  const Eigen::Vector3d twc = Tcw.inverse().translation();
  const Eigen::Vector3d tlc = (*last.T_cw) * twc;  // current centre in the last frame
  const bool forward = tlc.z() > cur.cam.bf / cur.cam.fx && stereo;
  const bool backward = -tlc.z() > cur.cam.bf / cur.cam.fx && stereo;
  std::vector<float> rot;
  std::vector<int> ids;
  std::vector<size_t> cand;
  for (size_t i = 0; i < last.size(); i++) {
    const MapPointPtr& mp = last.points[i];
    if (!mp || last.outlier[i] || mp->bad || !mp->active) continue;
    float invz, u, v;
    if (!project(cur.cam, Tcw * mp->pos, invz, u, v)) continue;
    const int last_oct = last.f.keypoints_un[i].octave;
    const float r = th * sc.scale[last_oct];
    if (forward)
      cur.grid.featuresInArea(u, v, r, last_oct, -1, cand);
    else if (backward)
      cur.grid.featuresInArea(u, v, r, 0, last_oct, cand);
    else
      cur.grid.featuresInArea(u, v, r, last_oct - 1, last_oct + 1, cand);
    if (cand.empty()) continue;
    int best = 256, best_idx = -1;
    for (size_t idx : cand) {
      if (!cur.usable(idx)) continue;
      if (cur.points[idx] && cur.points[idx]->numObservations() > 0) continue;
      if (cur.hasStereo(idx)) {
        const float ur = u - cur.cam.bf * invz;
        if (std::fabs(ur - cur.f.u_right[idx]) > r) continue;
      }
      const int d = dist(mp->desc, cur.f.descriptors, idx);
      if (d < best) {
        best = d;
        best_idx = static_cast<int>(idx);
      }
    }
    if (best <= p_.th_high) {
      cur.points[best_idx] = mp;
      ids.push_back(best_idx);
      rot.push_back(last.f.keypoints_un[i].angle - cur.f.keypoints_un[best_idx].angle);
      n++;
    }
  }
  return n - dropByOrientation(rot, ids, cur.points);
}

int Matcher::searchByProjection(TrackedFrame& F, KeyFrame* kf, const std::set<const MapPoint*>& found, float th,
                                int orb_dist) const {
  int n = 0;
  const auto& sc = *F.scale;
  const SE3& Tcw = *F.T_cw;
  const Eigen::Vector3d Ow = Tcw.inverse().translation();
  std::vector<float> rot;
  std::vector<int> ids;
  std::vector<size_t> cand;
  for (size_t i = 0; i < kf->points.size(); i++) {
    const MapPointPtr& mp = kf->points[i];
    if (!mp || mp->bad || !mp->active || found.count(mp.get())) continue;
    float invz, u, v;
    if (!project(F.cam, Tcw * mp->pos, invz, u, v)) continue;
    const float d3 = static_cast<float>((mp->pos - Ow).norm());
    if (!mp->inScaleRange(d3)) continue;
    const int level = mp->predictScale(d3, sc.log_scale_factor, sc.n_levels);
    const float r = th * sc.scale[level];
    F.grid.featuresInArea(u, v, r, level - 1, level + 1, cand);
    int best = 256, best_idx = -1;
    for (size_t idx : cand) {
      if (!F.usable(idx) || F.points[idx]) continue;
      const int d = dist(mp->desc, F.f.descriptors, idx);
      if (d < best) {
        best = d;
        best_idx = static_cast<int>(idx);
      }
    }
    if (best <= orb_dist) {
      F.points[best_idx] = mp;
      ids.push_back(best_idx);
      rot.push_back(kf->keys_un[i].angle - F.f.keypoints_un[best_idx].angle);
      n++;
    }
  }
  return n - dropByOrientation(rot, ids, F.points);
}

/** One-to-one keyframe -> frame matching shared by searchByDescriptors and
 *  searchByBoW: `for_each_pair(visit)` calls visit(i, candidates) for each
 *  keyframe keypoint i with the frame keypoints it may match. */
template <class ForEachPair>
int Matcher::matchKeyFrameToFrame(KeyFrame* kf, TrackedFrame& F, ForEachPair&& for_each_pair) const {
  std::vector<int> best_for_f(F.size(), 256);
  std::vector<int> kf_for_f(F.size(), -1);
  for_each_pair([&](uint32_t i, const auto& candidates) {
    const MapPointPtr& mp = kf->points[i];
    if (!mp || mp->bad || !mp->active) return;
    const uint8_t* dk = kf->descriptors.ptr<uint8_t>(static_cast<int>(i));
    BestTwo best;
    for (const auto jj : candidates) {
      const size_t j = static_cast<size_t>(jj);
      if (!F.usable(j)) continue;
      best.offer(descriptorDistance(dk, F.f.descriptors.ptr<uint8_t>(static_cast<int>(j))), static_cast<int>(j));
    }
    const int b1 = best.d1, bi = best.idx;
    if (bi < 0 || b1 > p_.th_low || b1 >= p_.nn_ratio * best.d2) return;
    if (b1 < best_for_f[bi]) {  // one-to-one: keep the closest keyframe point per frame keypoint
      best_for_f[bi] = b1;
      kf_for_f[bi] = static_cast<int>(i);
    }
  });
  std::vector<float> rot;
  std::vector<int> ids;
  int n = 0;
  for (size_t j = 0; j < F.size(); j++) {
    if (kf_for_f[j] < 0) continue;
    F.points[j] = kf->points[kf_for_f[j]];
    ids.push_back(static_cast<int>(j));
    rot.push_back(kf->keys_un[kf_for_f[j]].angle - F.f.keypoints_un[j].angle);
    n++;
  }
  return n - dropByOrientation(rot, ids, F.points);
}

int Matcher::searchByDescriptors(KeyFrame* kf, TrackedFrame& F) const {
  std::vector<uint32_t> all(F.size());
  for (size_t j = 0; j < all.size(); j++) all[j] = static_cast<uint32_t>(j);
  return matchKeyFrameToFrame(kf, F, [&](auto&& visit) {
    for (size_t i = 0; i < kf->points.size(); i++) visit(static_cast<uint32_t>(i), all);
  });
}

int Matcher::searchByBoW(KeyFrame* kf, TrackedFrame& F) const {
  if (kf->feat.empty() || F.feat.empty()) return searchByDescriptors(kf, F);
  return matchKeyFrameToFrame(kf, F, [&](auto&& visit) {
    // Only keypoints under the same vocabulary node (direct index) are compared.
    kf->feat.forEachSharedNode(F.feat, [&](const auto& here, const auto& there) {
      for (uint32_t i : here) visit(i, there);
    });
  });
}

int Matcher::searchByBoW(KeyFrame* kf1, KeyFrame* kf2, std::vector<MapPointPtr>& matches12) const {
  matches12.assign(kf1->size(), nullptr);
  std::vector<char> used2(kf2->size(), 0);
  std::vector<float> rot;
  std::vector<int> ids;
  auto tryPair = [&](uint32_t i, const std::vector<uint32_t>& cands) {
    const MapPointPtr& mp1 = kf1->points[i];
    if (!mp1 || mp1->bad || !kf1->usable(i)) return;
    const uint8_t* d1 = kf1->descriptors.ptr<uint8_t>(static_cast<int>(i));
    BestTwo best;
    for (uint32_t j : cands) {
      const MapPointPtr& mp2 = kf2->points[j];
      if (used2[j] || !mp2 || mp2->bad || !mp2->active || !kf2->usable(j)) continue;
      best.offer(descriptorDistance(d1, kf2->descriptors.ptr<uint8_t>(static_cast<int>(j))), static_cast<int>(j));
    }
    const int b1 = best.d1, bi = best.idx;
    if (bi < 0 || b1 >= p_.th_low || b1 >= p_.nn_ratio * best.d2) return;
    matches12[i] = kf2->points[bi];
    used2[bi] = 1;
    ids.push_back(static_cast<int>(i));
    rot.push_back(kf1->keys_un[i].angle - kf2->keys_un[bi].angle);
  };
  if (!kf1->feat.empty() && !kf2->feat.empty()) {
    kf1->feat.forEachSharedNode(kf2->feat, [&](const auto& here, const auto& there) {
      for (uint32_t i : here) tryPair(i, there);
    });
  } else {
    std::vector<uint32_t> all(kf2->size());
    for (size_t j = 0; j < all.size(); j++) all[j] = static_cast<uint32_t>(j);
    for (size_t i = 0; i < kf1->size(); i++) tryPair(static_cast<uint32_t>(i), all);
  }
  std::vector<bool> keep;
  orientationFilter(rot, ids, keep);
  int n = 0;
  for (size_t k = 0; k < ids.size(); k++) {
    if (!keep[k])
      matches12[ids[k]].reset();
    else
      n++;
  }
  return n;
}

namespace {
/** Best unmatched keypoint of kf for a point at camera coordinates Xc (or -1). */
int bestInKeyFrame(const KeyFrame* kf, const MapPoint& mp, const Eigen::Vector3d& Xc, const Eigen::Vector3d& Ow_dir,
                   float th, int max_dist, const std::function<bool(size_t)>& skip) {
  if (Xc.z() <= 0) return -1;
  const float invz = static_cast<float>(1.0 / Xc.z());
  const float u = kf->cam.fx * static_cast<float>(Xc.x()) * invz + kf->cam.cx;
  const float v = kf->cam.fy * static_cast<float>(Xc.y()) * invz + kf->cam.cy;
  if (!kf->cam.bounds.contains(u, v)) return -1;
  const float d3 = static_cast<float>(Ow_dir.norm());
  if (!mp.inScaleRange(d3)) return -1;
  const auto& sc = *kf->scale;
  const int level = mp.predictScale(d3, sc.log_scale_factor, sc.n_levels);
  const float r = th * sc.scale[level];
  int best = 256, best_idx = -1;
  for (size_t idx : kf->grid.featuresInArea(u, v, r, level - 1, level + 1)) {
    if (!kf->usable(idx) || skip(idx)) continue;
    const int d = descriptorDistance(mp.desc.data(), kf->descriptors.ptr<uint8_t>(static_cast<int>(idx)));
    if (d < best) {
      best = d;
      best_idx = static_cast<int>(idx);
    }
  }
  return best <= max_dist ? best_idx : -1;
}
}  // namespace

int Matcher::searchBySE3(KeyFrame* kf1, KeyFrame* kf2, std::vector<MapPointPtr>& matches12, const SE3& T12,
                         float th) const {
  const SE3 T21 = T12.inverse();
  std::set<const MapPoint*> already1, already2;
  for (size_t i = 0; i < matches12.size(); i++)
    if (matches12[i]) {
      already2.insert(matches12[i].get());
      if (kf1->points[i]) already1.insert(kf1->points[i].get());
    }
  // kf1's points into kf2.
  std::vector<int> match1(kf1->size(), -1);
  for (size_t i = 0; i < kf1->size(); i++) {
    const MapPointPtr& mp = kf1->points[i];
    if (!mp || mp->bad || !mp->active || matches12[i]) continue;  // inactive: persistence filters
    const Eigen::Vector3d X1 = kf1->T_cw() * mp->pos;
    const Eigen::Vector3d X2 = T21 * X1;
    match1[i] = bestInKeyFrame(kf2, *mp, X2, X2, th, p_.th_high, [&](size_t j) {
      return !kf2->points[j] || kf2->points[j]->bad || !kf2->points[j]->active || already2.count(kf2->points[j].get());
    });
  }
  // kf2's points into kf1.
  std::vector<int> match2(kf2->size(), -1);
  for (size_t j = 0; j < kf2->size(); j++) {
    const MapPointPtr& mp = kf2->points[j];
    if (!mp || mp->bad || !mp->active || already2.count(mp.get())) continue;
    const Eigen::Vector3d X2 = kf2->T_cw() * mp->pos;
    const Eigen::Vector3d X1 = T12 * X2;
    match2[j] = bestInKeyFrame(kf1, *mp, X1, X1, th, p_.th_high, [&](size_t i) {
      return !kf1->points[i] || kf1->points[i]->bad || !kf1->points[i]->active || matches12[i];
    });
  }
  int n = 0;
  for (size_t i = 0; i < kf1->size(); i++) {
    const int j = match1[i];
    if (j >= 0 && match2[j] == static_cast<int>(i)) {
      matches12[i] = kf2->points[j];
      n++;
    }
  }
  return n;
}

int Matcher::searchByProjection(KeyFrame* kf, const SE3& T_cw, const std::vector<MapPointPtr>& points,
                                std::vector<MapPointPtr>& matched, float th) const {
  std::set<const MapPoint*> found;
  for (const auto& m : matched)
    if (m) found.insert(m.get());
  const Eigen::Vector3d Ow = T_cw.inverse().translation();
  int n = 0;
  for (const auto& mp : points) {
    if (!mp || mp->bad || found.count(mp.get())) continue;
    const Eigen::Vector3d Xc = T_cw * mp->pos;
    const Eigen::Vector3d PO = mp->pos - Ow;
    if (PO.dot(mp->normal) < 0.5 * PO.norm()) continue;
    const int idx = bestInKeyFrame(kf, *mp, Xc, PO, th, p_.th_low, [&](size_t i) { return matched[i] != nullptr; });
    if (idx >= 0) {
      matched[idx] = mp;
      n++;
    }
  }
  return n;
}

int Matcher::fuse(KeyFrame* kf, const SE3& T_cw, const std::vector<MapPointPtr>& points, float th,
                  std::vector<MapPointPtr>& replace) const {
  replace.assign(points.size(), nullptr);
  const Eigen::Vector3d Ow = T_cw.inverse().translation();
  int n = 0;
  for (size_t k = 0; k < points.size(); k++) {
    const MapPointPtr& mp = points[k];
    if (!mp || mp->bad || !mp->active || mp->isIn(kf)) continue;  // inactive: persistence filters
    const Eigen::Vector3d Xc = T_cw * mp->pos;
    const Eigen::Vector3d PO = mp->pos - Ow;
    if (PO.dot(mp->normal) < 0.5 * PO.norm()) continue;
    const int idx = bestInKeyFrame(kf, *mp, Xc, PO, th, p_.th_low, [](size_t) { return false; });
    if (idx < 0) continue;
    const MapPointPtr& in_kf = kf->points[idx];
    if (in_kf && !in_kf->bad) {
      if (!in_kf->active) continue;  // an inactive point is not merged with an active one
      if (in_kf != mp) replace[k] = in_kf;
    } else {
      mp->addObservation(kf, idx);
      kf->addPoint(mp, idx);
    }
    n++;
  }
  return n;
}

Eigen::Matrix3d fundamental12(const KeyFrame* kf1, const KeyFrame* kf2) {
  const SE3 T12 = kf1->T_cw() * kf2->T_wc();
  const Eigen::Matrix3d R12 = T12.rotation();
  const Eigen::Vector3d t12 = T12.translation();
  Eigen::Matrix3d K1, K2;
  K1 << kf1->cam.fx, 0, kf1->cam.cx, 0, kf1->cam.fy, kf1->cam.cy, 0, 0, 1;
  K2 << kf2->cam.fx, 0, kf2->cam.cx, 0, kf2->cam.fy, kf2->cam.cy, 0, 0, 1;
  return K1.transpose().inverse() * SE3::skew(t12) * R12 * K2.inverse();
}

int Matcher::searchForTriangulation(const KeyFrame* kf1, const KeyFrame* kf2, const Eigen::Matrix3d& F12,
                                    std::vector<std::pair<int, int>>& pairs, bool only_stereo) const {
  pairs.clear();
  // Epipole of camera 1 in image 2 (candidates too close to it are ambiguous).
  const Eigen::Vector3d C2 = kf2->T_cw() * kf1->center();
  const float invz = static_cast<float>(1.0 / C2.z());
  const float ex = kf2->cam.fx * C2.x() * invz + kf2->cam.cx;
  const float ey = kf2->cam.fy * C2.y() * invz + kf2->cam.cy;
  const auto& sc2 = *kf2->scale;
  const size_t n1 = kf1->size(), n2 = kf2->size();
  std::vector<int> free2;
  for (size_t j = 0; j < n2; j++)
    if (!kf2->points[j] && kf2->usable(j)) free2.push_back(static_cast<int>(j));
  std::vector<int> match12(n1, -1), best_d2(n2, 256), owner2(n2, -1);
  for (size_t i = 0; i < n1; i++) {
    if (kf1->points[i] || !kf1->usable(i)) continue;
    const bool stereo1 = kf1->u_right[i] >= 0;
    if (only_stereo && !stereo1) continue;
    const auto& p1 = kf1->keys_un[i].pt;
    const double a = p1.x * F12(0, 0) + p1.y * F12(1, 0) + F12(2, 0);
    const double b = p1.x * F12(0, 1) + p1.y * F12(1, 1) + F12(2, 1);
    const double c = p1.x * F12(0, 2) + p1.y * F12(1, 2) + F12(2, 2);
    const double den = a * a + b * b;
    if (den == 0) continue;
    const uint8_t* d1 = kf1->descriptors.ptr<uint8_t>(static_cast<int>(i));
    int best = p_.th_low, best_j = -1;
    for (int j : free2) {
      const auto& kp2 = kf2->keys_un[j];
      const double num = a * kp2.pt.x + b * kp2.pt.y + c;
      if (num * num / den >= 3.84 * sc2.sigma2[kp2.octave]) continue;
      const int d = descriptorDistance(d1, kf2->descriptors.ptr<uint8_t>(j));
      if (d > p_.th_low || d > best) continue;
      const bool stereo2 = kf2->u_right[j] >= 0;
      if (!stereo1 && !stereo2) {
        const float dx = ex - kp2.pt.x, dy = ey - kp2.pt.y;
        if (dx * dx + dy * dy < 100 * sc2.scale[kp2.octave]) continue;
      }
      best = d;
      best_j = j;
    }
    if (best_j >= 0 && best < best_d2[best_j]) {
      if (owner2[best_j] >= 0) match12[owner2[best_j]] = -1;
      owner2[best_j] = static_cast<int>(i);
      best_d2[best_j] = best;
      match12[i] = best_j;
    }
  }
  std::vector<float> rot;
  std::vector<int> ids;
  for (size_t i = 0; i < n1; i++)
    if (match12[i] >= 0) {
      ids.push_back(static_cast<int>(i));
      rot.push_back(kf1->keys_un[i].angle - kf2->keys_un[match12[i]].angle);
    }
  std::vector<bool> keep;
  orientationFilter(rot, ids, keep);
  for (size_t k = 0; k < ids.size(); k++)
    if (keep[k]) pairs.emplace_back(ids[k], match12[ids[k]]);
  return static_cast<int>(pairs.size());
}

int Matcher::fuse(KeyFrame* kf, const std::vector<MapPointPtr>& pts, float th) const {
  int n = 0;
  const SE3& Tcw = kf->T_cw();
  const Eigen::Vector3d Ow = kf->center();
  const auto& sc = *kf->scale;
  std::vector<size_t> cand;
  for (const auto& mp0 : pts) {
    MapPointPtr mp = mp0;
    if (!mp || mp->bad || !mp->active || mp->isIn(kf)) continue;  // inactive: persistence filters
    const Eigen::Vector3d Xc = Tcw * mp->pos;
    if (Xc.z() < 0) continue;
    const float invz = static_cast<float>(1.0 / Xc.z());
    const float u = kf->cam.fx * Xc.x() * invz + kf->cam.cx;
    const float v = kf->cam.fy * Xc.y() * invz + kf->cam.cy;
    if (!kf->cam.bounds.contains(u, v)) continue;
    const float ur = u - kf->cam.bf * invz;
    const Eigen::Vector3d PO = mp->pos - Ow;
    const float d3 = static_cast<float>(PO.norm());
    if (!mp->inScaleRange(d3)) continue;
    if (PO.dot(mp->normal) < 0.5 * d3) continue;
    const int level = mp->predictScale(d3, sc.log_scale_factor, sc.n_levels);
    const float r = th * sc.scale[level];
    kf->grid.featuresInArea(u, v, r, -1, -1, cand);
    int best = 256, best_idx = -1;
    for (size_t idx : cand) {
      if (!kf->usable(idx)) continue;
      const auto& kp = kf->keys_un[idx];
      if (kp.octave < level - 1 || kp.octave > level) continue;
      const float ex = u - kp.pt.x, ey = v - kp.pt.y;
      float e2 = ex * ex + ey * ey;
      const bool st = kf->u_right[idx] >= 0;
      if (st) {
        const float er = ur - kf->u_right[idx];
        e2 += er * er;
      }
      if (e2 * sc.inv_sigma2[kp.octave] > (st ? 7.8f : 5.99f)) continue;
      const int d = dist(mp->desc, kf->descriptors, idx);
      if (d < best) {
        best = d;
        best_idx = static_cast<int>(idx);
      }
    }
    if (best > p_.th_low) continue;
    MapPointPtr in_kf = kf->points[best_idx];
    if (in_kf && !in_kf->bad) {
      if (!in_kf->active) continue;  // an inactive point (a moved object's, say) is not merged with an active one
      if (in_kf->numObservations() > mp->numObservations())
        mp->replaceWith(in_kf);
      else
        in_kf->replaceWith(mp);
    } else {
      mp->addObservation(kf, best_idx);
      kf->addPoint(mp, best_idx);
    }
    n++;
  }
  return n;
}

}  // namespace dslam
