#include "common.h"

#include <opencv2/calib3d.hpp>

#include "dslam/features/rotation_histogram.h"

#include <algorithm>
#include <climits>
#include <cmath>

#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/descriptor.h"

namespace dslam::cls {

cv::Size imageSize(const Frame& f, const CameraModel* cam, cv::Size fallback) {
  if (!f.gray.empty()) return f.gray.size();
  if (!f.input.image.empty()) return f.input.image.size();
  if (cam && cam->left.valid()) return cv::Size(cam->left.width, cam->left.height);
  return fallback;
}

void ensureMeta(Frame& f) {
  if (f.meta.size() != f.keypoints.size()) f.resetMeta();
}

std::vector<int> cocoIdList(const Params& p, const std::string& key) {
  std::vector<int> out = p.getIntList(key);
  for (int id : out)
    if (!coco::find(id))
      p.fail(key, std::to_string(id) + " is not a COCO category id (person = 1, chair = 62, see dslam/core/coco.h)");
  return out;
}

ClassValues classValues(const Params& p, const std::string& key, bool need_default) {
  ClassValues cv;
  for (const auto& [k, v] : p.getDoubleMap(key)) {
    if (k == "default") {
      cv.fallback = v;
      cv.has_default = true;
      continue;
    }
    int id = coco::idFromName(k);
    if (id < 0) {
      char* end = nullptr;
      const long n = std::strtol(k.c_str(), &end, 10);
      if (end && *end == '\0' && !k.empty() && coco::find(static_cast<int>(n))) id = static_cast<int>(n);
    }
    if (id < 0)
      p.fail(key, "'" + k +
                      "' is not a COCO class name or id (COCO spelling, e.g. person, chair, \"dining table\"; "
                      "or 'default')");
    cv.by_class[id] = v;
  }
  if (need_default && !cv.has_default)
    p.fail(key, "needs a 'default' entry for unlisted classes");
  return cv;
}

PixelLookup::PixelLookup(const cv::Mat& m, cv::Size ref) : m_(m) {
  if (!m.empty() && ref.width > 0 && ref.height > 0) {
    sx_ = static_cast<double>(m.cols) / ref.width;
    sy_ = static_cast<double>(m.rows) / ref.height;
  }
}

SegmentIndex::SegmentIndex(const Detections& d) : d_(&d) {
  for (size_t i = 0; i < d.segments.size(); i++) idx_.emplace(d.segments[i].id, i);
}

KeypointRegions panopticRegions(const std::vector<cv::KeyPoint>& kps, const Detections& d, cv::Size ref) {
  KeypointRegions r;
  r.region.assign(kps.size(), Region::None);
  r.segment.assign(kps.size(), 0);
  r.category.assign(kps.size(), -1);
  if (d.panoptic.empty() || d.panoptic.type() != CV_32S) return r;
  const PixelLookup lut(d.panoptic, ref);
  const SegmentIndex segs(d);
  for (size_t i = 0; i < kps.size(); i++) {
    const auto px = lut.pixel(kps[i].pt);
    if (!px) continue;
    const int id = d.panoptic.at<int32_t>(*px);
    r.segment[i] = id;
    const PanopticSegment* s = id != 0 ? segs.find(id) : nullptr;
    if (!s || s->kind == SegmentKind::Unknown) {
      r.region[i] = Region::Unknown;
      continue;
    }
    r.region[i] = s->kind == SegmentKind::Thing ? Region::Thing : Region::Stuff;
    r.category[i] = s->category_id;
  }
  return r;
}

cv::Point2f undistortPixel(const cv::Point2f& p, const CameraModel* cam) {
  if (!cam || !cam->left.valid() || !cam->left.hasDistortion()) return p;
  const Eigen::Vector2d u = cam->left.undistort(p.x, p.y);
  return cv::Point2f(static_cast<float>(u.x()), static_cast<float>(u.y()));
}

cv::Point2f undistorted(const Frame& f, size_t i, const CameraModel* cam) {
  if (f.keypoints_un.size() == f.keypoints.size()) return f.keypoints_un[i].pt;
  return undistortPixel(f.keypoints[i].pt, cam);
}

std::vector<ParamSpec> matchParamSpecs() {
  return {
      P_int("max_hamming", 50,
            "descriptor matching: largest Hamming distance of a match (ORBmatcher::TH_LOW, Panoptic-SLAM code)", 0, 256),
      P_double("nn_ratio", 0.9, "descriptor matching: best/second-best ratio (ORBmatcher(0.9, true), Panoptic-SLAM code)",
               0, 1),
      P_bool("check_orientation", true, "descriptor matching: rotation-histogram consistency check (ORB-SLAM)"),
      P_bool("finest_level_only", false,
             "descriptor matching: match only octave-0 keypoints (Panoptic-SLAM's public code does)"),
      P_double("search_radius", 0,
               "descriptor matching: max pixel distance between matched keypoints (0 = whole image, as the papers)", 0,
               100000),
  };
}

MatchParams matchParams(const Params& p) {
  MatchParams m;
  m.max_distance = static_cast<int>(p.getInt("max_hamming"));
  m.nn_ratio = p.getDouble("nn_ratio");
  m.check_orientation = p.getBool("check_orientation");
  m.finest_level_only = p.getBool("finest_level_only");
  m.radius = p.getDouble("search_radius");
  return m;
}


std::vector<int> matchDescriptors(const std::vector<cv::KeyPoint>& ck, const cv::Mat& cd, const std::vector<int>& cur,
                                  const std::vector<cv::KeyPoint>& pk, const cv::Mat& pd, const std::vector<int>& prev,
                                  const MatchParams& mp) {
  std::vector<int> out(cur.size(), -1);
  if (cur.empty() || prev.empty() || cd.empty() || pd.empty()) return out;
  if (cd.cols != kOrbDescriptorBytes || pd.cols != kOrbDescriptorBytes || cd.type() != CV_8U || pd.type() != CV_8U)
    throw DataError("descriptor matching: expected 32-byte CV_8U ORB descriptors");

  // Optional spatial grid over the previous candidates.
  const bool grid = mp.radius > 0;
  const double cell = grid ? mp.radius : 1.0;
  std::unordered_map<int64_t, std::vector<int>> cells;  // key -> positions in `prev`
  auto key = [](int cx, int cy) { return (static_cast<int64_t>(cx) << 32) ^ static_cast<uint32_t>(cy); };
  if (grid)
    for (size_t j = 0; j < prev.size(); j++) {
      const cv::Point2f& p = pk[prev[j]].pt;
      cells[key(static_cast<int>(std::floor(p.x / cell)), static_cast<int>(std::floor(p.y / cell)))].push_back(
          static_cast<int>(j));
    }
  const double r2 = mp.radius * mp.radius;

  struct PrevState {
    int dist = INT_MAX;  // distance of its current match
    int cur = -1;        // position in `cur` of its match
  };
  std::vector<PrevState> pst(prev.size());
  std::vector<int> matched;     // positions in `cur` with a match, in match order
  std::vector<float> rot_diff;  // their keypoint angle differences
  std::vector<int> cand;

  for (size_t i = 0; i < cur.size(); i++) {
    const cv::KeyPoint& kc = ck[cur[i]];
    if (mp.finest_level_only && kc.octave > 0) continue;
    const uint8_t* d1 = cd.ptr<uint8_t>(cur[i]);
    BestTwo bt(INT_MAX);
    auto consider = [&](int j) {
      const int dist = descriptorDistance(d1, pd.ptr<uint8_t>(prev[j]));
      if (pst[j].dist > dist) bt.offer(dist, j);  // a previous keypoint keeps a closer match
    };
    if (grid) {
      const int cx = static_cast<int>(std::floor(kc.pt.x / cell)), cy = static_cast<int>(std::floor(kc.pt.y / cell));
      cand.clear();
      for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
          auto it = cells.find(key(cx + dx, cy + dy));
          if (it == cells.end()) continue;
          for (int j : it->second) {
            const cv::Point2f d = pk[prev[j]].pt - kc.pt;
            if (static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y <= r2) cand.push_back(j);
          }
        }
      for (int j : cand) consider(j);
    } else {
      for (size_t j = 0; j < prev.size(); j++) consider(static_cast<int>(j));
    }
    const int best = bt.d1, best2 = bt.d2, best_j = bt.idx;
    if (best_j < 0 || best > mp.max_distance) continue;
    if (!(best < static_cast<double>(best2) * mp.nn_ratio)) continue;
    if (pst[best_j].cur >= 0) out[pst[best_j].cur] = -1;
    out[i] = best_j;
    pst[best_j].cur = static_cast<int>(i);
    pst[best_j].dist = best;
    if (mp.check_orientation) {
      matched.push_back(static_cast<int>(i));
      rot_diff.push_back(kc.angle - pk[prev[best_j]].angle);
    }
  }
  if (mp.check_orientation) {
    const std::vector<bool> keep = rotationConsistent(rot_diff);  // 12-degree bins, rotation_histogram.h
    for (size_t k = 0; k < matched.size(); k++)
      if (!keep[k]) out[matched[k]] = -1;
  }
  for (int& o : out)
    if (o >= 0) o = prev[o];
  return out;
}

