#include "dslam/plugins/backends/ceres_backend.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <sstream>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/timing.h"

IMPLEMENTS_MRPT_OBJECT(CeresBackend, Backend, dslam)

namespace dslam {

struct CeresBackend::Settings : backends::CommonSettings {
  std::string linear_solver = "auto";
  int dense_schur_max_keyframes = 40;
  int num_threads = 1;
  bool num_threads_given = false;
  double function_tolerance = 1e-6;
};

namespace {

/** Ends a solve with its best estimate when the caller's abort flag is set
 *  (ORB-SLAM's g2o setForceStopFlag) or its deadline has passed. */
class AbortCallback : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const BAOptions& opt) : opt_(opt) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return backends::abortRequested(opt_) ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  const BAOptions& opt_;
};

// Parameter block of a pose: [qx qy qz qw tx ty tz] (Eigen quaternion
// coefficient order, then translation).
constexpr int kPoseSize = 7;
using PoseBlock = std::array<double, kPoseSize>;

PoseBlock toBlock(const SE3& T) {
  PoseBlock b;
  const auto& q = T.quaternion();
  b = {q.x(), q.y(), q.z(), q.w(), T.translation().x(), T.translation().y(), T.translation().z()};
  return b;
}

SE3 fromBlock(const double* b) {
  return SE3(Eigen::Quaterniond(b[3], b[0], b[1], b[2]), Eigen::Vector3d(b[4], b[5], b[6]));
}

/** SE3 with the left update x [+] delta = exp(delta) * x, delta = [rho; phi].
 *  The BA cost functions below return their Jacobians directly with respect
 *  to delta in the first 6 columns of the 7-column block (7th column zero),
 *  so PlusJacobian is [I6; 0] (the usual trick of g2o-style Jacobians in
 *  Ceres). Only for the analytic BA cost functions: do not use it with
 *  automatic differentiation. */
class SE3LeftManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseSize; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    const SE3 T = SE3::exp(Eigen::Map<const SE3::Vec6>(delta)) * fromBlock(x);
    const PoseBlock b = toBlock(T);
    std::copy(b.begin(), b.end(), x_plus_delta);
    return true;
  }
  bool PlusJacobian(const double*, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.topRows<6>().setIdentity();
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    Eigen::Map<SE3::Vec6> d(y_minus_x);
    d = (fromBlock(y) * fromBlock(x).inverse()).log();
    return true;
  }
  bool MinusJacobian(const double*, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.leftCols<6>().setIdentity();
    return true;
  }
};

/** Reprojection residual sqrt(info) * (proj(T_cw X) - obs): N = 2 for
 *  [u, v], N = 3 for [u, v, u_right]. Analytic Jacobians. */
template <int N>
class ReprojectionCost final : public ceres::SizedCostFunction<N, kPoseSize, 3> {
 public:
  ReprojectionCost(const BACamera& cam, const BAObservation& o) : cam_(cam), obs_(o) {}

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const double* p = params[0];
    const Eigen::Map<const Eigen::Quaterniond> q(p);
    const Eigen::Map<const Eigen::Vector3d> t(p + 4);
    const Eigen::Map<const Eigen::Vector3d> X(params[1]);
    const Eigen::Vector3d Xc = q * X + t;
    Eigen::Matrix<double, N, 3> Jc;  // d(residual)/d(Xc)
    backends::reprojectionResidual<N>(cam_, obs_, Xc, residuals, jacobians ? &Jc : nullptr);
    if (!jacobians) return true;
    if (jacobians[0]) {
      // Xc(delta) = exp(delta) Xc ~ Xc + rho + phi x Xc  ->  [I, -[Xc]x]
      Eigen::Map<Eigen::Matrix<double, N, kPoseSize, Eigen::RowMajor>> Jp(jacobians[0]);
      Jp.template leftCols<3>() = Jc;
      Jp.template middleCols<3>(3) = -Jc * SE3::skew(Xc);
      Jp.col(6).setZero();
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, N, 3, Eigen::RowMajor>> Jx(jacobians[1]);
      Jx = Jc * q.toRotationMatrix();
    }
    return true;
  }

 private:
  BACamera cam_;
  BAObservation obs_;
};

// ---- pose graph --------------------------------------------------------

/** log() of SE3 for automatic differentiation; same convention as
 *  SE3::log(): [rho; phi], rho = V(phi)^-1 t. */
