#include <cmath>

#include "dslam/core/backend.h"

namespace dslam {

double huberCost(double s, double d) { return s <= d * d ? s : 2 * d * std::sqrt(s) - d * d; }

double evaluateCost(const BAProblem& p, const BAOptions& opt) {
  double cost = 0;
  for (const auto& o : p.observations) {
    if (o.outlier) continue;
    const auto& kf = p.keyframes[o.kf];
    const Eigen::Vector3d Xc = kf.T_cw * p.points[o.pt].X_w;
    const double iz = 1.0 / Xc.z();
    const double u = p.camera.fx * Xc.x() * iz + p.camera.cx;
    const double v = p.camera.fy * Xc.y() * iz + p.camera.cy;
    double s = (u - o.uv.x()) * (u - o.uv.x()) + (v - o.uv.y()) * (v - o.uv.y());
    const bool stereo = o.u_right >= 0;
    if (stereo) {
      const double ur = u - p.camera.bf * iz;
      s += (ur - o.u_right) * (ur - o.u_right);
    }
    s *= o.information;
    cost += opt.robust ? huberCost(s, stereo ? opt.huber_stereo : opt.huber_mono) : s;
  }
  return cost;
}

double evaluateCost(const PoseGraph& g) {
  double cost = 0;
  for (const auto& e : g.edges) {
    const SE3 err = e.T_from_to.inverse() * g.nodes[e.from].T_wc.inverse() * g.nodes[e.to].T_wc;
    const SE3::Vec6 r = err.log();
    cost += r.dot(e.information * r);
  }
  return cost;
}

}  // namespace dslam