std::vector<ParamSpec> ransacParamSpecs(double default_threshold, const std::string& source) {
  return {
      P_double("ransac_threshold", default_threshold,
               "RANSAC inlier distance (px) of findFundamentalMat(FM_RANSAC) (" + source + ")", 1e-6, 100),
      P_double("ransac_confidence", 0.99, "RANSAC confidence (" + source + ": 0.99)", 0.5, 0.999999),
      P_int("ransac_max_iterations", 1000,
            "RANSAC iteration cap (OpenCV's default 1000, used by the papers' code; the main cost on real data)", 1,
            1000000),
      P_int("min_fit_matches", 41, "fewest correspondences to fit the fundamental matrix (Panoptic-SLAM code: > 40)",
            8, 100000),
      P_int("max_fit_points", 0, "fit on at most this many correspondences, evenly subsampled (0 = all, as the papers)",
            0, 1000000),
      P_enum("ransac_method", "ransac", {"ransac", "usac"},
             "ransac: cv::FM_RANSAC (the papers); usac: cv::USAC_FM_8PTS (OpenCV 4.5+, faster, also deterministic)"),
      P_bool("motion_prior", false,
             "use the motion model's predicted camera motion (not in the papers): RANSAC runs only on the "
             "correspondences near the predicted epipolar lines, with prior_iterations; LK flow starts at the "
             "predicted position"),
      P_double("prior_gate", 2.0, "motion_prior: correspondences farther than this (px) from the predicted epipolar "
                                  "line are not used to fit", 0.01, 1000),
      P_int("prior_iterations", 50, "motion_prior: RANSAC iteration cap on the gated correspondences", 1, 1000000),
  };
}

