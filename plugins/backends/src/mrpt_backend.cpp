#include "dslam/plugins/backends/mrpt_backend.h"

#include <mrpt/graphs/CNetworkOfPoses.h>
#include <mrpt/graphslam/levmarq.h>
#include <mrpt/img/TCamera.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DPDFGaussianInf.h>
#include <mrpt/vision/bundle_adjustment.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <unordered_set>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/timing.h"

IMPLEMENTS_MRPT_OBJECT(MrptBackend, Backend, dslam)

namespace dslam {

// MRPT's robust LM scales the gradient by the kernel weights but not the
// Hessian: from the same start it needs ~4x the iterations of Ceres / g2o to
// converge (measured on the 10 KF / 1000 point test problem: 5 iterations
// leave the cost 40x above the optimum, 20 reach it).
constexpr int kMrptFirstPassIterations = 20;

struct MrptBackend::Settings : backends::CommonSettings {
  Settings() { first_pass_iterations = kMrptFirstPassIterations; }
};

namespace {

mrpt::poses::CPose3D toMrpt(const SE3& T) {
  const mrpt::math::CMatrixDouble33 R(T.rotation());
  mrpt::math::CVectorFixedDouble<3> t;
  for (int i = 0; i < 3; i++) t[i] = T.translation()[i];
  return mrpt::poses::CPose3D(R, t);
}

SE3 fromMrpt(const mrpt::poses::CPose3D& p) {
  return SE3(Eigen::Matrix3d(p.getRotationMatrix().asEigen()), Eigen::Vector3d(p.x(), p.y(), p.z()));
}

}  // namespace

MrptBackend::MrptBackend() : s_(std::make_shared<Settings>()) {}
MrptBackend::~MrptBackend() = default;

std::string MrptBackend::description() const {
  return "MRPT bundle_adj_full (monocular [u,v] only, unit weights, pseudo-Huber) and "
         "optimize_graph_spa_levmarq pose graph; reference backend";
}

std::vector<ParamSpec> MrptBackend::paramSpecs() const {
  return backends::CommonSettings::specs(kMrptFirstPassIterations);
}

void MrptBackend::configure(const Params& p, const PluginContext& ctx) {
  Backend::configure(p, ctx);
  auto s = std::make_shared<Settings>();
  s->read(p);
  s_ = s;
}

BAResult MrptBackend::bundleAdjust(BAProblem& problem, const BAOptions& opt_in) {
  const double t0 = nowSeconds();
  const Settings& S = *s_;
  backends::validate(problem, "MrptBackend");
  const BAOptions opt = S.apply(opt_in);
  BAResult res;
  res.initial_cost = evaluateCost(problem, opt);

  // bundle_adj_full keeps the first num_fix_frames frames and the first
  // num_fix_points points constant, and needs at least one fixed frame:
  // reorder (fixed first) and prepend a dummy fixed frame if none is fixed.
  const size_t nk = problem.keyframes.size(), np = problem.points.size();
  std::vector<int> frame_of_kf(nk), kf_of_frame, pt_index(np), pt_of_index;
  for (int pass = 0; pass < 2; pass++)
    for (size_t i = 0; i < nk; i++)
      if (problem.keyframes[i].fixed == (pass == 0)) {
        frame_of_kf[i] = static_cast<int>(kf_of_frame.size());
        kf_of_frame.push_back(static_cast<int>(i));
      }
  size_t num_fix_frames = std::count_if(problem.keyframes.begin(), problem.keyframes.end(),
                                        [](const BAKeyframe& k) { return k.fixed; });
  const bool dummy = num_fix_frames == 0;
  if (dummy) {
    for (auto& f : frame_of_kf) f++;
    kf_of_frame.insert(kf_of_frame.begin(), -1);
    num_fix_frames = 1;
  }
  for (int pass = 0; pass < 2; pass++)
    for (size_t i = 0; i < np; i++)
      if (problem.points[i].fixed == (pass == 0)) {
        pt_index[i] = static_cast<int>(pt_of_index.size());
        pt_of_index.push_back(static_cast<int>(i));
      }
  const size_t num_fix_points = std::count_if(problem.points.begin(), problem.points.end(),
                                              [](const BAPoint& p) { return p.fixed; });

  // One weight for every observation: the kernel threshold in pixels uses
  // the median information.
  std::vector<double> infos;
  for (const auto& o : problem.observations)
    if (!o.outlier) infos.push_back(o.information);
  double med_info = 1;
  if (!infos.empty()) {
    std::nth_element(infos.begin(), infos.begin() + infos.size() / 2, infos.end());
    med_info = infos[infos.size() / 2];
  }

  mrpt::img::TCamera cam;
  cam.fx(problem.camera.fx);
  cam.fy(problem.camera.fy);
  cam.cx(problem.camera.cx);
  cam.cy(problem.camera.cy);

  std::ostringstream msg;
  auto pass = [&](int iterations, bool robust) -> bool {
    mrpt::vision::TSequenceFeatureObservations obs;
    obs.reserve(problem.observations.size());
    std::unordered_set<uint64_t> seen;
    size_t dups = 0;
    for (const auto& o : problem.observations) {
      if (o.outlier) continue;
      const uint64_t key = (static_cast<uint64_t>(o.kf) << 32) | static_cast<uint32_t>(o.pt);
      if (!seen.insert(key).second) {
        dups++;
        continue;
      }
      obs.emplace_back(static_cast<mrpt::vision::TLandmarkID>(pt_index[o.pt]),
                       static_cast<mrpt::vision::TCameraPoseID>(frame_of_kf[o.kf]),
                       mrpt::img::TPixelCoordf(static_cast<float>(o.uv.x()), static_cast<float>(o.uv.y())));
    }
    if (dups) msg << dups << " duplicate (keyframe, point) observations ignored; ";
    if (obs.empty() || pt_of_index.empty() || (kf_of_frame.size() == num_fix_frames && num_fix_points == np)) {
      msg << "nothing to optimise; ";
      return true;
    }
    mrpt::vision::TFramePosesVec frames(kf_of_frame.size());
    for (size_t f = 0; f < kf_of_frame.size(); f++)
      if (kf_of_frame[f] >= 0) frames[f] = toMrpt(problem.keyframes[kf_of_frame[f]].T_cw.inverse());  // camera pose
    mrpt::vision::TLandmarkLocationsVec lms(pt_of_index.size());
    for (size_t k = 0; k < pt_of_index.size(); k++) {
      const auto& X = problem.points[pt_of_index[k]].X_w;
      lms[k] = mrpt::math::TPoint3D(X.x(), X.y(), X.z());
    }

    mrpt::containers::yaml ep = mrpt::containers::yaml::Map();
    ep["max_iterations"] = static_cast<uint64_t>(iterations);
    ep["num_fix_frames"] = static_cast<uint64_t>(num_fix_frames);
    ep["num_fix_points"] = static_cast<uint64_t>(num_fix_points);
    ep["robust_kernel"] = robust;
    ep["kernel_param"] = opt.huber_mono / std::sqrt(med_info);
    ep["verbose"] = opt.verbose;
    int iters = 0;
    double sq_err = 0;
    try {
      sq_err = mrpt::vision::bundle_adj_full(
          obs, cam, frames, lms, ep,
          [&](size_t, double, size_t, const mrpt::vision::TSequenceFeatureObservations&,
              const mrpt::vision::TFramePosesVec&, const mrpt::vision::TLandmarkLocationsVec&) { iters++; });
    } catch (const std::exception& e) {
      msg << "bundle_adj_full failed: " << exceptionSummary(e) << "; ";
      return false;
    }
    res.iterations += iters;
    msg << "bundle_adj_full " << iters << " it, sq.err " << sq_err << "; ";
    for (size_t f = 0; f < kf_of_frame.size(); f++) {
      const int k = kf_of_frame[f];
      if (k >= 0 && !problem.keyframes[k].fixed) problem.keyframes[k].T_cw = fromMrpt(frames[f]).inverse();
    }
    for (size_t j = num_fix_points; j < pt_of_index.size(); j++)
      problem.points[pt_of_index[j]].X_w = Eigen::Vector3d(lms[j].x, lms[j].y, lms[j].z);
    return true;
  };

  res.success = backends::optimizeWithOutlierRejection(problem, S, opt, pass, &res.num_outliers);
  backends::finishResult(res, problem, opt, msg.str(), t0);
  return res;
}

PoseGraphResult MrptBackend::optimizePoseGraph(PoseGraph& graph, const PoseGraphOptions& opt_in) {
  const double t0 = nowSeconds();
  const Settings& S = *s_;
  backends::validate(graph, "MrptBackend");
  const PoseGraphOptions opt = S.apply(opt_in);
  PoseGraphResult res;
  res.initial_cost = evaluateCost(graph);

  mrpt::graphs::CNetworkOfPoses3DInf G;
  std::set<mrpt::graphs::TNodeID> free_nodes;
  bool root_set = false;
  for (size_t i = 0; i < graph.nodes.size(); i++) {
    G.nodes[i] = toMrpt(graph.nodes[i].T_wc);
    if (graph.nodes[i].fixed && !root_set) {
      G.root = i;
      root_set = true;
    }
  }
  for (const auto& e : graph.edges) {
    const mrpt::math::CMatrixDouble66 info(e.information);
    G.insertEdge(e.from, e.to, mrpt::poses::CPose3DPDFGaussianInf(toMrpt(e.T_from_to), info));
    for (int n : {e.from, e.to})
      if (!graph.nodes[n].fixed) free_nodes.insert(static_cast<mrpt::graphs::TNodeID>(n));
  }
  if (free_nodes.empty()) {
    res.success = true;
    res.final_cost = res.initial_cost;
    res.message = "nothing to optimise";
    res.time_ms = backends::elapsedMs(t0);
    return res;
  }

  mrpt::containers::yaml ep = mrpt::containers::yaml::Map();
  ep["max_iterations"] = static_cast<uint64_t>(opt.max_iterations);
  ep["verbose"] = opt.verbose;
  mrpt::graphslam::TResultInfoSpaLevMarq info{};
  try {
    mrpt::graphslam::optimize_graph_spa_levmarq(G, info, &free_nodes, ep);
  } catch (const std::exception& e) {
    res.success = false;
    res.message = "optimize_graph_spa_levmarq failed: " + exceptionSummary(e);
    res.final_cost = res.initial_cost;
    res.time_ms = backends::elapsedMs(t0);
    return res;
  }
  for (const auto id : free_nodes) graph.nodes[id].T_wc = fromMrpt(G.nodes.at(id));
  res.success = true;
  res.iterations = static_cast<int>(info.num_iters);
  std::ostringstream m;
  m << "optimize_graph_spa_levmarq " << info.num_iters << " it, sq.err " << info.final_total_sq_error;
  res.message = m.str();
  res.final_cost = evaluateCost(graph);
  res.time_ms = backends::elapsedMs(t0);
  return res;
}

}  // namespace dslam
