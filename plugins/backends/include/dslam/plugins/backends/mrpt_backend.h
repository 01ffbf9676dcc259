#pragma once
/** \file mrpt_backend.h
 *  dslam::MrptBackend: bundle adjustment with mrpt::vision::bundle_adj_full
 *  and pose-graph optimisation with mrpt::graphslam::optimize_graph_spa_levmarq.
 *  MRPT headers stay out of this file. */
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/backend.h"

namespace dslam {

/** MRPT backend, mainly a reference to compare CeresBackend against.
 *
 *  Limits of bundle_adj_full (MRPT 2.5), handled as follows:
 *  - monocular only: only the left-image [u, v] of every observation is
 *    used; u_right (stereo / RGB-D) is ignored by the optimisation (the
 *    reported costs, from evaluateCost(), still include it);
 *  - one weight for all observations: per-observation information is not
 *    used; the robust kernel (MRPT's pseudo-Huber) gets the threshold
 *    huber_mono / sqrt(median information) pixels;
 *  - fixed frames / points must be the first ones: the problem is reordered
 *    (fixed first); when no keyframe is fixed a dummy fixed frame without
 *    observations is prepended, so every keyframe is optimised;
 *  - one observation per (keyframe, point) pair: duplicates are dropped;
 *  - pixels are single precision (TPixelCoordf).
 *  The ORB-SLAM outlier scheme (robust pass, chi2 test, second pass without
 *  outliers and without kernel, chi2 test) is run on top, as in CeresBackend.
 *
 *  Pose graph: CNetworkOfPoses3DInf, MRPT's residual is the pseudo-log
 *  [t; log(R)] of T_ij_meas^-1 T_i^-1 T_j (close to ours for small errors);
 *  the edge information is passed as is (same [translation; rotation]
 *  order). Fixed nodes are left out of the optimised set. */
class MrptBackend : public Backend {
  DEFINE_MRPT_OBJECT(MrptBackend, dslam)
 public:
  MrptBackend();
  ~MrptBackend() override;
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;

  BAResult bundleAdjust(BAProblem& problem, const BAOptions& opt) override;
  PoseGraphResult optimizePoseGraph(PoseGraph& graph, const PoseGraphOptions& opt) override;

  struct Settings;

 private:
  std::shared_ptr<const Settings> s_;  // immutable once configured; shared by clones
};

}  // namespace dslam
