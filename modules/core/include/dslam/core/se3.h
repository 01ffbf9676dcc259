#pragma once
/** \file se3.h
 *  Minimal rigid-body transform on Eigen, used by every module instead of the
 *  heavier mrpt::poses types on hot paths.
 *
 *  Convention: `SE3 T_ab` maps points from frame b into frame a
 *  (p_a = T_ab * p_b). Trajectories store T_wc (camera-to-world, the TUM
 *  convention: translation = camera centre in the world). */
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dslam {

class SE3 {
 public:
  using Vec3 = Eigen::Vector3d;
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  using Mat3 = Eigen::Matrix3d;
  using Mat4 = Eigen::Matrix4d;

  SE3() : q_(Eigen::Quaterniond::Identity()), t_(Vec3::Zero()) {}
  SE3(const Eigen::Quaterniond& q, const Vec3& t) : q_(q.normalized()), t_(t) {}
  SE3(const Mat3& R, const Vec3& t) : q_(Eigen::Quaterniond(R).normalized()), t_(t) {}
  explicit SE3(const Mat4& T) : SE3(Mat3(T.block<3, 3>(0, 0)), Vec3(T.block<3, 1>(0, 3))) {}

  static SE3 Identity() { return SE3(); }

  const Eigen::Quaterniond& quaternion() const { return q_; }
  Mat3 rotation() const { return q_.toRotationMatrix(); }
  const Vec3& translation() const { return t_; }
  Vec3& translation() { return t_; }

  Mat4 matrix() const {
    Mat4 T = Mat4::Identity();
    T.block<3, 3>(0, 0) = rotation();
    T.block<3, 1>(0, 3) = t_;
    return T;
  }
  Eigen::Matrix<double, 3, 4> matrix3x4() const { return matrix().topRows<3>(); }

  SE3 inverse() const {
    const Eigen::Quaterniond qi = q_.conjugate();
    return SE3(qi, -(qi * t_));
  }
  SE3 operator*(const SE3& o) const { return SE3(q_ * o.q_, t_ + q_ * o.t_); }
  Vec3 operator*(const Vec3& p) const { return q_ * p + t_; }

  /** Rotation angle in radians, in [0, pi]. */
  double angle() const {
    const double w = std::min(1.0, std::abs(q_.w()));
    return 2.0 * std::acos(w);
  }

  /** Exponential map; xi = [rho (translation part); phi (rotation vector)]. */
  static SE3 exp(const Vec6& xi) {
    const Vec3 rho = xi.head<3>(), phi = xi.tail<3>();
    const double th = phi.norm();
    Mat3 V = Mat3::Identity();
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    if (th > 1e-10) {
      const Vec3 a = phi / th;
      q = Eigen::Quaterniond(Eigen::AngleAxisd(th, a));
      const Mat3 W = skew(phi);
      V += (1 - std::cos(th)) / (th * th) * W + (th - std::sin(th)) / (th * th * th) * W * W;
    } else {
      q = Eigen::Quaterniond(1, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z()).normalized();
      V += 0.5 * skew(phi);
    }
    return SE3(q, V * rho);
  }

  /** Logarithm map, inverse of exp(). */
  Vec6 log() const {
    const Eigen::AngleAxisd aa(q_);
    Vec3 phi = aa.angle() * aa.axis();
    if (aa.angle() > M_PI) phi = (aa.angle() - 2 * M_PI) * aa.axis();
    const double th = phi.norm();
    Mat3 Vinv = Mat3::Identity();
    if (th > 1e-10) {
      const Mat3 W = skew(phi);
      Vinv += -0.5 * W + (1.0 / (th * th)) * (1 - (th * std::sin(th)) / (2 * (1 - std::cos(th)))) * W * W;
    } else {
      Vinv += -0.5 * skew(phi);
    }
    Vec6 xi;
    xi.head<3>() = Vinv * t_;
    xi.tail<3>() = phi;
    return xi;
  }

  static Mat3 skew(const Vec3& v) {
    Mat3 S;
    S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return S;
  }

 private:
  Eigen::Quaterniond q_;
  Vec3 t_;
};

/** Whether R is a rotation up to `tol` (Frobenius norm of R^T R - I; a
 *  reflection passes: check the determinant where it matters). Rotations
 *  read from files carry print rounding, hence the tolerance. */
inline bool isOrthonormal(const Eigen::Matrix3d& R, double tol) {
  return R.allFinite() && (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() <= tol;
}

}  // namespace dslam
