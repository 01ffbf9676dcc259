#include "dslam/plugins/classifiers/epipolar_consistency.h"

#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <cstdlib>

#include "common.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"

IMPLEMENTS_MRPT_OBJECT(EpipolarConsistency, KeypointClassifier, dslam)

namespace dslam {

struct EpipolarConsistency::Impl {
  enum class Apply { Things, Unknown, All, Boxes };
  bool flow = true;
  Apply apply = Apply::All;
  double threshold = 1.0, min_score = 0;
  cls::RansacParams ransac;
  std::vector<int> exclude;
  bool drop_unmatched = false;
  // LK
  int win = 22, levels = 5, iters = 20, edge = 5;
  double eps = 0.01, patch_check = 2120;
  cls::MatchParams match;
  // Pyramid of the last current frame, reused as the previous one.
  struct Cache {
    int index = -1;
    double timestamp = 0;
    const uchar* data = nullptr;
    std::vector<cv::Mat> pyr;
  } cache;

  void pyramid(const cv::Mat& gray, int index, double ts, std::vector<cv::Mat>& out) {
    if (cache.index == index && cache.timestamp == ts && cache.data == gray.data && !cache.pyr.empty()) {
      out = cache.pyr;
      return;
    }
    cv::buildOpticalFlowPyramid(gray, out, cv::Size(win, win), levels);
  }

