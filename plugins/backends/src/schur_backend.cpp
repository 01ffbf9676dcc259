#include "dslam/plugins/backends/schur_backend.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/timing.h"

IMPLEMENTS_MRPT_OBJECT(SchurBackend, CeresBackend, dslam)

namespace dslam {

struct SchurBackend::SchurSettings : backends::CommonSettings {
  double function_tolerance = 1e-6;
  double initial_lambda = 1e-4;
  int dense_max_keyframes = 100;
};

namespace {

using Mat63 = Eigen::Matrix<double, 6, 3>;
using Mat66 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;  // Ceres' LM bounds of the damping diagonal
constexpr double kGradientTolerance = 1e-10, kParameterTolerance = 1e-8;  // Ceres' defaults
constexpr double kMinLambda = 1e-32, kMaxLambda = 1e32;  // 1 / Ceres' max and min trust region radius

/** One optimisation pass of Levenberg-Marquardt with the points eliminated
 *  (Schur complement); the state lives in `problem`. */
class SchurSolver {
 public:
  SchurSolver(BAProblem& p, const SchurBackend::SchurSettings& s, const BAOptions& opt, bool robust)
      : p_(p), s_(s), opt_(opt), robust_(robust) {
    const size_t nk = p.keyframes.size(), np = p.points.size();
    cam_of_kf_.assign(nk, -1);
    pt_of_point_.assign(np, -1);
    std::vector<int> n_obs_kf(nk, 0), n_obs_pt(np, 0);
    for (size_t i = 0; i < p.observations.size(); i++) {
      const auto& o = p.observations[i];
      if (o.outlier) continue;
      if (p.keyframes[o.kf].fixed && p.points[o.pt].fixed) continue;  // constant: no part in the solve
      obs_.push_back(static_cast<int>(i));
      n_obs_kf[o.kf]++;
      n_obs_pt[o.pt]++;
    }
    for (size_t k = 0; k < nk; k++)
      if (!p.keyframes[k].fixed && n_obs_kf[k] > 0) {
        cam_of_kf_[k] = static_cast<int>(kf_of_cam_.size());
        kf_of_cam_.push_back(static_cast<int>(k));
      }
    for (size_t j = 0; j < np; j++)
      if (!p.points[j].fixed && n_obs_pt[j] > 0) {
        pt_of_point_[j] = static_cast<int>(point_of_pt_.size());
        point_of_pt_.push_back(static_cast<int>(j));
      }
    // observations of each free point (CSR), in observation order
    pt_begin_.assign(point_of_pt_.size() + 1, 0);
    for (int i : obs_) {
      const int q = pt_of_point_[p.observations[i].pt];
      if (q >= 0) pt_begin_[q + 1]++;
    }
    for (size_t q = 0; q < point_of_pt_.size(); q++) pt_begin_[q + 1] += pt_begin_[q];
    pt_obs_.resize(pt_begin_.back());
    std::vector<int> fill(pt_begin_.begin(), pt_begin_.end() - 1);
    for (size_t a = 0; a < obs_.size(); a++) {
      const int q = pt_of_point_[p.observations[obs_[a]].pt];
      if (q >= 0) pt_obs_[fill[q]++] = static_cast<int>(a);
    }
  }

  int numCameras() const { return static_cast<int>(kf_of_cam_.size()); }
  int numPoints() const { return static_cast<int>(point_of_pt_.size()); }

  /** Runs up to `iterations` LM steps; false if the cost is not finite. */
  bool run(int iterations, int* done, std::string* log) {
    double cost = linearize();
    if (!std::isfinite(cost)) {
      *log = "non-finite initial cost";
      return false;
    }
    double lambda = s_.initial_lambda, nu = 2;
    int accepted = 0, rejected = 0;
    const char* stop = "NO_CONVERGENCE";
    // A step not taken: more damping; false once the damping is useless.
    auto reject = [&] {
      rejected++;
      lambda *= nu;
      nu *= 2;
      return lambda <= kMaxLambda;
    };
    for (int it = 0; it < iterations; it++) {
      if (backends::abortRequested(opt_)) {
        stop = "ABORTED";
        break;
      }
      if (gradientMaxNorm() <= kGradientTolerance) {
        stop = "CONVERGENCE";
        break;
      }
      (*done)++;
      double predicted = 0;
      if (!solve(lambda, &predicted) || !(predicted > 0)) {
        if (!reject()) {
          stop = "DAMPING_LIMIT";
          break;
        }
        continue;
      }
      if (stepNorm() <= kParameterTolerance * (stateNorm() + kParameterTolerance)) {
        stop = "CONVERGENCE";
        break;
      }
      saveState();
      applyStep();
      const double new_cost = evaluate();
      const double ratio = (cost - new_cost) / predicted;
      if (std::isfinite(new_cost) && ratio > 1e-3) {
        accepted++;
        const double rel = (cost - new_cost) / std::max(cost, 1e-300);
        lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2 * ratio - 1, 3));
        lambda = std::max(lambda, kMinLambda);
        nu = 2;
        cost = linearize();
        if (rel < s_.function_tolerance) {
          stop = "CONVERGENCE";
          break;
        }
      } else {
        restoreState();
        if (!reject()) {
          stop = "DAMPING_LIMIT";
          break;
        }
      }
    }
    std::ostringstream m;
    m << "schur " << numCameras() << " kf " << numPoints() << " pt " << accepted + rejected << " it (" << rejected
      << " rejected, " << stop << ")";
    *log = m.str();
    return true;
  }

