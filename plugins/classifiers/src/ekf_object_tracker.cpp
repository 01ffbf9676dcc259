#include "dslam/plugins/classifiers/ekf_object_tracker.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include <Eigen/Dense>

#include "common.h"
#include "dslam/core/error.h"

IMPLEMENTS_MRPT_OBJECT(EkfObjectTracker, KeypointClassifier, dslam)

namespace dslam {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

std::string EkfObjectTracker::description() const {
  return "Changing-SLAM object tracking: one constant-velocity EKF per detected object (world frame); keypoints on "
         "moving or new objects are dynamic, on static ones movable";
}

std::vector<ParamSpec> EkfObjectTracker::paramSpecs() const {
  return {
      P_list("classes", ParamType::IntList, "[]", "COCO ids of the tracked boxes ([] = every detected class)"),
      P_double("min_score", 0, "ignore boxes with a lower score", 0, 1),
      P_double("iou_threshold", 0.3,
               "box IoU (same class) above which a box continues a track (Changing-SLAM 4.3; chosen default)", 0, 1),
      P_map("sigma_accel", "{person: 0.5, chair: 0.02, default: 0.01}",
            "random-acceleration noise (m/s^2) per class of the constant-velocity model (Changing-SLAM 4.4)"),
      P_map("speed_threshold", "{person: 0.2, default: 0.1}",
            "DOC threshold: speed (m/s) above which an object is dynamic, per class (Changing-SLAM 4.5; chosen "
            "defaults)"),
      P_double("measurement_sigma", 0.05, "std (m) of the centroid measurement per axis, camera frame (chosen default)",
               1e-6, 100),
      P_double("initial_covariance", 1.0, "P0 = this x identity (Changing-SLAM: P0 = I)", 1e-9, 1e9),
      P_int("min_static_updates", 5,
            "consecutive slow updates before a new (or moving) object counts as static (chosen default)", 0, 100000),
      P_int("max_missed", 10, "frames without a box before a track is dropped", 0, 100000),
      P_double("center_fraction", 0.3,
               "central window of the box (fraction of width/height) whose median depth places the centroid (eq. 8)",
               0.01, 1),
      P_list("guard_exempt_classes", ParamType::IntList, "[1]",
             "classes the two static-object guards below (cut boxes, significant motion) do not apply to: people "
             "stop and start walking on their own, the paper's rule catches them at once"),
      P_double("truncated_margin", 5,
               "a box within this many pixels (plus 5% of its size) of the image border is cut by it: its centre is "
               "not the object's, it gives no measurement to an existing track (chosen default; -1 = off)",
               -1, 10000),
      P_double("size_sigma", 0.0,
               "added std of the centroid measurement, as a fraction of the box's metric size (the box centre at "
               "the central depth slides over the object as the view changes; 0 = off, the default: it delays the "
               "detection of walking people)",
               0, 10),
      P_double("moving_chi2", 11.34,
               "an object proven static becomes moving only if also v' P_v^-1 v exceeds this (its velocity is "
               "significantly non-zero; 3 d.o.f., 11.34 = 99%; 0 = the paper's rule, speed above the threshold only)",
               0, 1e9),
      P_double("gate_chi2", 11.34,
               "innovation gate: a centroid measurement whose squared Mahalanobis distance exceeds this (3 d.o.f., "
               "11.34 = 99%) is not fused (a jump of the depth in the central window, another object); 0 = off",
               0, 1e9),
      P_int("max_gated", 3, "after this many consecutive gated measurements the track restarts at the measurement",
            1, 100000),
      P_bool("label_static_movable", true, "keypoints on tracked static objects are Movable (OnObject)"),
  };
}

void EkfObjectTracker::configure(const Params& p, const PluginContext& ctx) {
  KeypointClassifier::configure(p, ctx);
  classes_ = cls::cocoIdList(p, "classes");
  min_score_ = p.getDouble("min_score");
  iou_ = p.getDouble("iou_threshold");
  const cls::ClassValues sa = cls::classValues(p, "sigma_accel");
  sigma_a_ = sa.by_class;
  sigma_a_default_ = sa.fallback;
  const cls::ClassValues st = cls::classValues(p, "speed_threshold");
  speed_thr_ = st.by_class;
  speed_thr_default_ = st.fallback;
  for (const auto& [k, v] : sigma_a_)
    if (v < 0) p.fail("sigma_accel", "negative value for class " + std::to_string(k));
  if (sigma_a_default_ < 0) p.fail("sigma_accel", "negative default");
  meas_sigma_ = p.getDouble("measurement_sigma");
  p0_ = p.getDouble("initial_covariance");
  min_static_ = static_cast<int>(p.getInt("min_static_updates"));
  max_missed_ = static_cast<int>(p.getInt("max_missed"));
  center_fraction_ = p.getDouble("center_fraction");
  movable_ = p.getBool("label_static_movable");
  truncated_margin_ = p.getDouble("truncated_margin");
  exempt_ = cls::cocoIdList(p, "guard_exempt_classes");
  gate_chi2_ = p.getDouble("gate_chi2");
  size_sigma_ = p.getDouble("size_sigma");
  moving_chi2_ = p.getDouble("moving_chi2");
  max_gated_ = static_cast<int>(p.getInt("max_gated"));
  if (ctx.camera) {
    camera_ = *ctx.camera;
    have_camera_ = true;
  }
  reset();
}

void EkfObjectTracker::reset() {
  tracks_.clear();
  next_id_ = 1;
  pending_ = {};
}

double EkfObjectTracker::sigmaAccel(int c) const {
  auto it = sigma_a_.find(c);
  return it == sigma_a_.end() ? sigma_a_default_ : it->second;
}

double EkfObjectTracker::speedThreshold(int c) const {
  auto it = speed_thr_.find(c);
  return it == speed_thr_.end() ? speed_thr_default_ : it->second;
}

const TrackedObject* EkfObjectTracker::track(int id) const {
  for (const auto& t : tracks_)
    if (t.id == id) return &t;
  return nullptr;
}

bool EkfObjectTracker::truncated(const cv::Rect2f& box, const Frame& f) const {
  if (truncated_margin_ < 0) return false;
  const cv::Size sz = cls::imageSize(f, have_camera_ ? &camera_ : nullptr);
  // A detector's box edges jitter by a few percent of the box size.
  const float mx = static_cast<float>(truncated_margin_) + 0.05f * box.width,
              my = static_cast<float>(truncated_margin_) + 0.05f * box.height;
  return box.x <= mx || box.y <= my || box.x + box.width >= static_cast<float>(sz.width) - mx ||
         box.y + box.height >= static_cast<float>(sz.height) - my;
}

bool EkfObjectTracker::tracked(const BoundingBox& b) const {
  return b.score >= min_score_ && b.box.width > 0 && b.box.height > 0 &&
         (classes_.empty() || cls::contains(classes_, b.class_id));
}

namespace {

inline bool validDepth(float d) { return d > 0 && std::isfinite(d); }

float median(std::vector<float>& v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

/** Changing-SLAM eq. 8: object centroid in the camera frame from the box
 *  centre pixel and the median valid depth of the central window (depth
 *  image, else keypoint depths in the window, else in the whole box). */
std::optional<Eigen::Vector3d> centroidCam(const Frame& f, const cv::Rect2f& box, const CameraModel& cam, double cf) {
  const float cw = box.width * static_cast<float>(cf), ch = box.height * static_cast<float>(cf);
  const cv::Rect2f win(box.x + 0.5f * (box.width - cw), box.y + 0.5f * (box.height - ch), cw, ch);
  std::vector<float> d;
  const cv::Mat& depth = f.input.depth;
  if (!depth.empty() && depth.type() == CV_32F) {
    const cv::Rect r =
        cv::Rect(cv::Point(static_cast<int>(std::floor(win.x)), static_cast<int>(std::floor(win.y))),
                 cv::Point(static_cast<int>(std::ceil(win.x + win.width)), static_cast<int>(std::ceil(win.y + win.height)))) &
        cv::Rect(0, 0, depth.cols, depth.rows);
    for (int y = r.y; y < r.y + r.height; y++) {
      const float* row = depth.ptr<float>(y);
      for (int x = r.x; x < r.x + r.width; x++)
        if (validDepth(row[x])) d.push_back(row[x]);
    }
  }
  for (int pass = 0; pass < 2 && d.empty(); pass++)
    for (size_t i = 0; i < f.size() && i < f.depth.size(); i++)
      if (validDepth(f.depth[i]) && cls::inBox(f.keypoints[i].pt, pass == 0 ? win : box)) d.push_back(f.depth[i]);
  if (d.empty()) return std::nullopt;
  const double z = median(d);
  const cv::Point2f c(box.x + 0.5f * box.width, box.y + 0.5f * box.height);
  const cv::Point2f u = cls::undistortPixel(c, &cam);
  return cam.left.unproject(u.x, u.y, z);
}

}  // namespace

EkfObjectTracker::Assoc EkfObjectTracker::associate(const Frame& f, const Detections& det,
                                                    const std::optional<SE3>& T_wc) const {
  Assoc a;
  a.frame = f.index();
  a.box_track.assign(det.boxes.size(), -2);
  a.new_ids.assign(det.boxes.size(), -1);
  // Track boxes moved to the projection of the predicted object position.
  std::vector<cv::Rect2f> pred(tracks_.size());
  for (size_t t = 0; t < tracks_.size(); t++) {
    const TrackedObject& o = tracks_[t];
    pred[t] = o.box;
    if (!T_wc || !have_camera_ || !camera_.left.valid()) continue;
    const double dt = std::max(0.0, f.timestamp() - o.time);
    const Eigen::Vector3d pw = o.x.head<3>() + dt * o.x.tail<3>();
    const Eigen::Vector3d pc = T_wc->inverse() * pw;
    if (pc.z() < 0.05) continue;
    Eigen::Vector2d uv = camera_.left.project(pc);
    if (camera_.left.hasDistortion()) uv = camera_.left.distort(uv.x(), uv.y());
    pred[t] = cv::Rect2f(static_cast<float>(uv.x() - 0.5 * o.box.width), static_cast<float>(uv.y() - 0.5 * o.box.height),
                         o.box.width, o.box.height);
  }
  std::vector<std::tuple<float, int, int>> pairs;  // (-iou, box, track)
  for (size_t b = 0; b < det.boxes.size(); b++) {
    if (!tracked(det.boxes[b])) continue;
    a.box_track[b] = -1;
    for (size_t t = 0; t < tracks_.size(); t++) {
      if (tracks_[t].class_id != det.boxes[b].class_id) continue;
      const float v = iou(det.boxes[b].box, pred[t]);
      if (v > iou_) pairs.emplace_back(-v, static_cast<int>(b), static_cast<int>(t));
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<char> used(tracks_.size(), 0);
  for (const auto& [niou, b, t] : pairs) {
    if (a.box_track[b] >= 0 || used[t]) continue;
    a.box_track[b] = t;
    used[t] = 1;
  }
  int next = next_id_;
  for (size_t b = 0; b < det.boxes.size(); b++)
    if (a.box_track[b] == -1) a.new_ids[b] = next++;
  return a;
}

void EkfObjectTracker::classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) {
  cls::ensureMeta(frame);
  if (ctx.camera) {
    camera_ = *ctx.camera;
    have_camera_ = true;
  }
  pending_ = {};
  if (!det.valid) return;
  const std::optional<SE3> pose = ctx.predicted_T_wc ? ctx.predicted_T_wc : ctx.previous_T_wc;
  pending_ = associate(frame, det, pose);
  // The ids reserved for new tracks are on this frame's keypoints now (and
  // on the map points made of them): never given to another box, even when
  // afterTracking() creates no track (no pose, no depth in the box).
  for (int id : pending_.new_ids) next_id_ = std::max(next_id_, id + 1);
  for (size_t b = 0; b < det.boxes.size(); b++) {
    const int t = pending_.box_track[b];
    if (t == -2) continue;
    bool dyn = true;
    KpReason reason = KpReason::NewObject;
    int id = pending_.new_ids[b];
    if (t >= 0) {
      dyn = tracks_[t].dynamic;
      reason = tracks_[t].reason;
      id = tracks_[t].id;
    }
    const BoundingBox& bb = det.boxes[b];
    for (size_t i = 0; i < frame.size(); i++) {
      if (!cls::inBox(frame.keypoints[i].pt, bb.box)) continue;
      KeypointMeta& m = frame.meta[i];
      // Depth repopulation found it behind the object: it keeps no class
      // (the object map must not take the background into the object).
      const bool background = m.reason == KpReason::BoxBackground;
      if (dyn)
        cls::raise(m, KpLabel::Dynamic, reason);
      else if (movable_)
        cls::raise(m, KpLabel::Movable, KpReason::OnObject);
      if (m.class_id < 0 && !background) m.class_id = static_cast<int16_t>(bb.class_id);
      // The id of the box whose class it carries: a keypoint of the suitcase
      // inside the overlap with the fridge's box is the suitcase's, not the
      // fridge's (else it makes an object of its own: class suitcase, id of
      // the fridge). Keypoints of no class take the id of the first box.
      if (m.class_id == bb.class_id || (m.class_id < 0 && m.object_id < 0)) m.object_id = id;
    }
  }
}

bool EkfObjectTracker::fuse(TrackedObject& o, const Eigen::Vector3d& zc, const cv::Rect2f& box, const SE3& T_wc,
                            double t_now, double fallback_dt) const {
  const SE3 T_cw = T_wc.inverse();
  const Eigen::Matrix3d R_cw = T_cw.rotation();
  double dt = t_now - o.time;
  if (!(dt > 0)) dt = fallback_dt;
  // Predict: constant velocity, random acceleration (Changing-SLAM 4.4).
  Mat6 F = Mat6::Identity();
  F.block<3, 3>(0, 3) = dt * Eigen::Matrix3d::Identity();
  const double q = sigmaAccel(o.class_id) * sigmaAccel(o.class_id);
  Mat6 Q = Mat6::Zero();
  const Eigen::Matrix3d I3 = Eigen::Matrix3d::Identity();
  Q.block<3, 3>(0, 0) = q * dt * dt * dt * dt / 4 * I3;
  Q.block<3, 3>(0, 3) = q * dt * dt * dt / 2 * I3;
  Q.block<3, 3>(3, 0) = q * dt * dt * dt / 2 * I3;
  Q.block<3, 3>(3, 3) = q * dt * dt * I3;
  o.x = F * o.x;
  o.P = F * o.P * F.transpose() + Q;
  // Update: camera-frame centroid, h(x) = R_cw p + t_cw.
  Eigen::Matrix<double, 3, 6> H = Eigen::Matrix<double, 3, 6>::Zero();
  H.block<3, 3>(0, 0) = R_cw;
  const Eigen::Vector3d y = zc - (T_cw * Eigen::Vector3d(o.x.head<3>()));
  // The box centre at the central depth is not a fixed point of the object: it slides over it as the view
  // changes, by a fraction of the object's size.
  const double size_m = std::max(box.width, box.height) * zc.z() / std::max(1e-9, camera_.left.fx);
  const double sv = size_sigma_ * size_m;
  const Eigen::Matrix3d R = (meas_sigma_ * meas_sigma_ + sv * sv) * I3;
  const Eigen::Matrix3d S = H * o.P * H.transpose() + R;
  o.box = box;
  o.missed = 0;
  if (gate_chi2_ > 0 && y.dot(S.ldlt().solve(y)) > gate_chi2_) {
    // Not this object's motion (the central window's depth jumped to another surface, or another object):
    // not fused; repeated, the track starts again where the measurements are.
    if (++o.gated >= max_gated_) {
      o.x.head<3>() = T_wc * zc;
      o.x.tail<3>().setZero();
      o.P = p0_ * Mat6::Identity();
      o.time = t_now;
      o.updates = 1;
      o.gated = 0;
      o.static_count = 0;
      if (min_static_ > 0) {
        o.dynamic = true;
        o.reason = KpReason::NewObject;
      }
    }
    return false;
  }
  o.gated = 0;
  const Eigen::Matrix<double, 6, 3> K = o.P * H.transpose() * S.inverse();
  o.x += K * y;
  const Mat6 IKH = Mat6::Identity() - K * H;
  o.P = IKH * o.P * IKH.transpose() + K * R * K.transpose();  // Joseph form
  o.time = t_now;
  o.updates++;
  return true;
}

void EkfObjectTracker::afterTracking(const Frame& frame, const Detections& det, const std::optional<SE3>& T_wc) {
  if (!det.valid || !T_wc) {  // nothing to place in the world: keep the tracks as they are
    pending_ = {};
    return;
  }
  if (!have_camera_ && ctx_.camera) {
    camera_ = *ctx_.camera;
    have_camera_ = true;
  }
  if (!have_camera_ || !camera_.left.valid())
    throw Error("EkfObjectTracker: no camera model (classify() without ClassifierContext::camera)");
  const Assoc a = (pending_.frame == frame.index() && pending_.box_track.size() == det.boxes.size())
                      ? pending_
                      : associate(frame, det, T_wc);
  pending_ = {};
  const double t_now = frame.timestamp();
  const double fallback_dt = camera_.fps > 0 ? 1.0 / camera_.fps : 1.0 / 30.0;
  std::vector<char> seen(tracks_.size(), 0);
  std::vector<TrackedObject> created;

  for (size_t b = 0; b < det.boxes.size(); b++) {
    const int ti = a.box_track[b];
    if (ti == -2) continue;
    const BoundingBox& bb = det.boxes[b];
    if (ti >= 0) seen[ti] = 1;
    const auto zc = centroidCam(frame, bb.box, camera_, center_fraction_);
    if (!zc) continue;  // no depth: no measurement this frame
    if (ti < 0) {
      TrackedObject o;
      o.id = a.new_ids[b];
      o.class_id = bb.class_id;
      o.x.head<3>() = *T_wc * *zc;
      o.P = p0_ * Mat6::Identity();
      o.box = bb.box;
      o.time = t_now;
      o.updates = 1;
      created.push_back(o);
      continue;
    }
    TrackedObject& o = tracks_[ti];
    if (!cls::contains(exempt_, o.class_id) && truncated(bb.box, frame)) {
      // Cut by the image border: the visible part's centre slides over the object as the view changes (a
      // steady apparent motion), no measurement of where it is. The track follows the box; the decision
      // below is made on the state as it is (slow: a step towards static).
      o.box = bb.box;
      o.missed = 0;
    } else if (!fuse(o, *zc, bb.box, *T_wc, t_now, fallback_dt)) {
      continue;  // gated out (or restarted)
    }
    // Decision (Changing-SLAM 4.5).
    // Ours: an object proven static becomes moving only when its velocity also differs from zero by more
    // than its uncertainty (a noisy or sliding centroid is no evidence of motion); new and moving objects
    // keep the paper's rule.
    const Eigen::Vector3d v = o.x.tail<3>();
    const bool moving = o.speed() > speedThreshold(o.class_id) &&
                        (o.dynamic || moving_chi2_ <= 0 || cls::contains(exempt_, o.class_id) ||
                         v.dot(o.P.block<3, 3>(3, 3).ldlt().solve(v)) > moving_chi2_);
    if (moving) {
      o.static_count = 0;
      o.dynamic = true;
      o.reason = KpReason::ObjectMoving;
    } else {
      o.static_count++;
      if (o.static_count >= min_static_) {
        o.dynamic = false;
        o.reason = KpReason::None;
      }
    }
  }
  // Missed tracks, then the new ones.
  std::vector<TrackedObject> kept;
  for (size_t t = 0; t < tracks_.size(); t++) {
    if (!seen[t]) tracks_[t].missed++;
    if (tracks_[t].missed <= max_missed_) kept.push_back(tracks_[t]);
  }
  for (auto& o : created) {
    if (min_static_ == 0) {
      o.dynamic = false;
      o.reason = KpReason::None;
    }
    next_id_ = std::max(next_id_, o.id + 1);
    kept.push_back(o);
  }
  tracks_ = std::move(kept);
}

}  // namespace dslam
