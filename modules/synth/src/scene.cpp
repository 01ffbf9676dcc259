#include "dslam/synth/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dslam/core/coco.h"
#include "dslam/synth/rng.h"

namespace dslam::synth {

namespace {

using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
constexpr double kDeg = M_PI / 180.0;

Mat3 rotZ(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }
Mat3 rotY(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }
Mat3 rotX(double a) { return Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix(); }

/** Camera (OpenCV axes) looking along world +x with z up. */
Mat3 cameraBase() {
  Mat3 B;
  B.col(0) = Vec3(0, -1, 0);
  B.col(1) = Vec3(0, 0, -1);
  B.col(2) = Vec3(1, 0, 0);
  return B;
}

Mat3 lookAt(const Vec3& p, const Vec3& target) {
  Vec3 z = (target - p).normalized();
  Vec3 x = z.cross(Vec3::UnitZ());
  if (x.norm() < 1e-6) x = Vec3(0, -1, 0);
  x.normalize();
  const Vec3 y = z.cross(x);
  Mat3 R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return R;
}

/** roll about the optical axis, pitch up, yaw about world z (0 = +x). */
Mat3 rpyToR(const Vec3& rpy) { return rotZ(rpy.z()) * rotY(-rpy.y()) * cameraBase() * rotZ(rpy.x()); }

double smooth(double u) { return u * u * (3 - 2 * u); }

/** Rotation taking local z to direction d. */
Mat3 alignZ(const Vec3& d) {
  const Vec3 z = d.normalized();
  return Quat::FromTwoVectors(Vec3::UnitZ(), z).toRotationMatrix();
}

double boundRadius(const Primitive& p) {
  switch (p.kind) {
    case Primitive::Kind::Box: return p.half.norm();
    case Primitive::Kind::Cylinder: return std::hypot(std::max(p.half.x(), p.half.y()), p.half.z());
    case Primitive::Kind::Ellipsoid: return p.half.maxCoeff();
    case Primitive::Kind::Capsule: return p.half.z() + p.half.x();
    case Primitive::Kind::Quad: return std::hypot(p.half.y(), p.half.z());
  }
  return 0;
}

Primitive make(Primitive::Kind k, const SE3& T, const Vec3& half, int inst, int mat, Vec3 uv = Vec3::Zero()) {
  Primitive p;
  p.kind = k;
  p.T_wl = T;
  p.half = half;
  p.instance_id = inst;
  p.material = mat;
  p.uv_offset = uv;
  p.bound_radius = boundRadius(p);
  return p;
}

Primitive capsule(const Vec3& a, const Vec3& b, double r, int inst, int mat, Vec3 uv = Vec3::Zero()) {
  const Vec3 d = b - a;
  const double L = std::max(d.norm(), 1e-6);
  return make(Primitive::Kind::Capsule, SE3(alignZ(d), (a + b) / 2), Vec3(r, r, L / 2), inst, mat, uv);
}

/** Polyline point and direction at arc length s (piecewise linear). */
struct Polyline {
  std::vector<Vec3> pts;
  std::vector<double> cum;  ///< cumulative length at each point
  double length() const { return cum.empty() ? 0 : cum.back(); }
  void build(const std::vector<Vec3>& p) {
    pts = p;
    cum.assign(p.size(), 0);
    for (size_t i = 1; i < p.size(); i++) cum[i] = cum[i - 1] + (p[i] - p[i - 1]).norm();
  }
  size_t segment(double s) const {
    size_t i = 0;
    while (i + 2 < pts.size() && s > cum[i + 1]) i++;
    return i;
  }
  Vec3 at(double s) const {
    if (pts.size() == 1) return pts[0];
    const size_t i = segment(s);
    const double len = cum[i + 1] - cum[i];
    const double u = len > 1e-9 ? std::clamp((s - cum[i]) / len, 0.0, 1.0) : 0.0;
    return pts[i] + u * (pts[i + 1] - pts[i]);
  }
  Vec3 dir(size_t i) const {
    Vec3 d = pts[std::min(i + 1, pts.size() - 1)] - pts[std::min(i, pts.size() - 2)];
    d.z() = 0;
    return d.norm() > 1e-9 ? d.normalized() : Vec3(1, 0, 0);
  }
  /** Heading (rad) at s, turning smoothly within `blend` m of a corner. */
  double heading(double s, double blend, bool closed) const {
    const size_t i = segment(s);
    const Vec3 d = dir(i);
    double h = std::atan2(d.y(), d.x());
    const bool has_next = i + 2 < pts.size() || closed;
    const bool has_prev = i > 0 || closed;
    const double to_end = cum[i + 1] - s, from_start = s - cum[i];
    auto angleTo = [](double a, double b) {
      double dd = std::remainder(b - a, 2 * M_PI);
      if (std::abs(std::abs(dd) - M_PI) < 1e-6) dd = M_PI;  // U-turns turn left
      return dd;
    };
    // U-turns happen almost in place, gentle corners over `blend` metres.
    auto width = [&](double dd) { return std::abs(dd) > 2.6 ? std::min(blend, 0.12) : blend; };
    const Vec3 dn = dir(i + 2 < pts.size() ? i + 1 : 0);
    const Vec3 dp = dir(i > 0 ? i - 1 : pts.size() - 2);
    const double dnext = angleTo(h, std::atan2(dn.y(), dn.x()));
    const double dprev = angleTo(h, std::atan2(dp.y(), dp.x()));
    if (has_next && to_end < width(dnext)) {
      h += dnext * 0.5 * (1 - to_end / width(dnext));
    } else if (has_prev && from_start < width(dprev)) {
      h += dprev * 0.5 * (1 - from_start / width(dprev));
    }
    return h;
  }
};

/** Unfolded polyline of a path (pingpong: there and back; loop: closed). */
Polyline pathPolyline(const PathSpec& p) {
  std::vector<Vec3> pts = p.waypoints;
  if (p.mode == "pingpong")
    for (int i = static_cast<int>(p.waypoints.size()) - 2; i >= 0; i--) pts.push_back(p.waypoints[i]);
  else if (p.mode == "loop")
    pts.push_back(p.waypoints[0]);
  Polyline pl;
  pl.build(pts);
  return pl;
}

/** Arc length travelled at time t. */
double pathArc(const PathSpec& p, const Polyline& pl, double t) {
  const double tau = std::max(0.0, t - p.start) * p.speed;
  const double L = pl.length();
  if (L <= 0) return 0;
  if (p.mode == "once") return std::min(tau, L);
  return std::fmod(tau, L);
}

/** Cubic Hermite between keyframes i and i+1 of values V (tangents by
 *  finite differences in time, zero at the first and last keyframe). */
Vec3 hermite(const std::vector<Vec3>& V, const std::vector<CameraKeyframe>& K, size_t i, double u) {
  const double dt = K[i + 1].t - K[i].t;
  auto tangent = [&](size_t j) {
    Vec3 m = Vec3::Zero();
    if (j > 0 && j + 1 < K.size()) m = (V[j + 1] - V[j - 1]) / (K[j + 1].t - K[j - 1].t);
    return Vec3(m * dt);
  };
  const Vec3 m0 = tangent(i), m1 = tangent(i + 1);
  const double u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * V[i] + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * V[i + 1] + (u3 - u2) * m1;
}

}  // namespace

double signedDistance(const Primitive& prim, const Vec3& pw) {
  const Vec3 p = prim.T_wl.inverse() * pw;
  const Vec3& h = prim.half;
  switch (prim.kind) {
    case Primitive::Kind::Box: {
      const Vec3 q = p.cwiseAbs() - h;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    case Primitive::Kind::Cylinder: {
      const double rr = std::hypot(p.x() / h.x(), p.y() / h.y());
      const double dr = (rr - 1) * std::min(h.x(), h.y());
      const double dz = std::abs(p.z()) - h.z();
      return std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0);
    }
    case Primitive::Kind::Ellipsoid: {
      const double k0 = p.cwiseQuotient(h).norm();
      const double k1 = p.cwiseQuotient(h.cwiseProduct(h)).norm();
      if (k1 < 1e-12) return -h.minCoeff();
      return k0 * (k0 - 1) / k1;
    }
    case Primitive::Kind::Capsule: {
      const double z = std::clamp(p.z(), -h.z(), h.z());
      return (p - Vec3(0, 0, z)).norm() - h.x();
    }
    case Primitive::Kind::Quad: {
      const double dy = std::max(std::abs(p.y()) - h.y(), 0.0), dz = std::max(std::abs(p.z()) - h.z(), 0.0);
      return std::sqrt(p.x() * p.x() + dy * dy + dz * dz);
    }
  }
  return std::numeric_limits<double>::infinity();
}

SceneModel::SceneModel(const Scenario& s) : s_(s) {
  Rng rng(s_.seed, 0x5ce7e);
  auto addMat = [&](TextureSpec t, double w, double h) {
    if (t.seed == 0) t.seed = rng.next() | 1;
    else rng.next();
    materials_.push_back({t, w, h});
    return static_cast<int>(materials_.size() - 1);
  };
  const Vec3& R = s_.room.size;
  room_mat_[0] = addMat(s_.room.walls[0], R.y(), R.z());
  room_mat_[1] = addMat(s_.room.walls[1], R.y(), R.z());
  room_mat_[2] = addMat(s_.room.walls[2], R.x(), R.z());
  room_mat_[3] = addMat(s_.room.walls[3], R.x(), R.z());
  room_mat_[4] = addMat(s_.room.floor, R.x(), R.y());
  room_mat_[5] = addMat(s_.room.ceiling, R.x(), R.y());

  instances_.resize(1 + s_.objects.size() + s_.people.size());
  instances_[0] = {0, "room", "room", 0, true, false, false};
  for (const auto& o : s_.objects) {
    const Vec3& z = o.size;
    object_mat_.push_back(addMat(o.texture, 2 * (z.x() + z.y()) + 0.1, z.z() + std::max(z.x(), z.y()) + 0.1));
    InstanceInfo ii;
    ii.instance_id = o.instance_id;
    ii.name = o.name;
    ii.class_name = o.class_name;
    ii.category_id = o.labelled ? o.category_id : 0;
    ii.labelled = o.labelled;
    ii.is_person = o.labelled && o.category_id == coco::kPerson;
    ii.isthing = o.labelled ? coco::isThing(o.category_id) : true;
    instances_[o.instance_id] = ii;
  }
  for (const auto& p : s_.people) {
    TextureSpec skin{"skin", p.skin, true, 1.0, 0};
    TextureSpec hair{"plain", p.hair, true, 1.0, 0};
    TextureSpec shoes{"plain", {0.12, 0.1, 0.09}, true, 1.0, 0};
    person_mat_.push_back({addMat(p.shirt, 1.2, 0.9), addMat(p.pants, 0.8, 1.0), addMat(skin, 0.6, 0.6),
                           addMat(hair, 0.6, 0.6), addMat(shoes, 0.4, 0.4)});
    InstanceInfo ii;
    ii.instance_id = p.instance_id;
    ii.name = p.name;
    ii.class_name = "person";
    ii.category_id = coco::kPerson;
    ii.is_person = true;
    instances_[p.instance_id] = ii;
  }
  // Handheld shake: three sinusoids per axis with seeded frequencies/phases.
  Rng jr(s_.seed, 0x5a4e);
  for (int i = 0; i < 18; i++) {
    jit_freq_.push_back(Vec3(0.15 + 1.2 * jr.uniform(), 0.15 + 1.2 * jr.uniform(), 0.15 + 1.2 * jr.uniform()));
    jit_phase_.push_back(Vec3(2 * M_PI * jr.uniform(), 2 * M_PI * jr.uniform(), 2 * M_PI * jr.uniform()));
  }
}

SE3 SceneModel::cameraPoseAt(double t) const {
  const TrajectorySpec& T = s_.trajectory;
  Vec3 p = T.center;
  Mat3 R = Mat3::Identity();
  const double w = 2 * M_PI / T.period;
  if (T.type == "static") {
    R = lookAt(T.center, T.look_at);
  } else if (T.type == "xyz") {
    const Mat3 R0 = lookAt(T.center, T.look_at);
    p = T.center + T.amplitude * (std::sin(w * t) * R0.col(0) - 0.7 * std::sin(w * t / 1.37 + 1.0) * R0.col(1) +
                                  0.6 * std::sin(w * t / 1.71 + 2.0) * R0.col(2));
    R = R0;
  } else if (T.type == "rpy") {
    const double A = T.amplitude * kDeg;
    R = lookAt(T.center, T.look_at) * rotY(A * std::sin(w * t)) * rotX(0.6 * A * std::sin(w * t / 1.37 + 1.0)) *
        rotZ(0.6 * A * std::sin(w * t / 1.71 + 2.0));
  } else if (T.type == "halfsphere") {
    Vec3 d0 = T.look_at - T.center;
    d0.z() = 0;
    d0 = d0.norm() > 1e-9 ? d0.normalized() : Vec3(1, 0, 0);
    const double az = 1.1 * std::sin(w * t);
    const double el = 0.7 * 0.5 * (1 - std::cos(w * t / 1.5));
    const Vec3 side = Vec3::UnitZ().cross(d0);
    const Vec3 v = Eigen::AngleAxisd(az, Vec3::UnitZ()) * (Eigen::AngleAxisd(-el, side) * (-d0));
    p = T.center + T.radius * v + T.radius * d0;  // starts at the centre
    R = lookAt(p, T.look_at);
  } else if (T.type == "orbit") {
    const double th = w * t;
    p = T.center + T.radius * Vec3(std::cos(th), std::sin(th), 0);
    R = rpyToR(Vec3(0, T.pitch * kDeg, th + M_PI / 2 - T.heading * kDeg));
  } else {  // keyframes
    const auto& K = T.keyframes;
    auto rotOf = [&](const CameraKeyframe& k) { return k.look_at ? lookAt(k.position, *k.look_at) : rpyToR(k.rpy); };
    if (K.size() == 1 || t <= K.front().t) {
      p = K.front().position;
      R = rotOf(K.front());
    } else if (t >= K.back().t) {
      p = K.back().position;
      R = rotOf(K.back());
    } else {
      size_t i = 0;
      while (i + 2 < K.size() && t > K[i + 1].t) i++;
      const double t0 = K[i].t, t1 = K[i + 1].t, dt = t1 - t0;
      const double u = std::clamp((t - t0) / dt, 0.0, 1.0);
      if (T.interpolation == "linear") {
        p = K[i].position + u * (K[i + 1].position - K[i].position);
        R = Quat(rotOf(K[i])).slerp(u, Quat(rotOf(K[i + 1]))).toRotationMatrix();
      } else {
        // Cubic Hermite with finite-difference tangents (zero at the ends).
        std::vector<Vec3> P(K.size()), A(K.size());
        for (size_t j = 0; j < K.size(); j++) {
          P[j] = K[j].position;
          A[j] = K[j].look_at ? *K[j].look_at : Vec3(K[j].position);
        }
        p = hermite(P, K, i, u);
        bool all_look = true;
        for (size_t j = (i > 0 ? i - 1 : 0); j <= std::min(i + 2, K.size() - 1); j++)
          all_look = all_look && K[j].look_at.has_value();
        if (all_look)
          R = lookAt(p, hermite(A, K, i, u));
        else
          R = Quat(rotOf(K[i])).slerp(smooth(u), Quat(rotOf(K[i + 1]))).toRotationMatrix();
      }
    }
  }
  // Handheld shake.
  if (T.jitter_position > 0 || T.jitter_rotation > 0) {
    auto noise = [&](int base) {
      Vec3 v = Vec3::Zero();
      for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
          v[a] += std::sin(2 * M_PI * jit_freq_[base + k][a] * t + jit_phase_[base + k][a]) / 1.7;
      return v;
    };
    p += T.jitter_position * noise(0);
    const Vec3 r = T.jitter_rotation * kDeg * noise(3);
    R = R * Eigen::AngleAxisd(r.norm(), r.norm() > 1e-12 ? Vec3(r.normalized()) : Vec3::UnitZ()).toRotationMatrix();
  }
  return SE3(R, p);
}

SE3 SceneModel::rightCameraPose(int frame) const {
  return cameraPose(frame) * SE3(Eigen::Quaterniond::Identity(), Vec3(s_.baseline, 0, 0));
}

ObjectState SceneModel::objectState(size_t i, int frame) const { return objectStateAt(i, s_.time(frame), frame); }

ObjectState SceneModel::objectStateAt(size_t i, double t, int frame) const {
  const ObjectSpec& o = s_.objects.at(i);
  ObjectState st;
  st.present = o.present;
  Vec3 pos = o.position;
  double yaw = o.yaw;
  if (!o.path.empty()) {
    const Polyline pl = pathPolyline(o.path);
    pos = pl.at(pathArc(o.path, pl, t));
  }
  // Events in order of their first frame (stable for ties: file order).
  std::vector<const EventSpec*> evs;
  for (const auto& e : s_.events)
    if (e.object == o.name || e.by == o.name) evs.push_back(&e);
  std::stable_sort(evs.begin(), evs.end(), [](auto* a, auto* b) { return a->first < b->first; });
  for (const EventSpec* e : evs) {
    if (frame < e->first) break;
    if (e->type == "removed" && e->object == o.name) st.present = false;
    if (e->type == "added" && e->object == o.name) st.present = true;
    if (e->type == "replaced") st.present = (e->by == o.name);
    if (e->type == "moved") {
      const double target_yaw = e->has_yaw ? e->yaw : yaw;
      if (frame >= e->last) {
        pos = e->position;
        yaw = target_yaw;
      } else {
        const double uu =
            smooth(std::clamp((t - s_.time(e->first)) / (s_.time(e->last) - s_.time(e->first)), 0.0, 1.0));
        pos = pos + uu * (e->position - pos);
        yaw = yaw + uu * std::remainder(target_yaw - yaw, 2 * M_PI);
      }
    }
  }
  st.T_wo = SE3(Mat3(rotZ(yaw) * rotY(-o.pitch)), pos);
  return st;
}

bool SceneModel::personPresent(size_t i, int frame) const {
  const PersonSpec& p = s_.people.at(i);
  const double t = s_.time(frame);
  if (p.enter >= 0 && t < p.enter) return false;
  if (p.leave >= 0 && t >= p.leave) return false;
  return true;
}

SE3 SceneModel::personRoot(size_t i, double t) const {
  const PersonSpec& p = s_.people.at(i);
  const double k = p.height / 1.75;
  if (p.action == "walk") {
    const Polyline pl = pathPolyline(p.path);
    const double s = pathArc(p.path, pl, t);
    Vec3 pos = pl.at(s);
    const double h = pl.heading(s, 0.4, p.path.mode != "once");
    const double phase = 2 * M_PI * s / (1.45 * k);
    pos.z() = 0.92 * k + 0.015 * k * std::cos(2 * phase);
    return SE3(Mat3(rotZ(h)), pos);
  }
  Vec3 pos = p.position;
  double yaw = p.yaw;
  if (p.action == "sit") {
    pos.z() = p.seat_height + 0.07 * k;
    yaw += 0.04 * std::sin(0.5 * t + p.instance_id);
  } else {
    pos.z() = 0.92 * k;
    yaw += 0.05 * std::sin(0.3 * t + p.instance_id);
  }
  return SE3(Mat3(rotZ(yaw)), pos);
}

std::vector<Primitive> SceneModel::personPrimitives(size_t i, int frame, double t) const {
  std::vector<Primitive> out;
  if (!personPresent(i, frame)) return out;
  const PersonSpec& p = s_.people.at(i);
  const auto& m = person_mat_.at(i);
  const int id = p.instance_id;
  const double k = p.height / 1.75;
  const SE3 root = personRoot(i, t);
  const double ph = 0.7 * id;  // per-person phase of idle motions
  // Joint angles (radians): hip/shoulder flexion forward, knee/elbow flexion.
  double hipL = 0, hipR = 0, kneeL = 0.05, kneeR = 0.05, shL = 0.05, shR = 0.05, elL = 0.2, elR = 0.2, head = 0;
  double lean = 0;
  if (p.action == "walk") {
    const Polyline pl = pathPolyline(p.path);
    const double s = pathArc(p.path, pl, t);
    double amp = 1.0;
    if (p.path.mode == "once") amp = std::clamp((pl.length() - s) / 0.4, 0.0, 1.0);
    if (t < p.path.start) amp = 0;
    const double phase = 2 * M_PI * s / (1.45 * k);
    hipL = amp * 0.42 * std::sin(phase);
    hipR = -hipL;
    kneeL = 0.08 + amp * 0.6 * std::max(0.0, std::cos(phase));
    kneeR = 0.08 + amp * 0.6 * std::max(0.0, -std::cos(phase));
    shL = -amp * 0.35 * std::sin(phase);
    shR = -shL;
    elL = 0.25 + amp * 0.2 * std::max(0.0, -std::sin(phase));
    elR = 0.25 + amp * 0.2 * std::max(0.0, std::sin(phase));
    head = 0.15 * std::sin(0.4 * t + ph);
    lean = 0.04 * amp;
  } else if (p.action == "sit") {
    hipL = hipR = M_PI / 2;
    kneeL = M_PI / 2 + 0.12 * std::sin(0.45 * t + ph);
    kneeR = M_PI / 2 - 0.1 * std::sin(0.35 * t + 2 * ph);
    shL = 0.55 + 0.25 * std::sin(0.7 * t + ph);
    shR = 0.5 + 0.3 * std::sin(0.55 * t + 3 * ph);
    elL = 1.0 + 0.35 * std::sin(1.1 * t + ph);
    elR = 1.1 + 0.3 * std::sin(0.9 * t + 2 * ph);
    head = 0.35 * std::sin(0.3 * t + ph);
    lean = -0.05 + 0.04 * std::sin(0.25 * t + ph);
  } else {  // stand
    shL = 0.08 + 0.15 * std::sin(0.6 * t + ph);
    shR = 0.08 + 0.2 * std::sin(0.5 * t + 2 * ph);
    elL = 0.3 + 0.3 * std::sin(0.8 * t + ph);
    elR = 0.4 + 0.25 * std::sin(0.7 * t + 3 * ph);
    head = 0.3 * std::sin(0.35 * t + ph);
  }
  auto W = [&](const Vec3& local) { return root * local; };
  auto dirW = [&](const Vec3& d) { return Vec3(root.rotation() * d); };
  auto sag = [](double a) { return Vec3(std::sin(a), 0, -std::cos(a)); };
  const SE3 upper = root * SE3(Mat3(rotY(lean)), Vec3::Zero());  // torso lean about the hips
  auto U = [&](const Vec3& local) { return upper * local; };
  const Mat3 Ru = upper.rotation();
  // Lower body (hip joints at the root height).
  for (int side = -1; side <= 1; side += 2) {
    const double hip = side > 0 ? hipL : hipR, knee = side > 0 ? kneeL : kneeR;
    const Vec3 hipJ(0, side * 0.09 * k, 0);
    const Vec3 kneeJ = hipJ + 0.43 * k * sag(hip);
    const Vec3 ankle = kneeJ + 0.42 * k * sag(hip - knee);
    out.push_back(capsule(W(hipJ), W(kneeJ), 0.068 * k, id, m[1], Vec3(side * 0.3, 0, 0)));
    out.push_back(capsule(W(kneeJ), W(ankle), 0.05 * k, id, m[1], Vec3(side * 0.3 + 0.11, 0.45, 0)));
    const Vec3 footC = ankle + Vec3(0.05 * k, 0, -0.035 * k);
    out.push_back(make(Primitive::Kind::Box, SE3(root.rotation(), W(footC)), Vec3(0.12, 0.045, 0.035) * k, id, m[4]));
  }
  // Pelvis, torso, shoulders.
  out.push_back(make(Primitive::Kind::Cylinder, SE3(Ru, U(Vec3(0, 0, 0.05 * k))), Vec3(0.11, 0.17, 0.09) * k, id,
                     m[1], Vec3(0, 0.3, 0)));
  out.push_back(make(Primitive::Kind::Cylinder, SE3(Ru, U(Vec3(0, 0, 0.32 * k))), Vec3(0.115, 0.18, 0.2) * k, id,
                     m[0]));
  const Vec3 shLpos(0, 0.2 * k, 0.5 * k), shRpos(0, -0.2 * k, 0.5 * k);
  out.push_back(capsule(U(Vec3(0, 0.15 * k, 0.5 * k)), U(Vec3(0, -0.15 * k, 0.5 * k)), 0.065 * k, id, m[0],
                        Vec3(0.2, 0.5, 0)));
  // Neck and head (head turns about the vertical axis).
  out.push_back(capsule(U(Vec3(0, 0, 0.52 * k)), U(Vec3(0.01 * k, 0, 0.62 * k)), 0.05 * k, id, m[2]));
  const Mat3 Rh = Ru * rotZ(head);
  out.push_back(make(Primitive::Kind::Ellipsoid, SE3(Rh, U(Vec3(0.01 * k, 0, 0.70 * k))), Vec3(0.1, 0.085, 0.115) * k,
                     id, m[2]));
  out.push_back(make(Primitive::Kind::Ellipsoid, SE3(Rh, U(Vec3(0, 0, 0.70 * k)) + Rh * Vec3(-0.022, 0, 0.035) * k),
                     Vec3(0.095, 0.09, 0.095) * k, id, m[3]));
  // Arms.
  for (int side = -1; side <= 1; side += 2) {
    const double sh = side > 0 ? shL : shR, el = side > 0 ? elL : elR;
    const Vec3 s0 = side > 0 ? shLpos : shRpos;
    Vec3 d1 = sag(sh);
    d1.y() = side * 0.1;
    const Vec3 elbow = s0 + 0.29 * k * d1.normalized();
    Vec3 d2 = sag(sh + el);
    d2.y() = side * 0.05;
    const Vec3 wrist = elbow + 0.26 * k * d2.normalized();
    out.push_back(capsule(U(s0), U(elbow), 0.046 * k, id, m[0], Vec3(side * 0.25 + 0.5, 0.1, 0)));
    out.push_back(capsule(U(elbow), U(wrist), 0.039 * k, id, m[0], Vec3(side * 0.25 + 0.7, 0.4, 0)));
    out.push_back(make(Primitive::Kind::Ellipsoid, SE3(Ru, U(wrist + 0.05 * k * d2.normalized())),
                       Vec3(0.045, 0.025, 0.05) * k, id, m[2]));
  }
  (void)dirW;
  return out;
}

std::vector<Primitive> SceneModel::objectPrimitives(size_t i, int frame, double t) const {
  std::vector<Primitive> out;
  const ObjectState st = objectStateAt(i, t, frame);
  if (!st.present) return out;
  const ObjectSpec& o = s_.objects.at(i);
  const int id = o.instance_id, mat = object_mat_.at(i);
  const Vec3& z = o.size;
  const Mat3 R = st.T_wo.rotation();
  auto P = [&](Primitive::Kind k, const Vec3& c, const Vec3& half, Vec3 uv = Vec3::Zero()) {
    out.push_back(make(k, SE3(R, st.T_wo * c), half, id, mat, uv));
  };
  using K = Primitive::Kind;
  if (o.type == "box" || o.type == "shelf") {
    P(K::Box, {0, 0, z.z() / 2}, z / 2);
  } else if (o.type == "cylinder") {
    P(K::Cylinder, {0, 0, z.z() / 2}, z / 2);
  } else if (o.type == "sphere") {
    P(K::Ellipsoid, {0, 0, z.z() / 2}, z / 2);
  } else if (o.type == "quad") {
    P(K::Quad, {0, 0, z.z() / 2}, Vec3(0, z.y() / 2, z.z() / 2));
  } else if (o.type == "table") {
    const double th = 0.04;
    P(K::Box, {0, 0, z.z() - th / 2}, {z.x() / 2, z.y() / 2, th / 2});
    int n = 0;
    for (int a = -1; a <= 1; a += 2)
      for (int b = -1; b <= 1; b += 2)
        P(K::Box, {a * (z.x() / 2 - 0.06), b * (z.y() / 2 - 0.06), (z.z() - th) / 2},
          {0.03, 0.03, (z.z() - th) / 2}, Vec3(0.3 * ++n, 0, 0));
  } else if (o.type == "chair") {
    const double hs = 0.46 * z.z() / 0.9;
    P(K::Box, {0, 0, hs - 0.03}, {z.x() / 2, z.y() / 2, 0.03});
    int n = 0;
    for (int a = -1; a <= 1; a += 2)
      for (int b = -1; b <= 1; b += 2)
        P(K::Cylinder, {a * (z.x() / 2 - 0.04), b * (z.y() / 2 - 0.04), (hs - 0.06) / 2},
          {0.018, 0.018, (hs - 0.06) / 2}, Vec3(0.2 * ++n, 0.3, 0));
    P(K::Box, {-z.x() / 2 + 0.025, 0, hs + (z.z() - hs) / 2}, {0.025, z.y() / 2, (z.z() - hs) / 2}, Vec3(0.7, 0.2, 0));
  } else if (o.type == "monitor") {
    P(K::Box, {0, 0, z.z() * 0.62}, {0.025, z.y() / 2, z.z() * 0.38});
    P(K::Cylinder, {-0.03, 0, z.z() * 0.14}, {0.025, 0.025, z.z() * 0.14}, Vec3(0.5, 0, 0));
    P(K::Box, {-0.03, 0, 0.008}, {z.x() / 2, 0.11, 0.008}, Vec3(0.9, 0, 0));
  } else if (o.type == "plant") {
    P(K::Cylinder, {0, 0, z.z() * 0.17}, {z.x() * 0.3, z.y() * 0.3, z.z() * 0.17}, Vec3(0, 0.6, 0));
    P(K::Ellipsoid, {0, 0, z.z() * 0.64}, {z.x() / 2, z.y() / 2, z.z() * 0.36});
  }
  return out;
}

std::vector<Primitive> SceneModel::primitivesAt(int frame, double t) const {
  std::vector<Primitive> out;
  for (size_t i = 0; i < s_.objects.size(); i++) {
    auto v = objectPrimitives(i, frame, t);
    out.insert(out.end(), v.begin(), v.end());
  }
  for (size_t i = 0; i < s_.people.size(); i++) {
    auto v = personPrimitives(i, frame, t);
    out.insert(out.end(), v.begin(), v.end());
  }
  return out;
}

std::vector<Primitive> SceneModel::primitives(int frame) const { return primitivesAt(frame, s_.time(frame)); }

double SceneModel::distanceToInstance(int frame, int instance_id, const Vec3& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& prim : primitives(frame))
    if (prim.instance_id == instance_id) best = std::min(best, signedDistance(prim, p));
  return best;
}

}  // namespace dslam::synth