 private:
  /** Residual and Jacobians of observation `o` at the current estimates;
   *  returns the weight-free squared norm s. N rows. */
  template <int N>
  double residual(const BAObservation& o, Eigen::Matrix<double, N, 1>& r, Eigen::Matrix<double, N, 6>* Jp,
                  Eigen::Matrix<double, N, 3>* Jx) const {
    const SE3& T = p_.keyframes[o.kf].T_cw;
    const Eigen::Vector3d Xc = T * p_.points[o.pt].X_w;
    Eigen::Matrix<double, N, 3> Jc;
    backends::reprojectionResidual<N>(p_.camera, o, Xc, r.data(), Jp || Jx ? &Jc : nullptr);
    if (Jp) {
      Jp->template leftCols<3>() = Jc;
      Jp->template rightCols<3>() = -Jc * SE3::skew(Xc);
    }
    if (Jx) *Jx = Jc * T.rotation();
    return r.squaredNorm();
  }

  double kernelCost(double s, bool stereo) const {
    return robust_ ? huberCost(s, stereo ? opt_.huber_stereo : opt_.huber_mono) : s;
  }

  /** IRLS weight rho'(s) of the Huber kernel. */
  double kernelWeight(double s, bool stereo) const {
    if (!robust_) return 1;
    const double a = stereo ? opt_.huber_stereo : opt_.huber_mono;
    return s <= a * a ? 1.0 : a / std::sqrt(s);
  }

  double evaluate() const {
    double cost = 0;
    for (int i : obs_) {
      const auto& o = p_.observations[i];
      double s;
      if (o.u_right >= 0) {
        Eigen::Vector3d r;
        s = residual<3>(o, r, nullptr, nullptr);
      } else {
        Eigen::Vector2d r;
        s = residual<2>(o, r, nullptr, nullptr);
      }
      cost += kernelCost(s, o.u_right >= 0);
    }
    return cost;
  }

  template <int N>
  void accumulate(size_t a, const BAObservation& o, double* cost) {
    Eigen::Matrix<double, N, 1> r;
    Eigen::Matrix<double, N, 6> Jp;
    Eigen::Matrix<double, N, 3> Jx;
    const double s = residual<N>(o, r, &Jp, &Jx);
    *cost += kernelCost(s, N == 3);
    const double w = kernelWeight(s, N == 3);
    const int c = cam_of_kf_[o.kf], q = pt_of_point_[o.pt];
    if (c >= 0) {
      Hcc_[c].noalias() += w * Jp.transpose() * Jp;
      bc_[c].noalias() += w * Jp.transpose() * r;
    }
    if (q >= 0) {
      Hpp_[q].noalias() += w * Jx.transpose() * Jx;
      bp_[q].noalias() += w * Jx.transpose() * r;
    }
    if (c >= 0 && q >= 0) W_[a].noalias() = w * Jp.transpose() * Jx;
  }

  /** Normal equations at the current estimates; returns the cost. */
  double linearize() {
    Hcc_.assign(numCameras(), Mat66::Zero());
    bc_.assign(numCameras(), Vec6::Zero());
    Hpp_.assign(numPoints(), Eigen::Matrix3d::Zero());
    bp_.assign(numPoints(), Eigen::Vector3d::Zero());
    W_.resize(obs_.size());
    double cost = 0;
    for (size_t a = 0; a < obs_.size(); a++) {
      const auto& o = p_.observations[obs_[a]];
      if (o.u_right >= 0)
        accumulate<3>(a, o, &cost);
      else
        accumulate<2>(a, o, &cost);
    }
    return cost;
  }

  static double damp(double d) { return std::clamp(d, kMinDiagonal, kMaxDiagonal); }