  /** Which keypoints fit the fundamental matrix and which are tested. */
  struct Sets {
    std::vector<int> fit, test, need;  ///< need = fit U test (sorted)
    std::vector<char> unknown;         ///< per keypoint: on an unknown / void region
  };
  Sets regions(const Frame& frame, const Detections& det, const CameraModel* cam) const;
  /** Previous-frame (undistorted) pixel per needed keypoint by LK flow (DS-SLAM checks). */
  void flowMatches(const Frame& frame, const Frame& prev, const std::vector<cv::Mat>& cur_pyr,
                   const std::vector<int>& need, const CameraModel* cam, const cls::MotionPrior& prior,
                   std::vector<cv::Point2f>& prev_un, std::vector<char>& have);
  /** The same by ORB descriptor matches with the previous frame's keypoints. */
  void descriptorMatches(const Frame& frame, const Frame& prev, const std::vector<int>& need, const CameraModel* cam,
                         std::vector<cv::Point2f>& prev_un, std::vector<char>& have) const;
};

EpipolarConsistency::Impl::Sets EpipolarConsistency::Impl::regions(const Frame& frame, const Detections& det,
                                                                   const CameraModel* cam) const {
  const size_t n = frame.size();
  const bool use_det = det.valid;
  const cv::Size ref = cls::imageSize(frame, cam);
  const cls::KeypointRegions pan =
      use_det ? cls::panopticRegions(frame.keypoints, det, ref) : cls::panopticRegions({}, Detections{}, ref);
  const bool have_pan = use_det && !det.panoptic.empty();
  const bool have_sem = use_det && !det.semantic.empty() && det.semantic.type() == CV_8U;
  const cls::PixelLookup sem(have_sem ? det.semantic : cv::Mat(), ref);
  Sets out;
  std::vector<char> excl(n, 0), apply_to(n, 0);
  out.unknown.assign(n, 0);
  for (size_t i = 0; i < n; i++) {
    const cv::Point2f& pt = frame.keypoints[i].pt;
    bool in_box = false;
    if (use_det)
      for (const auto& b : det.boxes) {
        if (b.score < min_score || !cls::inBox(pt, b.box)) continue;
        in_box = true;
        if (cls::contains(exclude, b.class_id)) excl[i] = 1;
      }
    int sem_c = -1;
    if (have_sem)
      if (auto q = sem.pixel(pt)) {
        sem_c = det.semantic.at<uint8_t>(*q);
        if (sem_c == coco::kNone) sem_c = -1;
      }
    if (sem_c >= 0 && cls::contains(exclude, sem_c)) excl[i] = 1;
    if (have_pan && pan.region[i] == cls::Region::Thing && cls::contains(exclude, pan.category[i])) excl[i] = 1;
    out.unknown[i] = have_pan ? pan.region[i] == cls::Region::Unknown : (have_sem && sem_c < 0);
    switch (apply) {
      case Apply::All: apply_to[i] = 1; break;
      case Apply::Boxes: apply_to[i] = in_box; break;
      case Apply::Unknown: apply_to[i] = out.unknown[i]; break;
      case Apply::Things:
        apply_to[i] = have_pan ? pan.region[i] == cls::Region::Thing
                      : have_sem ? (sem_c >= 0 && coco::isThing(sem_c))
                                 : in_box;
        break;
    }
  }
  for (size_t i = 0; i < n; i++) {
    if (frame.meta[i].label == KpLabel::Dynamic) continue;
    if (!excl[i] && (apply == Apply::All || !apply_to[i])) out.fit.push_back(static_cast<int>(i));
    if (apply_to[i]) out.test.push_back(static_cast<int>(i));
  }
  // Flow: only the subsampled fit candidates are tracked (LK is the cost). Descriptor matches are subsampled
  // after matching (fitFundamental), most candidates find no match.
  if (flow) out.fit = cls::evenSubset(out.fit, ransac.max_points);
  std::set_union(out.fit.begin(), out.fit.end(), out.test.begin(), out.test.end(), std::back_inserter(out.need));
  return out;
}

void EpipolarConsistency::Impl::flowMatches(const Frame& frame, const Frame& prev, const std::vector<cv::Mat>& cur_pyr,
                                            const std::vector<int>& need, const CameraModel* cam,
                                            const cls::MotionPrior& prior, std::vector<cv::Point2f>& prev_un,
                                            std::vector<char>& have) {
  std::vector<cv::Mat> prev_pyr;
  pyramid(prev.gray, prev.index(), prev.timestamp(), prev_pyr);
  std::vector<cv::Point2f> from, to;
  from.reserve(need.size());
  for (int i : need) from.push_back(frame.keypoints[i].pt);
  int flags = 0;
  if (ransac.motion_prior && prior.ok) {
    // Start each track where the motion model puts the point in the previous
    // image (its depth, else the median scene depth): coarse levels are not needed.
    std::vector<float> zs;
    for (int i : need)
      if (static_cast<size_t>(i) < frame.depth.size() && frame.depth[i] > 0) zs.push_back(frame.depth[i]);
    double z_far = 3.0;
    if (!zs.empty()) {
      std::nth_element(zs.begin(), zs.begin() + static_cast<long>(zs.size() / 2), zs.end());
      z_far = zs[zs.size() / 2];
    }
    to.resize(from.size());
    for (size_t k = 0; k < need.size(); k++) {
      const size_t i = static_cast<size_t>(need[k]);
      const cv::Point2f un = cls::undistorted(frame, i, cam);
      const double z = i < frame.depth.size() ? frame.depth[i] : -1.0;
      to[k] = from[k] + (prior.previousPixel(un, z, z_far) - un);  // the predicted shift, in raw pixels
    }
    flags = cv::OPTFLOW_USE_INITIAL_FLOW;
  }
  std::vector<uchar> status;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(cur_pyr, prev_pyr, from, to, status, err, cv::Size(win, win), levels,
                           cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, iters, eps), flags);
  const cv::Mat& g1 = frame.gray;
  const cv::Mat& g0 = prev.gray;
  for (size_t k = 0; k < need.size(); k++) {
    if (!status[k]) continue;
    // DS-SLAM: integer pixel positions, border margin, 3x3 patch difference.
    const int x2 = static_cast<int>(from[k].x), y2 = static_cast<int>(from[k].y);
    const int x1 = static_cast<int>(to[k].x), y1 = static_cast<int>(to[k].y);
    const int e = std::max(edge, 1);
    if (to[k].x < 0 || to[k].y < 0 || x1 < e || y1 < e || x2 < e || y2 < e || x1 >= g0.cols - e ||
        y1 >= g0.rows - e || x2 >= g1.cols - e || y2 >= g1.rows - e)
      continue;
    if (patch_check > 0) {
      double sum = 0;
      for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++)
          sum += std::abs(static_cast<int>(g0.at<uint8_t>(y1 + dy, x1 + dx)) -
                          static_cast<int>(g1.at<uint8_t>(y2 + dy, x2 + dx)));
      if (sum > patch_check) continue;
    }
    prev_un[need[k]] = cls::undistortPixel(to[k], cam);
    have[need[k]] = 1;
  }
}