RansacParams ransacParams(const Params& p) {
  RansacParams r;
  r.threshold = p.getDouble("ransac_threshold");
  r.confidence = p.getDouble("ransac_confidence");
  r.max_iterations = static_cast<int>(p.getInt("ransac_max_iterations"));
  r.min_matches = static_cast<int>(p.getInt("min_fit_matches"));
  r.max_points = static_cast<int>(p.getInt("max_fit_points"));
  r.usac = p.getString("ransac_method") == "usac";
  r.motion_prior = p.getBool("motion_prior");
  r.prior_gate = p.getDouble("prior_gate");
  r.prior_iterations = static_cast<int>(p.getInt("prior_iterations"));
  if (r.max_points > 0 && r.max_points < 8)
    p.fail("max_fit_points", "at least 8 (or 0 = all)");
  return r;
}

std::vector<int> evenSubset(const std::vector<int>& v, int n) {
  if (n <= 0 || static_cast<int>(v.size()) <= n) return v;
  std::vector<int> out;
  out.reserve(static_cast<size_t>(n));
  for (int k = 0; k < n; k++) out.push_back(v[static_cast<size_t>(static_cast<int64_t>(k) * static_cast<int64_t>(v.size()) / n)]);
  return out;
}

cv::Point2f MotionPrior::previousPixel(const cv::Point2f& un, double z, double z_far) const {
  const double d = z > 0 ? z : z_far;
  const Eigen::Vector3d Xc((un.x - cx) / fx * d, (un.y - cy) / fy * d, d);
  const Eigen::Vector3d Xp = T_cur_prev.inverse() * Xc;
  if (Xp.z() <= 1e-6) return un;
  return {static_cast<float>(fx * Xp.x() / Xp.z() + cx), static_cast<float>(fy * Xp.y() / Xp.z() + cy)};
}