  /** Damped step (H + lambda D) delta = -b into dc_, dp_; `predicted` = the
   *  model's cost decrease. False if the reduced system is not positive
   *  definite. */
  bool solve(double lambda, double* predicted) {
    const int m = numCameras(), n = numPoints();
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(6 * m, 6 * m);
    Eigen::VectorXd rhs(6 * m);
    for (int c = 0; c < m; c++) {
      Mat66 A = Hcc_[c];
      for (int k = 0; k < 6; k++) A(k, k) += lambda * damp(Hcc_[c](k, k));
      S.block<6, 6>(6 * c, 6 * c) = A;
      rhs.segment<6>(6 * c) = -bc_[c];
    }
    Cinv_.resize(n);
    std::vector<Mat63> Y;
    for (int q = 0; q < n; q++) {
      Eigen::Matrix3d C = Hpp_[q];
      for (int k = 0; k < 3; k++) C(k, k) += lambda * damp(Hpp_[q](k, k));
      bool ok = false;
      double det = 0;
      C.computeInverseAndDetWithCheck(Cinv_[q], det, ok, 0.0);
      if (!ok || !Cinv_[q].allFinite()) return false;
      const int b0 = pt_begin_[q], b1 = pt_begin_[q + 1];
      Y.clear();
      for (int e = b0; e < b1; e++) {
        const int a = pt_obs_[e];
        const int ca = cam_of_kf_[p_.observations[obs_[a]].kf];
        if (ca < 0) {
          Y.emplace_back(Mat63::Zero());
          continue;
        }
        Y.emplace_back(W_[a] * Cinv_[q]);
        rhs.segment<6>(6 * ca).noalias() += Y.back() * bp_[q];
      }
      for (int e = b0; e < b1; e++) {
        const int a = pt_obs_[e];
        const int ca = cam_of_kf_[p_.observations[obs_[a]].kf];
        if (ca < 0) continue;
        for (int f = e; f < b1; f++) {
          const int b = pt_obs_[f];
          const int cb = cam_of_kf_[p_.observations[obs_[b]].kf];
          if (cb < 0) continue;
          const Mat66 P = Y[e - b0] * W_[b].transpose();
          if (ca <= cb) {
            S.block<6, 6>(6 * ca, 6 * cb) -= P;
            if (f != e && ca == cb) S.block<6, 6>(6 * ca, 6 * cb) -= P.transpose();
          } else {
            S.block<6, 6>(6 * cb, 6 * ca) -= P.transpose();
          }
        }
      }
    }
    Eigen::VectorXd dc;
    if (m > 0) {
      Eigen::LLT<Eigen::MatrixXd, Eigen::Upper> llt(S);
      if (llt.info() != Eigen::Success) return false;
      dc = llt.solve(rhs);
      if (!dc.allFinite()) return false;
    }
    dc_.resize(m);
    for (int c = 0; c < m; c++) dc_[c] = dc.segment<6>(6 * c);
    dp_.resize(n);
    for (int q = 0; q < n; q++) {
      Eigen::Vector3d t = -bp_[q];
      for (int e = pt_begin_[q]; e < pt_begin_[q + 1]; e++) {
        const int a = pt_obs_[e];
        const int ca = cam_of_kf_[p_.observations[obs_[a]].kf];
        if (ca >= 0) t.noalias() -= W_[a].transpose() * dc_[ca];
      }
      dp_[q] = Cinv_[q] * t;
      if (!dp_[q].allFinite()) return false;
    }
    // Cost decrease predicted by the Gauss-Newton model of sum rho(s):
    // -(2 g.d + d'Hd) with (H + lambda D) d = -g, i.e. -g.d + lambda d'Dd.
    double pred = 0;
    for (int c = 0; c < m; c++) {
      pred -= bc_[c].dot(dc_[c]);
      for (int k = 0; k < 6; k++) pred += lambda * damp(Hcc_[c](k, k)) * dc_[c](k) * dc_[c](k);
    }
    for (int q = 0; q < n; q++) {
      pred -= bp_[q].dot(dp_[q]);
      for (int k = 0; k < 3; k++) pred += lambda * damp(Hpp_[q](k, k)) * dp_[q](k) * dp_[q](k);
    }
    *predicted = pred;
    return true;
  }

  double gradientMaxNorm() const {
    double g = 0;
    for (const auto& b : bc_) g = std::max(g, b.lpNorm<Eigen::Infinity>());
    for (const auto& b : bp_) g = std::max(g, b.lpNorm<Eigen::Infinity>());
    return g;
  }

  double stepNorm() const {
    double s2 = 0;
    for (const auto& d : dc_) s2 += d.squaredNorm();
    for (const auto& d : dp_) s2 += d.squaredNorm();
    return std::sqrt(s2);
  }

  double stateNorm() const {
    double s2 = 0;
    for (int k : kf_of_cam_) s2 += p_.keyframes[k].T_cw.translation().squaredNorm();
    for (int j : point_of_pt_) s2 += p_.points[j].X_w.squaredNorm();
    return std::sqrt(s2);
  }