template <class T>
Eigen::Matrix<T, 6, 1> logSE3(const Eigen::Quaternion<T>& q_in, const Eigen::Matrix<T, 3, 1>& t) {
  Eigen::Quaternion<T> q = q_in;
  if (q.w() < T(0)) q.coeffs() = -q.coeffs();  // shortest rotation, angle in [0, pi]
  const T wxyz[4] = {q.w(), q.x(), q.y(), q.z()};
  Eigen::Matrix<T, 3, 1> phi;
  ceres::QuaternionToAngleAxis(wxyz, phi.data());
  const T th2 = phi.squaredNorm();
  T c;  // (1 - th sin(th) / (2 (1 - cos th))) / th^2
  if (th2 > T(1e-4)) {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const T th = sqrt(th2);
    c = (T(1) - th * sin(th) / (T(2) * (T(1) - cos(th)))) / th2;
  } else {
    c = T(1.0 / 12.0) + th2 * T(1.0 / 720.0) + th2 * th2 * T(1.0 / 30240.0);
  }
  Eigen::Matrix<T, 3, 3> W;
  W << T(0), -phi.z(), phi.y(), phi.z(), T(0), -phi.x(), -phi.y(), phi.x(), T(0);
  const Eigen::Matrix<T, 3, 3> Vinv = Eigen::Matrix<T, 3, 3>::Identity() - T(0.5) * W + c * W * W;
  Eigen::Matrix<T, 6, 1> xi;
  xi.template head<3>() = Vinv * t;
  xi.template tail<3>() = phi;
  return xi;
}

/** Between factor on SE3 nodes T_wc (blocks [qx qy qz qw tx ty tz]):
 *  r = sqrtI * log(Z^-1 T_i^-1 T_j). A Sim3 variant (essential graph of
 *  monocular SLAM) would be a functor with 8-parameter blocks and a 7-dof
 *  log, added beside this one with its own manifold. */
struct SE3BetweenResidual {
  SE3BetweenResidual(const SE3& Z, const Eigen::Matrix<double, 6, 6>& sqrt_info)
      : Zinv(Z.inverse()), sqrt_info(sqrt_info) {}

  template <class T>
  bool operator()(const T* pi, const T* pj, T* res) const {
    const Eigen::Map<const Eigen::Quaternion<T>> qi(pi), qj(pj);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> ti(pi + 4), tj(pj + 4);
    const Eigen::Quaternion<T> qi_inv = qi.conjugate();
    const Eigen::Quaternion<T> q_ij = qi_inv * qj;
    const Eigen::Matrix<T, 3, 1> t_ij = qi_inv * (tj - ti);
    const Eigen::Quaternion<T> qz = Zinv.quaternion().cast<T>();
    const Eigen::Quaternion<T> qe = qz * q_ij;
    const Eigen::Matrix<T, 3, 1> te = qz * t_ij + Zinv.translation().cast<T>();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(res);
    r = sqrt_info.cast<T>() * logSE3<T>(qe, te);
    return true;
  }

  SE3 Zinv;
  Eigen::Matrix<double, 6, 6> sqrt_info;
};

ceres::LinearSolverType parseSolver(const std::string& s) {
  if (s == "dense_schur") return ceres::DENSE_SCHUR;
  if (s == "sparse_schur") return ceres::SPARSE_SCHUR;
  if (s == "iterative_schur") return ceres::ITERATIVE_SCHUR;
  if (s == "sparse_normal_cholesky") return ceres::SPARSE_NORMAL_CHOLESKY;
  if (s == "dense_qr") return ceres::DENSE_QR;
  throw ConfigError("CeresBackend: unknown linear_solver '" + s + "'");
}

bool isSchur(ceres::LinearSolverType t) {
  return t == ceres::DENSE_SCHUR || t == ceres::SPARSE_SCHUR || t == ceres::ITERATIVE_SCHUR;
}

}  // namespace

CeresBackend::CeresBackend() : s_(std::make_shared<Settings>()) {}
CeresBackend::~CeresBackend() = default;

std::string CeresBackend::description() const {
  return "Ceres Solver bundle adjustment (analytic Jacobians, Huber, Schur; ORB-SLAM outlier scheme) and SE3 "
         "pose-graph optimisation";
}

std::vector<ParamSpec> CeresBackend::paramSpecs() const {
  auto s = backends::CommonSettings::specs();
  s.push_back(P_enum("linear_solver", "auto",
                     {"auto", "dense_schur", "sparse_schur", "iterative_schur", "sparse_normal_cholesky", "dense_qr"},
                     "BA linear solver; auto = dense_schur up to dense_schur_max_keyframes free keyframes, else "
                     "sparse_schur (SuiteSparse)"));
  s.push_back(P_int("dense_schur_max_keyframes", 40, "auto solver: largest number of free keyframes for dense_schur",
                    0, 100000));
  s.push_back(P_int("num_threads", 1,
                    "Ceres threads; if written here, overrides the caller's BAOptions::num_threads", 1, 256));
  s.push_back(P_double("function_tolerance", 1e-6, "Ceres stop criterion |d cost| / cost", 0.0, 1.0));
  return s;
}