MotionPrior motionPrior(const ClassifierContext& ctx) {
  MotionPrior m;
  if (!ctx.camera || !ctx.predicted_T_wc || !ctx.previous_T_wc) return m;
  const auto& L = ctx.camera->left;
  if (!(L.fx > 0) || !(L.fy > 0)) return m;
  m.fx = L.fx;
  m.fy = L.fy;
  m.cx = L.cx;
  m.cy = L.cy;
  m.T_cur_prev = ctx.predicted_T_wc->inverse() * *ctx.previous_T_wc;
  const Eigen::Vector3d t = m.T_cur_prev.translation();
  if (t.norm() < 1e-9) return m;  // no translation: no epipolar geometry
  const Eigen::Matrix3d R = m.T_cur_prev.rotation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  Eigen::Matrix3d Ki;
  Ki << 1 / L.fx, 0, -L.cx / L.fx, 0, 1 / L.fy, -L.cy / L.fy, 0, 0, 1;
  const Eigen::Matrix3d F = Ki.transpose() * tx * R * Ki;
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) m.F(r, c) = F(r, c);
  m.ok = true;
  return m;
}

FundamentalFit fitFundamental(const std::vector<cv::Point2f>& prev, const std::vector<cv::Point2f>& cur,
                              const RansacParams& rp, const MotionPrior* prior) {
  if (rp.motion_prior && prior && prior->ok) {
    std::vector<cv::Point2f> a, b;
    for (size_t i = 0; i < prev.size(); i++)
      if (epipolarDistance(prior->F, prev[i], cur[i]) < rp.prior_gate) {
        a.push_back(prev[i]);
        b.push_back(cur[i]);
      }
    if (static_cast<int>(a.size()) >= std::max(8, rp.min_matches)) {
      RansacParams gated = rp;
      gated.motion_prior = false;
      gated.max_iterations = rp.prior_iterations;
      FundamentalFit r = fitFundamental(a, b, gated);
      r.matches = static_cast<int>(prev.size());
      return r;
    }
  }
  FundamentalFit r;
  r.matches = static_cast<int>(prev.size());
  if (r.matches < std::max(8, rp.min_matches)) return r;
  std::vector<cv::Point2f> a, b;
  const std::vector<cv::Point2f>*pa = &prev, *pb = &cur;
  if (rp.max_points > 0 && r.matches > rp.max_points) {
    for (int k = 0; k < rp.max_points; k++) {
      const size_t i = static_cast<size_t>(static_cast<int64_t>(k) * r.matches / rp.max_points);
      a.push_back(prev[i]);
      b.push_back(cur[i]);
    }
    pa = &a;
    pb = &b;
  }
  cv::Mat mask;
  cv::Mat F;
  try {
    const int method = rp.usac ? static_cast<int>(cv::USAC_FM_8PTS) : static_cast<int>(cv::FM_RANSAC);
    F = cv::findFundamentalMat(*pa, *pb, method, rp.threshold, rp.confidence,
                               rp.max_iterations, mask);
  } catch (const cv::Exception&) {
    return r;
  }
  if (F.rows != 3 || F.cols != 3) return r;  // degenerate input (or several 7-point solutions)
  F.convertTo(F, CV_64F);
  r.F = cv::Matx33d(F.ptr<double>());
  r.inliers = cv::countNonZero(mask);
  r.ok = true;
  return r;
}

}  // namespace dslam::cls