void EpipolarConsistency::Impl::descriptorMatches(const Frame& frame, const Frame& prev, const std::vector<int>& need,
                                                  const CameraModel* cam, std::vector<cv::Point2f>& prev_un,
                                                  std::vector<char>& have) const {
  if (frame.descriptors.rows != static_cast<int>(frame.size()) || prev.descriptors.rows != static_cast<int>(prev.size()))
    throw DataError("frame " + std::to_string(frame.index()) +
                    ": descriptor matching needs one descriptor row per keypoint (current and previous frame)");
  std::vector<int> cand;
  const bool pm = prev.meta.size() == prev.size();
  for (size_t j = 0; j < prev.size(); j++)
    if (!pm || prev.meta[j].label != KpLabel::Dynamic) cand.push_back(static_cast<int>(j));
  const std::vector<int> m =
      cls::matchDescriptors(frame.keypoints, frame.descriptors, need, prev.keypoints, prev.descriptors, cand, match);
  for (size_t k = 0; k < need.size(); k++)
    if (m[k] >= 0) {
      prev_un[need[k]] = cls::undistorted(prev, static_cast<size_t>(m[k]), cam);
      have[need[k]] = 1;
    }
}

std::string EpipolarConsistency::description() const {
  return "moving consistency check: keypoints off the static scene's epipolar lines (LK flow or ORB matches, "
         "RANSAC fundamental matrix) are dynamic";
}

std::vector<ParamSpec> EpipolarConsistency::paramSpecs() const {
  std::vector<ParamSpec> s = {
      P_enum("matching", "flow", {"flow", "descriptors"},
             "correspondences: pyramidal LK optical flow (DS-SLAM, STDyn-SLAM) or ORB matches (Panoptic-SLAM)"),
      P_enum("apply_to", "all", {"things", "unknown", "all", "boxes"},
             "keypoints tested: panoptic things, unknown/void regions, all, or inside any box"),
      P_double("threshold", 1.0,
               "epipolar distance (px) above which a keypoint is dynamic (DS-SLAM/STDyn-SLAM limit_dis_epi = 1)", 0,
               1000),
      P_list("exclude_classes", ParamType::IntList, "[1]",
             "COCO ids whose boxes / masks are left out of the fit (a-priori dynamic: person)"),
      P_double("min_score", 0, "ignore boxes with a lower score", 0, 1),
      P_bool("drop_unmatched_unknown", false,
             "tested keypoints in unknown regions without a correspondence are dynamic (Panoptic-SLAM)"),
      P_int("lk_window", 22, "LK window size (px) (DS-SLAM code: 22)", 3, 255),
      P_int("lk_levels", 5, "LK pyramid levels above the base (DS-SLAM code: 5)", 0, 10),
      P_int("lk_iterations", 20, "LK iterations per level (DS-SLAM code: 20)", 1, 1000),
      P_double("lk_epsilon", 0.01, "LK convergence epsilon (DS-SLAM code: 0.01)", 1e-6, 10),
      P_double("patch_check", 2120,
               "reject flow whose 3x3 patches differ by more than this sum of absolute grey differences "
               "(DS-SLAM limit_of_check = 2120; 0 = off)",
               0, 1e9),
      P_int("edge_margin", 5, "reject flow within this many pixels of the image border (DS-SLAM limit_edge_corner)",
            0, 1000),
  };
  for (auto& m : cls::ransacParamSpecs(0.1, "DS-SLAM code")) s.push_back(m);
  for (auto& m : cls::matchParamSpecs()) s.push_back(m);
  return s;
}

void EpipolarConsistency::configure(const Params& p, const PluginContext& ctx) {
  KeypointClassifier::configure(p, ctx);
  auto im = std::make_shared<Impl>();
  im->flow = p.getString("matching") == "flow";
  const std::string a = p.getString("apply_to");
  im->apply = a == "things"    ? Impl::Apply::Things
              : a == "unknown" ? Impl::Apply::Unknown
              : a == "boxes"   ? Impl::Apply::Boxes
                               : Impl::Apply::All;
  im->threshold = p.getDouble("threshold");
  im->ransac = cls::ransacParams(p);
  im->exclude = cls::cocoIdList(p, "exclude_classes");
  im->min_score = p.getDouble("min_score");
  im->drop_unmatched = p.getBool("drop_unmatched_unknown");
  im->win = static_cast<int>(p.getInt("lk_window"));
  im->levels = static_cast<int>(p.getInt("lk_levels"));
  im->iters = static_cast<int>(p.getInt("lk_iterations"));
  im->eps = p.getDouble("lk_epsilon");
  im->patch_check = p.getDouble("patch_check");
  im->edge = static_cast<int>(p.getInt("edge_margin"));
  im->match = cls::matchParams(p);
  impl_ = im;
  reset();
}

