// LoopCloser, geometric verification: SE(3) RANSAC (Horn/Umeyama on 3D-3D
// matches) and guided matching of a loop candidate.
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>

#include "dslam/core/log.h"
#include "dslam/loop_closing/loop_closer.h"
#include "dslam/tracking/matcher.h"
#include "dslam/tracking/pose_optimizer.h"

namespace dslam {

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

bool LoopCloser::refineCorrection(KeyFrame* cur, const std::vector<MapPointPtr>& matched, SE3& Tcw,
                                  double* position_sigma) const {
  std::vector<PoseObservation> obs;
  for (size_t i = 0; i < matched.size(); i++) {
    const MapPointPtr& mp = matched[i];
    if (!mp || mp->bad) continue;
    PoseObservation o;
    o.Xw = mp->pos;
    o.uv = {cur->keys_un[i].pt.x, cur->keys_un[i].pt.y};
    o.u_right = i < cur->u_right.size() && cur->u_right[i] >= 0 ? cur->u_right[i] : -1.0;
    o.information = cur->scale->inv_sigma2[static_cast<size_t>(cur->keys_un[i].octave)];
    obs.push_back(o);
  }
  if (static_cast<int>(obs.size()) < p_.min_inliers) return false;
  PoseOptimizerParams pp;
  pp.fx = cur->cam.fx, pp.fy = cur->cam.fy, pp.cx = cur->cam.cx, pp.cy = cur->cam.cy, pp.bf = cur->cam.bf;
  SE3 T = Tcw;
  std::vector<char> out;
  const PoseOptimizerResult r = optimizePose(T, obs, out, pp);
  DSLAM_LOG(Debug, "  correction refined on " << obs.size() << " matches: " << r.inliers << " inliers, moved "
                                              << (T.inverse().translation() - Tcw.inverse().translation()).norm()
                                              << " m");
  if (r.inliers < p_.min_inliers) return false;
  Tcw = T;
  if (position_sigma) {
    const Eigen::Matrix3d S = poseCovariance(T, obs, out, pp).topLeftCorner<3, 3>();
    *position_sigma = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S).eigenvalues().maxCoeff()));
  }
  return true;
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
    SE3 Tcw_corr = c.T12 * cand->T_cw();
    std::vector<MapPointPtr> matched = c.matches;
    guided.searchByProjection(cur, Tcw_corr, c.loop_points, matched, 10);
    if (p_.refine_correction && refineCorrection(cur, matched, Tcw_corr, &c.position_sigma)) {
      c.T12 = Tcw_corr * cand->T_wc();
      matched = c.matches;  // matched again with the refined pose
      guided.searchByProjection(cur, Tcw_corr, c.loop_points, matched, 10);
    }
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

}  // namespace dslam
