#pragma once
/** \file eval.h
 *  Trajectory evaluation against ground truth: absolute trajectory error
 *  (ATE) and relative pose error (RPE) with the semantics of the TUM RGB-D
 *  benchmark (docs/evaluation.md).
 *
 *  - Association: dslam::traj::associate (greedy one-to-one, |dt| < max_dt).
 *  - Alignment of the estimate onto the ground truth: none, SE(3) or Sim(3)
 *    (Horn/Umeyama least squares on the associated positions).
 *  - ATE: |t_gt - t_aligned_est| per associated pair, metres.
 *  - RPE: for pose pairs (i, j), E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) with Q the
 *    ground truth and P the (aligned) estimate; translational |t(E)| in
 *    metres, rotational angle(E) in degrees.
 *
 *  Every error that means "nothing to compare" (no pose pair within max_dt,
 *  too few pairs for an alignment or a delta) throws DataError naming the
 *  inputs; no function returns zeros for missing data. */
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "dslam/core/se3.h"
#include "dslam/core/trajectory.h"

namespace dslam::eval {

// ---------------------------------------------------------------- basics --

enum class Align { None, SE3, Sim3 };
Align alignFromString(const std::string& s);  ///< "none" | "se3" | "sim3" (ConfigError otherwise)
const char* toString(Align a);

enum class DeltaUnit { Frames, Seconds, Meters };
DeltaUnit deltaUnitFromString(const std::string& s);  ///< "frames"|"f", "s", "m" (ConfigError otherwise)
const char* toString(DeltaUnit u);                    ///< "frames" | "s" | "m"

/** Summary statistics of a list of errors (numpy semantics: population std,
 *  median = mean of the two middle values for an even count). */
struct Stats {
  size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
};
/** Throws DataError if `v` is empty. */
Stats computeStats(const std::vector<double>& v);

/** Similarity transform mapping estimate-world points onto ground-truth-world
 *  points: p_gt ~= scale * R * p_est + t (rotation and t in `T`). */
struct Alignment {
  Align method = Align::None;
  SE3 T;             ///< R, t
  double scale = 1;  ///< 1 unless Sim3
  Eigen::Matrix4d matrix() const;                 ///< [sR t; 0 1]
  Eigen::Vector3d apply(const Eigen::Vector3d& p) const;
  /** Aligned pose: rotation R * R_wc, translation scale * R * t_wc + t. */
  SE3 apply(const SE3& T_wc) const;
  Trajectory apply(const Trajectory& t) const;
};

/** Least-squares alignment (Eigen::umeyama) of `est` onto `gt` (same size,
 *  corresponding points). None: identity. SE3/Sim3 need at least 3 points;
 *  Sim3 needs the estimate points not all equal (DataError otherwise). */
Alignment alignPoints(const std::vector<Eigen::Vector3d>& est, const std::vector<Eigen::Vector3d>& gt, Align method);

/** Associated pose pairs of two trajectories. */
struct Association {
  double max_dt = 0.02;
  std::vector<std::pair<size_t, size_t>> pairs;  ///< (gt index, est index), sorted by time
  size_t size() const { return pairs.size(); }
};
/** traj::associate on the stamps; throws DataError (naming gt_name and
 *  est_name, their time spans and max_dt) if no pair is found. */
Association associate(const Trajectory& gt, const Trajectory& est, double max_dt = 0.02,
                      const std::string& gt_name = "ground truth", const std::string& est_name = "estimate");

/** Alignment of `est` onto `gt` from the associated positions. */
Alignment alignTrajectories(const Trajectory& gt, const Trajectory& est, const Association& assoc, Align method);

// ------------------------------------------------------------------- ATE --

struct AteOptions {
  double max_dt = 0.02;  ///< association threshold, seconds
  Align align = Align::SE3;
  std::string gt_name = "ground truth", est_name = "estimate";  ///< used in error messages (file paths)
};

struct AteResult {
  AteOptions options;
  Association assoc;
  Alignment alignment;
  Trajectory aligned;          ///< every estimate pose with the alignment applied
  std::vector<double> errors;  ///< per associated pair (same order as assoc.pairs), metres
  Stats stats;                 ///< of `errors`
};

AteResult computeAte(const Trajectory& gt, const Trajectory& est, const AteOptions& opt = {});

// ------------------------------------------------------------------- RPE --

struct RpeOptions {
  double max_dt = 0.02;
  double delta = 1;  ///< frames: a positive integer; s / m: a positive number
  DeltaUnit unit = DeltaUnit::Frames;
  /** SE3 and None give the same RPE (a rigid alignment cancels); Sim3 scales
   *  the estimate's translations (monocular). */
  Align align = Align::None;
  std::string gt_name = "ground truth", est_name = "estimate";
};

/** One relative-pose comparison between associated pairs k0 < k1
 *  (indices into Association::pairs). */
struct RpePair {
  size_t k0 = 0, k1 = 0;
  double t0 = 0, t1 = 0;  ///< ground-truth stamps
  double trans = 0;       ///< metres
  double rot = 0;         ///< degrees
};

struct RpeResult {
  RpeOptions options;
  Association assoc;
  Alignment alignment;
  Trajectory aligned;
  std::vector<RpePair> pairs;
  Stats trans;  ///< metres
  Stats rot;    ///< degrees
};

/** Pose pairs (k0, k1) over the associated poses:
 *  - Frames: (k, k + delta).
 *  - Seconds: k1 = the first associated pose with t_gt[k1] - t_gt[k] >= delta
 *    (1 us tolerance); k without such a pose is skipped.
 *  - Meters: the same with the distance travelled along the whole ground
 *    truth trajectory between the two ground-truth poses (1e-9 m tolerance).
 *  Throws DataError if no pair exists (delta longer than the overlap). */
RpeResult computeRpe(const Trajectory& gt, const Trajectory& est, const RpeOptions& opt = {});

/** The RPE error transform of one pair: (Q0^-1 Q1)^-1 (P0^-1 P1). */
SE3 relativeError(const SE3& gt0, const SE3& gt1, const SE3& est0, const SE3& est1);
/** Rotation angle of T in radians, [0, pi] (atan2 form, accurate near 0). */
double rotationAngle(const SE3& T);

// ------------------------------------------------------------- reports --

/** One JSON object: metric, pairs, max_dt, align, scale, rmse, mean, median,
 *  std, min, max (metres). */
std::string toJson(const AteResult& r);
/** One JSON object: metric, pairs, associated, max_dt, align, scale, delta,
 *  delta_unit, trans {rmse, mean, median, std, min, max} (metres),
 *  rot {...} (degrees). */
std::string toJson(const RpeResult& r);
/** Human-readable multi-line summaries. */
std::string toText(const AteResult& r);
std::string toText(const RpeResult& r);

}  // namespace dslam::eval