void EpipolarConsistency::reset() {
  stats_ = {};
  F_ = cv::Matx33d::zeros();
  if (impl_) impl_->cache = {};
}

void EpipolarConsistency::classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) {
  cls::ensureMeta(frame);
  if (!impl_) throw Error("EpipolarConsistency: classify() before configure()");
  Impl& im = *impl_;
  stats_ = {};
  const size_t n = frame.size();
  const CameraModel* cam = ctx.camera;

  // Pyramid of this frame for the next call (flow mode).
  std::vector<cv::Mat> cur_pyr;
  if (im.flow && !frame.gray.empty()) {
    if (frame.gray.type() != CV_8U)
      throw DataError("frame " + std::to_string(frame.index()) + ": grey image must be CV_8U");
    cv::buildOpticalFlowPyramid(frame.gray, cur_pyr, cv::Size(im.win, im.win), im.levels);
  }
  struct CacheGuard {  // store this frame's pyramid on every exit path
    Impl& im;
    const Frame& f;
    std::vector<cv::Mat>& pyr;
    ~CacheGuard() {
      if (pyr.empty()) return;
      im.cache.index = f.index();
      im.cache.timestamp = f.timestamp();
      im.cache.data = f.gray.data;
      im.cache.pyr = std::move(pyr);
    }
  } guard{im, frame, cur_pyr};

  const Frame* prev = ctx.previous;
  if (!prev || n == 0 || (prev->keypoints.empty() && !im.flow)) return;
  if (im.flow && (prev->gray.empty() || cur_pyr.empty() || prev->gray.size() != frame.gray.size())) return;

  const Impl::Sets sets = im.regions(frame, det, cam);
  const std::vector<int>& fit = sets.fit;
  const std::vector<int>& test = sets.test;
  stats_.tested = static_cast<int>(test.size());
  if (test.empty()) return;

  // ---- correspondences: previous (undistorted) pixel per needed keypoint
  std::vector<cv::Point2f> prev_un(n);
  std::vector<char> have(n, 0);
  const cls::MotionPrior prior = im.ransac.motion_prior ? cls::motionPrior(ctx) : cls::MotionPrior{};
  if (im.flow)
    im.flowMatches(frame, *prev, cur_pyr, sets.need, cam, prior, prev_un, have);
  else
    im.descriptorMatches(frame, *prev, sets.need, cam, prev_un, have);

  // ---- fundamental matrix from the fit set
  std::vector<cv::Point2f> p0, p1;
  for (int i : fit)
    if (have[i]) {
      p0.push_back(prev_un[i]);
      p1.push_back(cls::undistorted(frame, static_cast<size_t>(i), cam));
    }
  const cls::FundamentalFit ff = cls::fitFundamental(p0, p1, im.ransac, &prior);
  stats_.fit_matches = ff.matches;
  stats_.fit_inliers = ff.inliers;
  if (!ff.ok) {
    DSLAM_LOG(Debug, "EpipolarConsistency: frame " << frame.index() << ": no fundamental matrix (" << ff.matches
                                                   << " correspondences)");
    return;
  }
  stats_.fitted = true;
  F_ = ff.F;

  // ---- test
  for (int i : test) {
    KeypointMeta& m = frame.meta[i];
    if (!have[i]) {
      if (im.drop_unmatched && sets.unknown[i]) {
        cls::raise(m, KpLabel::Dynamic, KpReason::UnmatchedUnknown);
        stats_.unmatched_dropped++;
      }
      continue;
    }
    stats_.matched++;
    const double d = cls::epipolarDistance(F_, prev_un[i], cls::undistorted(frame, static_cast<size_t>(i), cam));
    if (d > im.threshold) {
      cls::raise(m, KpLabel::Dynamic, KpReason::EpipolarOutlier);
      stats_.outliers++;
    }
  }
}

}  // namespace dslam
