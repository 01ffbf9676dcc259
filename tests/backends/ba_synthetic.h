#pragma once
// Synthetic bundle-adjustment and pose-graph problems (seeded), shared by
// tests/backends and benchmarks/bench_backends.cpp.
#include <cmath>
#include <random>
#include <vector>

#include "dslam/core/backend.h"

namespace dslam::test {

struct SynthBAConfig {
  int keyframes = 10;
  int points = 1000;
  double path_length = 2.0;  ///< m, keyframes spread along x; points span x in +-(path_length / 2 + 2)
  bool stereo = false;      ///< add u_right to every observation
  double pixel_sigma = 1.0; ///< noise of u, v, u_right at level 0 (0 = exact observations)
  int levels = 1;           ///< > 1: random pyramid level: noise pixel_sigma * 1.2^level, information 1.2^(-2 level)
  int fixed_keyframes = 2;  ///< the first ones
  int fixed_points = 0;     ///< the first ones
  double outlier_ratio = 0; ///< observations replaced by a gross error of 20-60 px
  double pose_noise_t = 0.03;          ///< m, per axis, initial estimate of free keyframes
  double pose_noise_r = 1.5 * M_PI / 180;  ///< rad, per axis
  double point_noise = 0.05;           ///< m, per axis, initial estimate of free points
  unsigned seed = 1;
};

/** ~ORB-SLAM2 RGB-D local BA: 20 keyframes (2 fixed) along 12 m, 3000
 *  points (each keyframe sees about a third of them), stereo residuals, 4
 *  pyramid levels, 2 % gross outliers (bench_backends and the backend tests). */
inline SynthBAConfig localBAConfig() {
  SynthBAConfig c;
  c.keyframes = 20;
  c.points = 3000;
  c.path_length = 12;
  c.stereo = true;
  c.levels = 4;
  c.fixed_keyframes = 2;
  c.outlier_ratio = 0.02;
  return c;
}

struct SynthBA {
  BAProblem problem;                ///< perturbed initial estimates, noisy observations
  std::vector<SE3> true_T_cw;
  std::vector<Eigen::Vector3d> true_X;
  std::vector<char> is_outlier;     ///< per observation: injected gross error
};

inline SE3 smallRotation(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0, sigma);
  const Eigen::Vector3d w(n(rng), n(rng), n(rng));
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.norm() > 0 ? w.normalized() : Eigen::Vector3d::UnitX())),
             Eigen::Vector3d::Zero());
}

/** Camera 640x480, f = 500, bf = 40 (8 cm baseline, as a Kinect in
 *  ORB-SLAM2). Keyframes move sideways along x over path_length looking at
 *  +z with small rotations; points in x in +-(path_length / 2 + 2), y in
 *  [-2, 2], z in [3, 7]. Each point is observed by every keyframe that sees
 *  it in the image. */