void CeresBackend::configure(const Params& p, const PluginContext& ctx) {
  Backend::configure(p, ctx);
  auto s = std::make_shared<Settings>();
  s->read(p);
  s->linear_solver = p.getString("linear_solver");
  if (s->linear_solver != "auto") parseSolver(s->linear_solver);  // validate early
  s->dense_schur_max_keyframes = static_cast<int>(p.getInt("dense_schur_max_keyframes"));
  s->num_threads = static_cast<int>(p.getInt("num_threads"));
  s->num_threads_given = p.isGiven("num_threads");
  s->function_tolerance = p.getDouble("function_tolerance");
  s_ = s;
}

BAResult CeresBackend::bundleAdjust(BAProblem& problem, const BAOptions& opt_in) {
  const double t0 = nowSeconds();
  const Settings& S = *s_;
  backends::validate(problem, "CeresBackend");
  BAOptions opt = S.apply(opt_in);
  if (S.num_threads_given) opt.num_threads = S.num_threads;

  BAResult res;
  res.initial_cost = evaluateCost(problem, opt);

  const size_t nk = problem.keyframes.size(), np = problem.points.size();
  std::vector<PoseBlock> poses(nk);
  std::vector<std::array<double, 3>> points(np);
  for (size_t i = 0; i < nk; i++) poses[i] = toBlock(problem.keyframes[i].T_cw);
  for (size_t i = 0; i < np; i++) {
    const Eigen::Vector3d& X = problem.points[i].X_w;
    points[i] = {X.x(), X.y(), X.z()};
  }

  SE3LeftManifold manifold;
  ceres::HuberLoss huber_mono(opt.huber_mono), huber_stereo(opt.huber_stereo);
  std::ostringstream msg;

  // One optimisation pass over the observations not flagged as outliers;
  // writes the free estimates back into `problem`.
  auto pass = [&](int iterations, bool robust) -> bool {
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem P(po);
    for (const auto& o : problem.observations) {
      if (o.outlier) continue;
      double* pose = poses[o.kf].data();
      double* X = points[o.pt].data();
      if (o.u_right >= 0)
        P.AddResidualBlock(new ReprojectionCost<3>(problem.camera, o), robust ? &huber_stereo : nullptr, pose, X);
      else
        P.AddResidualBlock(new ReprojectionCost<2>(problem.camera, o), robust ? &huber_mono : nullptr, pose, X);
    }
    int free_kf = 0, free_pt = 0;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t i = 0; i < nk; i++) {
      double* b = poses[i].data();
      if (!P.HasParameterBlock(b)) continue;
      P.SetManifold(b, &manifold);
      if (problem.keyframes[i].fixed) {
        P.SetParameterBlockConstant(b);
      } else {
        free_kf++;
        ordering->AddElementToGroup(b, 1);
      }
    }
    for (size_t i = 0; i < np; i++) {
      double* b = points[i].data();
      if (!P.HasParameterBlock(b)) continue;
      if (problem.points[i].fixed) {
        P.SetParameterBlockConstant(b);
      } else {
        free_pt++;
        ordering->AddElementToGroup(b, 0);
      }
    }
    if (free_kf == 0 && free_pt == 0) {
      msg << "nothing to optimise; ";
      return true;
    }

    ceres::Solver::Options so;
    so.max_num_iterations = iterations;
    so.num_threads = std::max(1, opt.num_threads);
    so.function_tolerance = S.function_tolerance;
    so.minimizer_progress_to_stdout = opt.verbose;
    so.logging_type = opt.verbose ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
    if (S.linear_solver == "auto")
      so.linear_solver_type = free_kf <= S.dense_schur_max_keyframes ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    else
      so.linear_solver_type = parseSolver(S.linear_solver);
    if (isSchur(so.linear_solver_type) && (free_kf == 0 || free_pt == 0))
      so.linear_solver_type = free_kf + free_pt <= 200 ? ceres::DENSE_QR : ceres::SPARSE_NORMAL_CHOLESKY;
    if (isSchur(so.linear_solver_type)) {
      if (so.linear_solver_type == ceres::ITERATIVE_SCHUR) so.preconditioner_type = ceres::SCHUR_JACOBI;
      so.linear_solver_ordering = ordering;
    }

    AbortCallback abort_cb(opt);
    if (opt.abort || opt.deadline > 0) so.callbacks.push_back(&abort_cb);
    ceres::Solver::Summary sum;
    ceres::Solve(so, &P, &sum);
    if (opt.verbose) DSLAM_LOG(Info, "CeresBackend BA pass: " << sum.BriefReport());
    res.iterations += std::max<int>(0, static_cast<int>(sum.iterations.size()) - 1);  // [0] = initial point
    msg << ceres::LinearSolverTypeToString(so.linear_solver_type) << " " << sum.iterations.size() - 1 << " it ("
        << sum.num_unsuccessful_steps << " rejected, " << ceres::TerminationTypeToString(sum.termination_type) << "); ";
    if (!sum.IsSolutionUsable()) {
      msg << sum.message << "; ";
      return false;
    }
    for (size_t i = 0; i < nk; i++)
      if (!problem.keyframes[i].fixed && P.HasParameterBlock(poses[i].data()))
        problem.keyframes[i].T_cw = fromBlock(poses[i].data());
    for (size_t i = 0; i < np; i++)
      if (!problem.points[i].fixed && P.HasParameterBlock(points[i].data()))
        problem.points[i].X_w = Eigen::Vector3d(points[i][0], points[i][1], points[i][2]);
    return true;
  };

  res.success = backends::optimizeWithOutlierRejection(problem, S, opt, pass, &res.num_outliers);
  backends::finishResult(res, problem, opt, msg.str(), t0);
  return res;
}

