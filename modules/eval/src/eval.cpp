#include "dslam/eval/eval.h"

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/trajectory/associate.h"

namespace dslam::eval {

// ---------------------------------------------------------------- basics --

Align alignFromString(const std::string& s) {
  if (s == "none") return Align::None;
  if (s == "se3") return Align::SE3;
  if (s == "sim3") return Align::Sim3;
  throw ConfigError("unknown alignment '" + s + "' (valid: se3, sim3, none)");
}

const char* toString(Align a) {
  switch (a) {
    case Align::None: return "none";
    case Align::SE3: return "se3";
    case Align::Sim3: return "sim3";
  }
  return "?";
}

DeltaUnit deltaUnitFromString(const std::string& s) {
  if (s == "frames" || s == "f") return DeltaUnit::Frames;
  if (s == "s") return DeltaUnit::Seconds;
  if (s == "m") return DeltaUnit::Meters;
  throw ConfigError("unknown RPE delta unit '" + s + "' (valid: frames, s, m)");
}

const char* toString(DeltaUnit u) {
  switch (u) {
    case DeltaUnit::Frames: return "frames";
    case DeltaUnit::Seconds: return "s";
    case DeltaUnit::Meters: return "m";
  }
  return "?";
}

Stats computeStats(const std::vector<double>& v) {
  if (v.empty()) throw DataError("error statistics of an empty list");
  Stats s;
  s.count = v.size();
  const double n = static_cast<double>(v.size());
  double sum = 0, sq = 0;
  s.min = v.front();
  s.max = v.front();
  for (double e : v) {
    sum += e;
    sq += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sq / n);
  double var = 0;
  for (double e : v) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  if (!std::isfinite(s.rmse) || !std::isfinite(s.std))
    throw DataError("the errors are not finite numbers: pose coordinates too large for double precision (" +
                    std::to_string(s.max) + " m)");
  std::vector<double> w = v;
  const size_t h = w.size() / 2;
  std::nth_element(w.begin(), w.begin() + h, w.end());
  s.median = w[h];
  if (w.size() % 2 == 0) s.median = 0.5 * (s.median + *std::max_element(w.begin(), w.begin() + h));
  return s;
}

Eigen::Matrix4d Alignment::matrix() const {
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  M.block<3, 3>(0, 0) = scale * T.rotation();
  M.block<3, 1>(0, 3) = T.translation();
  return M;
}

Eigen::Vector3d Alignment::apply(const Eigen::Vector3d& p) const {
  return scale * (T.quaternion() * p) + T.translation();
}

SE3 Alignment::apply(const SE3& T_wc) const {
  return SE3(T.quaternion() * T_wc.quaternion(), apply(T_wc.translation()));
}

Trajectory Alignment::apply(const Trajectory& t) const {
  Trajectory out;
  out.stamps = t.stamps;
  out.poses.reserve(t.size());
  for (const auto& p : t.poses) out.poses.push_back(apply(p));
  return out;
}

Alignment alignPoints(const std::vector<Eigen::Vector3d>& est, const std::vector<Eigen::Vector3d>& gt, Align method) {
  if (est.size() != gt.size())
    throw Error("alignPoints: " + std::to_string(est.size()) + " estimate points but " + std::to_string(gt.size()) +
                " ground-truth points");
  Alignment a;
  a.method = method;
  if (method == Align::None) return a;
  if (est.size() < 3)
    throw DataError(std::string(toString(method)) + " alignment needs at least 3 associated poses, got " +
                    std::to_string(est.size()) + " (use --align none)");
  const Eigen::Index n = static_cast<Eigen::Index>(est.size());
  Eigen::Matrix3Xd src(3, n), dst(3, n);
  for (Eigen::Index i = 0; i < n; i++) {
    src.col(i) = est[static_cast<size_t>(i)];
    dst.col(i) = gt[static_cast<size_t>(i)];
  }
  if (method == Align::Sim3) {
    auto samePoint = [n](const Eigen::Matrix3Xd& m) {
      const Eigen::Vector3d c = m.rowwise().mean();
      return (m.colwise() - c).squaredNorm() / static_cast<double>(n) < 1e-24;
    };
    if (samePoint(src))
      throw DataError("sim3 alignment: the associated estimate positions are all the same point (scale undefined)");
    if (samePoint(dst))
      throw DataError("sim3 alignment: the associated ground-truth positions are all the same point (scale undefined)");
  }
  const Eigen::Matrix4d M = Eigen::umeyama(src, dst, method == Align::Sim3);
  if (!M.allFinite())
    throw DataError(std::string(toString(method)) +
                    " alignment failed (non-finite result): positions too large or degenerate for double precision");
  Eigen::Matrix3d sR = M.block<3, 3>(0, 0);
  a.scale = method == Align::Sim3 ? sR.col(0).norm() : 1.0;
  a.T = SE3(Eigen::Matrix3d(sR / a.scale), Eigen::Vector3d(M.block<3, 1>(0, 3)));
  return a;
}

namespace {
std::string span(const Trajectory& t) {
  return "[" + formatNumber("%.6f", t.stamps.front()) + ", " + formatNumber("%.6f", t.stamps.back()) + "] s";
}
}  // namespace

Association associate(const Trajectory& gt, const Trajectory& est, double max_dt, const std::string& gt_name,
                      const std::string& est_name) {
  if (gt.empty()) throw DataError(gt_name + ": ground truth has no poses");
  if (est.empty()) throw DataError(est_name + ": estimate has no poses");
  Association a;
  a.max_dt = max_dt;
  a.pairs = traj::associate(gt.stamps, est.stamps, max_dt);
  if (a.pairs.empty())
    throw DataError("no ground-truth pose within max_dt " + formatNumber("%g", max_dt) + " s of any of the " +
                    std::to_string(est.size()) + " estimate poses: ground truth " + gt_name + " spans " + span(gt) +
                    " (" + std::to_string(gt.size()) + " poses), estimate " + est_name + " spans " + span(est) +
                    " (check the timestamps, the files' formats or --max-dt)");
  return a;
}

Alignment alignTrajectories(const Trajectory& gt, const Trajectory& est, const Association& assoc, Align method) {
  std::vector<Eigen::Vector3d> pe, pg;
  pe.reserve(assoc.size());
  pg.reserve(assoc.size());
  for (auto [i, j] : assoc.pairs) {
    pg.push_back(gt.poses[i].translation());
    pe.push_back(est.poses[j].translation());
  }
  return alignPoints(pe, pg, method);
}

// ------------------------------------------------------------------- ATE --

AteResult computeAte(const Trajectory& gt, const Trajectory& est, const AteOptions& opt) {
  AteResult r;
  r.options = opt;
  r.assoc = associate(gt, est, opt.max_dt, opt.gt_name, opt.est_name);
  r.alignment = alignTrajectories(gt, est, r.assoc, opt.align);
  r.aligned = r.alignment.apply(est);
  r.errors.reserve(r.assoc.size());
  for (auto [i, j] : r.assoc.pairs)
    r.errors.push_back((gt.poses[i].translation() - r.aligned.poses[j].translation()).norm());
  r.stats = computeStats(r.errors);
  return r;
}

// ------------------------------------------------------------------- RPE --

double rotationAngle(const SE3& T) {
  const Eigen::Quaterniond& q = T.quaternion();
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
}

SE3 relativeError(const SE3& gt0, const SE3& gt1, const SE3& est0, const SE3& est1) {
  return (gt0.inverse() * gt1).inverse() * (est0.inverse() * est1);
}

RpeResult computeRpe(const Trajectory& gt, const Trajectory& est, const RpeOptions& opt) {
  if (!(opt.delta > 0) || !std::isfinite(opt.delta))
    throw ConfigError("RPE delta must be positive, got " + formatNumber("%g", opt.delta));
  if (opt.unit == DeltaUnit::Frames && opt.delta != std::floor(opt.delta))
    throw ConfigError("RPE delta in frames must be an integer, got " + formatNumber("%g", opt.delta));

  RpeResult r;
  r.options = opt;
  r.assoc = associate(gt, est, opt.max_dt, opt.gt_name, opt.est_name);
  const auto& P = r.assoc.pairs;
  const size_t n = P.size();
  if (n < 2)
    throw DataError("RPE needs at least 2 associated poses, got " + std::to_string(n) + " (ground truth " +
                    opt.gt_name + ", estimate " + opt.est_name + ")");
  r.alignment = alignTrajectories(gt, est, r.assoc, opt.align);
  r.aligned = r.alignment.apply(est);

  // Pair selection.
  std::vector<std::pair<size_t, size_t>> ks;
  if (opt.unit == DeltaUnit::Frames) {
    const size_t d = static_cast<size_t>(opt.delta);
    for (size_t k = 0; k + d < n; k++) ks.emplace_back(k, k + d);
  } else {
    std::vector<double> key(n);
    double tol = 1e-6;
    if (opt.unit == DeltaUnit::Seconds) {
      for (size_t k = 0; k < n; k++) key[k] = gt.stamps[P[k].first];
    } else {
      std::vector<double> cum(gt.size(), 0.0);
      for (size_t i = 1; i < gt.size(); i++)
        cum[i] = cum[i - 1] + (gt.poses[i].translation() - gt.poses[i - 1].translation()).norm();
      for (size_t k = 0; k < n; k++) key[k] = cum[P[k].first];
      tol = 1e-9 * std::max(1.0, opt.delta);
      for (size_t k = 1; k < n; k++)
        if (key[k] < key[k - 1]) throw DataError("RPE in metres needs the ground truth sorted by time: " + opt.gt_name);
    }
    size_t j = 0;
    for (size_t k = 0; k < n; k++) {
      if (j <= k) j = k + 1;
      while (j < n && key[j] - key[k] < opt.delta - tol) j++;
      if (j >= n) break;  // keys are non-decreasing: no later k finds a partner either
      ks.emplace_back(k, j);
    }
  }
  if (ks.empty()) {
    std::string what;
    if (opt.unit == DeltaUnit::Frames) {
      what = std::to_string(n) + " associated poses";
    } else if (opt.unit == DeltaUnit::Seconds) {
      what = "associated poses span " + formatNumber("%.6g", gt.stamps[P.back().first] - gt.stamps[P.front().first]) + " s";
    } else {
      double L = 0;
      for (size_t i = P.front().first + 1; i <= P.back().first; i++)
        L += (gt.poses[i].translation() - gt.poses[i - 1].translation()).norm();
      what = "associated poses span " + formatNumber("%.6g", L) + " m of ground-truth path";
    }
    throw DataError("RPE: no pose pair " + formatNumber("%g", opt.delta) + " " + toString(opt.unit) + " apart (" + what +
                    "; ground truth " + opt.gt_name + ", estimate " + opt.est_name + ")");
  }

  std::vector<double> et, er;
  r.pairs.reserve(ks.size());
  for (auto [k0, k1] : ks) {
    const auto [g0, e0] = P[k0];
    const auto [g1, e1] = P[k1];
    const SE3 E = relativeError(gt.poses[g0], gt.poses[g1], r.aligned.poses[e0], r.aligned.poses[e1]);
    RpePair rp;
    rp.k0 = k0;
    rp.k1 = k1;
    rp.t0 = gt.stamps[g0];
    rp.t1 = gt.stamps[g1];
    rp.trans = E.translation().norm();
    rp.rot = rotationAngle(E) * 180.0 / M_PI;
    r.pairs.push_back(rp);
    et.push_back(rp.trans);
    er.push_back(rp.rot);
  }
  r.trans = computeStats(et);
  r.rot = computeStats(er);
  return r;
}

// ------------------------------------------------------------- reports --

namespace {

/** JSON number; NaN/inf become null (as before: JSON has no NaN). */
nlohmann::ordered_json num(double v) {
  if (!std::isfinite(v)) return nullptr;
  return v;
}

nlohmann::ordered_json statsJson(const Stats& s) {
  return {{"rmse", num(s.rmse)}, {"mean", num(s.mean)}, {"median", num(s.median)},
          {"std", num(s.std)},   {"min", num(s.min)},   {"max", num(s.max)}};
}

std::string statsText(const Stats& s, const char* unit) {
  std::ostringstream o;
  auto line = [&](const char* name, double v) { o << "  " << name << formatNumber("%.7f", v) << " " << unit << "\n"; };
  line("rmse   ", s.rmse);
  line("mean   ", s.mean);
  line("median ", s.median);
  line("std    ", s.std);
  line("min    ", s.min);
  line("max    ", s.max);
  return o.str();
}

std::string alignText(const Alignment& a) {
  std::string s = toString(a.method);
  if (a.method == Align::Sim3) s += " (scale " + formatNumber("%.6f", a.scale) + ")";
  return s;
}

}  // namespace

std::string toJson(const AteResult& r) {
  nlohmann::ordered_json j = {{"metric", "ate"},
                              {"pairs", r.stats.count},
                              {"max_dt", num(r.assoc.max_dt)},
                              {"align", toString(r.alignment.method)},
                              {"scale", num(r.alignment.scale)}};
  const nlohmann::ordered_json stats = statsJson(r.stats);
  for (const auto& [k, v] : stats.items()) j[k] = v;
  return j.dump();
}

std::string toJson(const RpeResult& r) {
  nlohmann::ordered_json j = {{"metric", "rpe"},
                              {"pairs", r.pairs.size()},
                              {"associated", r.assoc.size()},
                              {"max_dt", num(r.assoc.max_dt)},
                              {"align", toString(r.alignment.method)},
                              {"scale", num(r.alignment.scale)},
                              {"delta", num(r.options.delta)},
                              {"delta_unit", toString(r.options.unit)},
                              {"trans", statsJson(r.trans)},
                              {"rot", statsJson(r.rot)}};
  return j.dump();
}

std::string toText(const AteResult& r) {
  std::ostringstream o;
  o << "ATE (translational, after alignment)\n"
    << "  max_dt " << formatNumber("%g", r.assoc.max_dt) << " s, alignment " << alignText(r.alignment) << ", "
    << r.stats.count << " pose pairs\n"
    << statsText(r.stats, "m");
  return o.str();
}

std::string toText(const RpeResult& r) {
  std::ostringstream o;
  o << "RPE (delta " << formatNumber("%g", r.options.delta) << " " << toString(r.options.unit) << ")\n"
    << "  max_dt " << formatNumber("%g", r.assoc.max_dt) << " s, alignment " << alignText(r.alignment) << ", "
    << r.assoc.size() << " associated poses, " << r.pairs.size() << " pose pairs\n"
    << "translational:\n"
    << statsText(r.trans, "m") << "rotational:\n"
    << statsText(r.rot, "deg");
  return o.str();
}

}  // namespace dslam::eval