inline SynthBA makeBA(const SynthBAConfig& c) {
  SynthBA s;
  std::mt19937 rng(c.seed);
  auto& p = s.problem;
  p.camera = {500, 500, 320, 240, c.stereo ? 40.0 : 0.0};
  const double half_x = c.path_length / 2 + 2;
  std::uniform_real_distribution<double> ux(-half_x, half_x), uy(-2, 2), uz(3, 7);
  std::uniform_real_distribution<double> uang(0, 2 * M_PI), umag(20, 60), u01(0, 1);
  std::normal_distribution<double> n01(0, 1);
  for (int k = 0; k < c.keyframes; k++) {
    const double a = c.keyframes > 1 ? double(k) / (c.keyframes - 1) : 0;
    const Eigen::Vector3d centre(c.path_length * (a - 0.5), 0.1 * std::sin(3 * a), 0.2 * std::cos(2 * a) - 0.2);
    const Eigen::Quaterniond R(Eigen::AngleAxisd(0.08 * std::sin(5 * a), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.05 * std::cos(4 * a), Eigen::Vector3d::UnitX()));
    const SE3 T_cw = SE3(R, centre).inverse();
    s.true_T_cw.push_back(T_cw);
    BAKeyframe kf;
    kf.id = 100 + k;
    kf.fixed = k < c.fixed_keyframes;
    kf.T_cw = T_cw;
    if (!kf.fixed) {
      std::normal_distribution<double> nt(0, c.pose_noise_t);
      kf.T_cw = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(nt(rng), nt(rng), nt(rng))) *
                smallRotation(rng, c.pose_noise_r) * T_cw;
    }
    p.keyframes.push_back(kf);
  }
  for (int i = 0; i < c.points; i++) {
    const Eigen::Vector3d X(ux(rng), uy(rng), uz(rng));
    s.true_X.push_back(X);
    BAPoint pt;
    pt.id = 1000 + i;
    pt.fixed = i < c.fixed_points;
    std::normal_distribution<double> np(0, c.point_noise);
    pt.X_w = pt.fixed ? X : Eigen::Vector3d(X + Eigen::Vector3d(np(rng), np(rng), np(rng)));
    p.points.push_back(pt);
  }
  const auto& cam = p.camera;
  for (int i = 0; i < c.points; i++)
    for (int k = 0; k < c.keyframes; k++) {
      const Eigen::Vector3d Xc = s.true_T_cw[k] * s.true_X[i];
      if (Xc.z() < 0.5) continue;
      const double u = cam.fx * Xc.x() / Xc.z() + cam.cx, v = cam.fy * Xc.y() / Xc.z() + cam.cy;
      if (u < 0 || u >= 640 || v < 0 || v >= 480) continue;
      const int level = c.levels > 1 ? int(u01(rng) * c.levels) % c.levels : 0;
      const double level_sigma = std::pow(1.2, level), sigma = c.pixel_sigma * level_sigma;
      BAObservation o;
      o.kf = k;
      o.pt = i;
      o.information = 1.0 / (level_sigma * level_sigma);  // ORB-SLAM: invSigma2 of the level
      o.uv = Eigen::Vector2d(u + sigma * n01(rng), v + sigma * n01(rng));
      if (c.stereo) o.u_right = u - cam.bf / Xc.z() + sigma * n01(rng);
      // always draw, so that the inlier noise does not depend on outlier_ratio
      const double pick = u01(rng), ang = uang(rng), mag = umag(rng);
      const bool gross = pick < c.outlier_ratio;
      if (gross) {
        o.uv += mag * Eigen::Vector2d(std::cos(ang), std::sin(ang));
        if (c.stereo) o.u_right += mag * std::cos(ang);
      }
      s.is_outlier.push_back(gross);
      p.observations.push_back(o);
    }
  return s;
}

struct SynthPG {
  PoseGraph graph;  ///< nodes initialised by chaining the noisy odometry
  std::vector<SE3> true_T_wc;
};

/** A loop of n poses on a circle of radius 5 m (camera looking inwards, small
 *  height oscillation); odometry edges i -> i+1 with noise (sigma_t per axis,
 *  sigma_r per axis), one loop-closure edge n-1 -> 0 with the same noise.
 *  Node 0 fixed. Initial estimates: odometry chained from node 0 (drifts). */
inline SynthPG makePoseGraph(int n = 30, double sigma_t = 0.03, double sigma_r = 1.0 * M_PI / 180,
                             unsigned seed = 3) {
  SynthPG s;
  std::mt19937 rng(seed);
  std::normal_distribution<double> nt(0, sigma_t);
  for (int i = 0; i < n; i++) {
    const double a = 2 * M_PI * i / n;
    const Eigen::Vector3d c(5 * std::cos(a), 0.3 * std::sin(3 * a), 5 * std::sin(a));
    // camera z axis towards the circle centre, y axis down
    const Eigen::Vector3d z = -Eigen::Vector3d(std::cos(a), 0, std::sin(a)), y(0, 1, 0);
    Eigen::Matrix3d R;
    R.col(2) = z;
    R.col(1) = y;
    R.col(0) = y.cross(z);
    s.true_T_wc.push_back(SE3(R, c));
  }
  Eigen::Matrix<double, 6, 6> info = Eigen::Matrix<double, 6, 6>::Identity();
  info.topLeftCorner<3, 3>() *= 1.0 / (sigma_t * sigma_t);
  info.bottomRightCorner<3, 3>() *= 1.0 / (sigma_r * sigma_r);
  auto noisy = [&](const SE3& Z) {
    return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(nt(rng), nt(rng), nt(rng))) * Z *
           smallRotation(rng, sigma_r);
  };
  for (int i = 0; i < n; i++) {
    const int j = (i + 1) % n;
    PoseGraphEdge e;
    e.from = i;
    e.to = j;
    e.T_from_to = noisy(s.true_T_wc[i].inverse() * s.true_T_wc[j]);
    e.information = info;
    s.graph.edges.push_back(e);
  }
  s.graph.nodes.resize(n);
  for (int i = 0; i < n; i++) {
    s.graph.nodes[i].id = i;
    s.graph.nodes[i].fixed = i == 0;
    s.graph.nodes[i].T_wc = i == 0 ? s.true_T_wc[0] : s.graph.nodes[i - 1].T_wc * s.graph.edges[i - 1].T_from_to;
  }
  return s;
}

}  // namespace dslam::test