  void saveState() {
    saved_T_.resize(kf_of_cam_.size());
    for (size_t c = 0; c < kf_of_cam_.size(); c++) saved_T_[c] = p_.keyframes[kf_of_cam_[c]].T_cw;
    saved_X_.resize(point_of_pt_.size());
    for (size_t q = 0; q < point_of_pt_.size(); q++) saved_X_[q] = p_.points[point_of_pt_[q]].X_w;
  }

  void restoreState() {
    for (size_t c = 0; c < kf_of_cam_.size(); c++) p_.keyframes[kf_of_cam_[c]].T_cw = saved_T_[c];
    for (size_t q = 0; q < point_of_pt_.size(); q++) p_.points[point_of_pt_[q]].X_w = saved_X_[q];
  }

  void applyStep() {
    for (size_t c = 0; c < kf_of_cam_.size(); c++) {
      SE3& T = p_.keyframes[kf_of_cam_[c]].T_cw;
      T = SE3::exp(dc_[c]) * T;
    }
    for (size_t q = 0; q < point_of_pt_.size(); q++) p_.points[point_of_pt_[q]].X_w += dp_[q];
  }

  BAProblem& p_;
  const SchurBackend::SchurSettings& s_;
  const BAOptions& opt_;
  const bool robust_;
  std::vector<int> obs_;                       // active observations (indices into p_.observations)
  std::vector<int> cam_of_kf_, kf_of_cam_;     // free keyframes <-> camera blocks
  std::vector<int> pt_of_point_, point_of_pt_; // free points <-> point blocks
  std::vector<int> pt_begin_, pt_obs_;         // CSR: active observations (indices into obs_) of each point block
  std::vector<Mat66> Hcc_;
  std::vector<Vec6> bc_, dc_;
  std::vector<Eigen::Matrix3d> Hpp_, Cinv_;
  std::vector<Eigen::Vector3d> bp_, dp_;
  std::vector<Mat63> W_;  // per active observation: w Jp' Jx (both blocks free)
  std::vector<SE3> saved_T_;
  std::vector<Eigen::Vector3d> saved_X_;
};

}  // namespace

SchurBackend::SchurBackend() : ss_(std::make_shared<SchurSettings>()) {}
SchurBackend::~SchurBackend() = default;

std::string SchurBackend::description() const {
  return "Levenberg-Marquardt bundle adjustment on the Schur complement with fixed-size blocks (Eigen; same model "
         "and ORB-SLAM outlier scheme as CeresBackend, several times faster per iteration); pose graph and large "
         "problems by CeresBackend";
}

std::vector<ParamSpec> SchurBackend::paramSpecs() const {
  auto s = CeresBackend::paramSpecs();
  s.push_back(P_double("initial_lambda", 1e-4,
                       "first Levenberg-Marquardt damping (times the Hessian's diagonal; Ceres: 1 / 1e4)", 0.0));
  s.push_back(P_int("dense_max_keyframes", 100,
                    "largest number of free keyframes solved here (dense reduced system); larger problems go to "
                    "CeresBackend with its linear_solver",
                    1, 100000));
  return s;
}

void SchurBackend::configure(const Params& p, const PluginContext& ctx) {
  CeresBackend::configure(p, ctx);
  auto s = std::make_shared<SchurSettings>();
  s->read(p);
  s->function_tolerance = p.getDouble("function_tolerance");
  s->initial_lambda = p.getDouble("initial_lambda");
  s->dense_max_keyframes = static_cast<int>(p.getInt("dense_max_keyframes"));
  ss_ = s;
}

BAResult SchurBackend::bundleAdjust(BAProblem& problem, const BAOptions& opt_in) {
  const SchurSettings& S = *ss_;
  int free_kf = 0;
  for (const auto& k : problem.keyframes) free_kf += k.fixed ? 0 : 1;
  if (free_kf > S.dense_max_keyframes) return CeresBackend::bundleAdjust(problem, opt_in);

  const double t0 = nowSeconds();
  backends::validate(problem, "SchurBackend");
  const BAOptions opt = S.apply(opt_in);
  BAResult res;
  res.initial_cost = evaluateCost(problem, opt);
  std::ostringstream msg;
  auto pass = [&](int iterations, bool robust) -> bool {
    SchurSolver solver(problem, S, opt, robust);
    if (solver.numCameras() == 0 && solver.numPoints() == 0) {
      msg << "nothing to optimise; ";
      return true;
    }
    std::string log;
    const bool ok = solver.run(iterations, &res.iterations, &log);
    if (opt.verbose) DSLAM_LOG(Info, "SchurBackend BA pass: " << log);
    msg << log << "; ";
    return ok;
  };
  res.success = backends::optimizeWithOutlierRejection(problem, S, opt, pass, &res.num_outliers);
  backends::finishResult(res, problem, opt, msg.str(), t0);
  return res;
}

}  // namespace dslam