PoseGraphResult CeresBackend::optimizePoseGraph(PoseGraph& graph, const PoseGraphOptions& opt_in) {
  const double t0 = nowSeconds();
  const Settings& S = *s_;
  backends::validate(graph, "CeresBackend");
  const PoseGraphOptions opt = S.apply(opt_in);
  PoseGraphResult res;
  res.initial_cost = evaluateCost(graph);

  const size_t n = graph.nodes.size();
  std::vector<PoseBlock> blocks(n);
  for (size_t i = 0; i < n; i++) blocks[i] = toBlock(graph.nodes[i].T_wc);

  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem P(po);
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> manifold;
  for (const auto& e : graph.edges) {
    const Eigen::Matrix<double, 6, 6> sqrt_info = e.information.llt().matrixU();  // I = U^T U
    auto* cost = new ceres::AutoDiffCostFunction<SE3BetweenResidual, 6, kPoseSize, kPoseSize>(
        new SE3BetweenResidual(e.T_from_to, sqrt_info));
    P.AddResidualBlock(cost, nullptr, blocks[e.from].data(), blocks[e.to].data());
  }
  int free_nodes = 0;
  for (size_t i = 0; i < n; i++) {
    double* b = blocks[i].data();
    if (!P.HasParameterBlock(b)) continue;
    P.SetManifold(b, &manifold);
    if (graph.nodes[i].fixed)
      P.SetParameterBlockConstant(b);
    else
      free_nodes++;
  }
  if (free_nodes == 0) {
    res.success = true;
    res.final_cost = res.initial_cost;
    res.message = "nothing to optimise";
    res.time_ms = backends::elapsedMs(t0);
    return res;
  }

  ceres::Solver::Options so;
  so.max_num_iterations = opt.max_iterations;
  so.linear_solver_type = free_nodes <= 100 ? ceres::DENSE_NORMAL_CHOLESKY : ceres::SPARSE_NORMAL_CHOLESKY;
  so.function_tolerance = S.function_tolerance;
  so.minimizer_progress_to_stdout = opt.verbose;
  so.logging_type = opt.verbose ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &P, &sum);
  if (opt.verbose) DSLAM_LOG(Info, "CeresBackend pose graph: " << sum.BriefReport());
  res.iterations = std::max<int>(0, static_cast<int>(sum.iterations.size()) - 1);
  res.success = sum.IsSolutionUsable();
  res.message = std::string(ceres::TerminationTypeToString(sum.termination_type)) + ": " + sum.message;
  if (res.success)
    for (size_t i = 0; i < n; i++)
      if (!graph.nodes[i].fixed && P.HasParameterBlock(blocks[i].data()))
        graph.nodes[i].T_wc = fromBlock(blocks[i].data());
  res.final_cost = evaluateCost(graph);
  res.time_ms = backends::elapsedMs(t0);
  return res;
}

}  // namespace dslam
