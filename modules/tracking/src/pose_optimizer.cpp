#include "dslam/tracking/pose_optimizer.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

namespace dslam {

namespace {

/** Residual and Jacobian w.r.t. a left perturbation exp(delta) * T_cw,
 *  delta = [rho; phi]. Returns false if the point is behind the camera. */
bool residual(const SE3& T, const PoseObservation& o, const PoseOptimizerParams& p, Eigen::Vector3d& e,
              Eigen::Matrix<double, 3, 6>& J, int& dim) {
  const Eigen::Vector3d Xc = T * o.Xw;
  if (Xc.z() <= 1e-6) return false;
  const double iz = 1.0 / Xc.z(), iz2 = iz * iz;
  const double u = p.fx * Xc.x() * iz + p.cx;
  const double v = p.fy * Xc.y() * iz + p.cy;
  Eigen::Matrix<double, 3, 3> dproj;
  dproj << p.fx * iz, 0, -p.fx * Xc.x() * iz2,  //
      0, p.fy * iz, -p.fy * Xc.y() * iz2,       //
      p.fx * iz, 0, -(p.fx * Xc.x() - p.bf) * iz2;
  Eigen::Matrix<double, 3, 6> dX;
  dX.leftCols<3>().setIdentity();
  dX.rightCols<3>() = -SE3::skew(Xc);
  dim = o.u_right >= 0 ? 3 : 2;
  e.x() = u - o.uv.x();
  e.y() = v - o.uv.y();
  e.z() = dim == 3 ? (u - p.bf * iz) - o.u_right : 0.0;
  J = dproj * dX;
  if (dim == 2) J.row(2).setZero();
  return true;
}

}  // namespace

PoseOptimizerResult optimizePose(SE3& T_cw, const std::vector<PoseObservation>& obs, std::vector<char>& outlier,
                                 const PoseOptimizerParams& p) {
  const size_t n = obs.size();
  outlier.assign(n, 0);
  PoseOptimizerResult res;
  if (n < 3) {
    std::fill(outlier.begin(), outlier.end(), 1);
    return res;
  }
  Eigen::Vector3d e;
  Eigen::Matrix<double, 3, 6> J;
  int dim = 2;
  for (int round = 0; round < p.rounds; round++) {
    const bool robust = round < 2;
    double lambda = 1e-4;
    double prev_cost = -1;
    for (int it = 0; it < p.iterations; it++) {
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      double cost = 0;
      for (size_t i = 0; i < n; i++) {
        if (outlier[i]) continue;
        if (!residual(T_cw, obs[i], p, e, J, dim)) continue;
        const double chi2 = obs[i].information * e.squaredNorm();
        const double delta2 = dim == 3 ? p.chi2_stereo : p.chi2_mono;
        double w = obs[i].information;
        if (robust && chi2 > delta2) {
          const double s = std::sqrt(chi2);
          w *= std::sqrt(delta2) / s;
          cost += 2 * std::sqrt(delta2) * s - delta2;
        } else {
          cost += chi2;
        }
        H.noalias() += w * J.transpose() * J;
        g.noalias() += w * J.transpose() * e;
      }
      if (prev_cost >= 0 && cost > prev_cost) lambda *= 10;
      prev_cost = cost;
      H.diagonal() *= (1.0 + lambda);
      const Eigen::Matrix<double, 6, 1> dx = H.ldlt().solve(-g);
      if (!dx.allFinite()) break;
      T_cw = SE3::exp(dx) * T_cw;
      if (dx.squaredNorm() < 1e-12) break;
    }
    // Classify (ORB-SLAM: every edge is re-evaluated, outliers may come back).
    res.inliers = 0;
    res.final_chi2 = 0;
    for (size_t i = 0; i < n; i++) {
      if (!residual(T_cw, obs[i], p, e, J, dim)) {
        outlier[i] = 1;
        continue;
      }
      const double chi2 = obs[i].information * e.squaredNorm();
      const bool out = chi2 > (dim == 3 ? p.chi2_stereo : p.chi2_mono);
      outlier[i] = out;
      if (!out) {
        res.inliers++;
        res.final_chi2 += chi2;
      }
    }
    if (res.inliers < 10) break;
  }
  return res;
}

Eigen::Matrix<double, 6, 6> poseCovariance(const SE3& T_cw, const std::vector<PoseObservation>& obs,
                                           const std::vector<char>& outlier, const PoseOptimizerParams& p) {
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Vector3d e;
  Eigen::Matrix<double, 3, 6> J;
  int dim = 2, n = 0;
  for (size_t i = 0; i < obs.size(); i++) {
    if (i < outlier.size() && outlier[i]) continue;
    if (!residual(T_cw, obs[i], p, e, J, dim)) continue;
    H.noalias() += obs[i].information * J.transpose() * J;
    n++;
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(H);
  if (n < 3 || ldlt.info() != Eigen::Success || !ldlt.isPositive() || ldlt.vectorD().minCoeff() <= 0)
    return Eigen::Matrix<double, 6, 6>::Zero();
  return ldlt.solve(Eigen::Matrix<double, 6, 6>::Identity());
}

PoseOptimizerResult optimizePoseOlderFirst(SE3& T_cw, const std::vector<PoseObservation>& obs,
                                          const std::vector<char>& young, int min_older, std::vector<char>& outlier,
                                          const PoseOptimizerParams& p, bool* checked) {
  if (checked) *checked = false;
  // Off (young_frames 0) or nothing young: no copy on this per-frame path.
  if (std::none_of(young.begin(), young.end(), [](char y) { return y != 0; })) return optimizePose(T_cw, obs, outlier, p);
  std::vector<PoseObservation> older;
  for (size_t i = 0; i < obs.size(); i++)
    if (!young[i]) older.push_back(obs[i]);
  if (older.size() < static_cast<size_t>(std::max(min_older, 3)) || older.size() == obs.size())
    return optimizePose(T_cw, obs, outlier, p);
  SE3 T_old = T_cw;
  std::vector<char> out_older;
  if (optimizePose(T_old, older, out_older, p).inliers < min_older) return optimizePose(T_cw, obs, outlier, p);
  // The young observations that fit the older points' pose join them.
  std::vector<PoseObservation> kept;
  std::vector<size_t> kept_index;
  outlier.assign(obs.size(), 1);
  Eigen::Vector3d e;
  Eigen::Matrix<double, 3, 6> J;
  int dim = 2;
  for (size_t i = 0; i < obs.size(); i++) {
    if (young[i] &&
        (!residual(T_old, obs[i], p, e, J, dim) ||
         obs[i].information * e.squaredNorm() > (dim == 3 ? p.chi2_stereo : p.chi2_mono)))
      continue;
    kept.push_back(obs[i]);
    kept_index.push_back(i);
  }
  if (checked) *checked = true;
  T_cw = T_old;
  std::vector<char> out_kept;
  const PoseOptimizerResult r = optimizePose(T_cw, kept, out_kept, p);
  for (size_t k = 0; k < kept_index.size(); k++) outlier[kept_index[k]] = out_kept[k];
  return r;
}

}  // namespace dslam
