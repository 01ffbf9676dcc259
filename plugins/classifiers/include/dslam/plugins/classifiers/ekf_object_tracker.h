#pragma once
/** \file ekf_object_tracker.h
 *  Changing-SLAM's object tracking with one extended Kalman filter per
 *  detected object. */
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dslam/core/camera.h"
#include "dslam/core/keypoint_classifier.h"

namespace dslam {

/** State of one tracked object. */
struct TrackedObject {
  int id = -1;
  int class_id = -1;
  Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();  ///< [x y z vx vy vz], world
  Eigen::Matrix<double, 6, 6> P = Eigen::Matrix<double, 6, 6>::Identity();
  cv::Rect2f box;            ///< last associated box
  double time = 0;           ///< timestamp of the last filter update
  int updates = 0;           ///< measurements fused (the first initialises)
  int static_count = 0;      ///< consecutive updates with speed <= threshold
  int missed = 0;            ///< frames without an associated box
  int gated = 0;             ///< consecutive measurements rejected by the innovation gate
  bool dynamic = true;       ///< current decision
  KpReason reason = KpReason::NewObject;  ///< NewObject or ObjectMoving while dynamic
  double speed() const { return x.tail<3>().norm(); }
};

/** Changing-SLAM, Sec. 4.3-4.5: boxes are associated frame to frame by IoU
 *  within a class (the track's box moved to where its predicted position
 *  projects); each object has an EKF with state [x y z vx vy vz] in the
 *  world frame, constant-velocity model with random-acceleration noise
 *  (sigma_a per class: person 0.5, chair 0.02, other 0.01 m/s^2), P0 = I,
 *  and as measurement the object centroid (eq. 8): the box centre pixel
 *  back-projected at the median valid depth of the box's central window,
 *  in the camera frame (h(x) = R_cw p + t_cw).
 *
 *  An object is dynamic while its estimated speed exceeds its class's
 *  threshold (`speed_threshold`, the DOC threshold), and a new object is
 *  dynamic (NewObject) until `min_static_updates` consecutive updates say
 *  it is slow. classify() associates the boxes using the predicted pose
 *  (ctx.predicted_T_wc, else ctx.previous_T_wc) and labels keypoints in
 *  boxes of dynamic objects Dynamic (ObjectMoving / NewObject), those of
 *  static objects Movable (OnObject) with the object id; afterTracking()
 *  runs the EKF update with the estimated pose. Never lowers a label.
 *
 *  Guards of ours against apparent motion of static objects: the centroid
 *  measurement's std grows with the box's metric size (`size_sigma`; the
 *  box centre at the central depth is not a fixed point of the object), a
 *  box cut by the image border (`truncated_margin`) gives no measurement
 *  to an existing track (the visible part's centre slides over the object
 *  as the camera turns: a steady apparent motion), and a measurement outside the
 *  innovation gate (`gate_chi2`) is not fused; `max_gated` of them in a row
 *  restart the track at the measurement (NewObject). An object proven
 *  static becomes moving only when its velocity is also significantly
 *  non-zero (`moving_chi2` on v' P_v^-1 v). People (`guard_exempt_classes`)
 *  keep the paper's rule: they stop and start walking on their own. */
class EkfObjectTracker : public KeypointClassifier {
  DEFINE_MRPT_OBJECT(EkfObjectTracker, dslam)
 public:
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  void classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) override;
  void afterTracking(const Frame& frame, const Detections& det, const std::optional<SE3>& T_wc) override;
  void reset() override;

  /** Current tracks (public for tests and analysis). */
  const std::vector<TrackedObject>& tracks() const { return tracks_; }
  const TrackedObject* track(int id) const;
  /** Random-acceleration sigma (m/s^2) and speed threshold (m/s) of a class. */
  double sigmaAccel(int class_id) const;
  double speedThreshold(int class_id) const;

 private:
  struct Assoc {
    int frame = -1;
    std::vector<int> box_track;  ///< per box: index into tracks_, -1 new, -2 ignored
    std::vector<int> new_ids;    ///< per box: id reserved for a new track
  };
  Assoc associate(const Frame& f, const Detections& det, const std::optional<SE3>& T_wc) const;
  bool tracked(const BoundingBox& b) const;
  /** Predict + update of `o` with camera-frame centroid `zc` of `box`;
   *  false if the innovation gate rejected it (the track may restart). */
  bool fuse(TrackedObject& o, const Eigen::Vector3d& zc, const cv::Rect2f& box, const SE3& T_wc, double t_now,
            double fallback_dt) const;
  /** Whether the box touches the image border (within truncated_margin). */
  bool truncated(const cv::Rect2f& box, const Frame& f) const;

  std::vector<int> classes_, exempt_{1};
  double min_score_ = 0, iou_ = 0.3, meas_sigma_ = 0.05, p0_ = 1.0, center_fraction_ = 0.3;
  int min_static_ = 5, max_missed_ = 10, max_gated_ = 3;
  double truncated_margin_ = 5, gate_chi2_ = 11.34, size_sigma_ = 0.0, moving_chi2_ = 11.34;
  bool movable_ = true;
  std::map<int, double> sigma_a_, speed_thr_;
  double sigma_a_default_ = 0.01, speed_thr_default_ = 0.1;
  std::vector<TrackedObject> tracks_;
  int next_id_ = 1;
  Assoc pending_;
  CameraModel camera_;
  bool have_camera_ = false;
};

}  // namespace dslam
