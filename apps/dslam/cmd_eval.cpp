// `dslam eval ate GT EST [...]` and `dslam eval rpe GT EST --delta N --delta-unit frames|s|m [...]`:
// trajectory evaluation against ground truth (docs/evaluation.md).
#include <filesystem>
#include <iostream>
#include <sstream>

#include "command.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/eval/eval.h"
#include "dslam/eval/plot.h"
#include "dslam/trajectory/io.h"

void setupEvalDense(CLI::App& eval);

namespace {

using namespace dslam;

struct Common {
  std::string gt, est;
  double max_dt = 0.02;
  std::string align;
  bool json = false;
  std::string plot;
  std::string gt_format = "auto", est_format = "auto";
  std::string gt_times, est_times;
  std::string save_aligned;
};

void addCommon(CLI::App* c, Common& o, const char* default_align) {
  o.align = default_align;
  c->add_option("gt", o.gt, "ground-truth trajectory file")->required();
  c->add_option("est", o.est, "estimated trajectory file")->required();
  c->add_option("--max-dt", o.max_dt, "association threshold |t_gt - t_est| < max_dt, seconds")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  c->add_option("--align", o.align, "alignment of the estimate onto the ground truth")
      ->capture_default_str()
      ->check(CLI::IsMember({"se3", "sim3", "none"}));
  c->add_flag("--json", o.json, "print one JSON object instead of text");
  c->add_option("--plot", o.plot, "write a plot (PNG) and its data (CSV next to it)");
  const auto formats = CLI::IsMember({"auto", "tum", "kitti", "euroc"});
  c->add_option("--gt-format", o.gt_format, "ground-truth file format")->capture_default_str()->check(formats);
  c->add_option("--est-format", o.est_format, "estimate file format")->capture_default_str()->check(formats);
  c->add_option("--kitti-times", o.gt_times, "times file (one per line) for a 12-column KITTI ground truth");
  c->add_option("--est-kitti-times", o.est_times, "times file (one per line) for a 12-column KITTI estimate");
  c->add_option("--save-aligned", o.save_aligned,
                "write the aligned estimate (TUM format; EuRoC CSV if the name ends in .csv)");
}

Trajectory load(const std::string& path, const std::string& format, const std::string& times, const char* what) {
  traj::ReadOptions ro;
  ro.format = traj::formatFromString(format);
  if (ro.format == traj::Format::Auto && !std::filesystem::is_regular_file(path))
    throw DataError(std::string(what) + " trajectory file not found: " + path);
  const traj::Format actual = ro.format == traj::Format::Auto ? traj::detectFormat(path) : ro.format;
  if (!times.empty() && actual != traj::Format::Kitti)
    throw ConfigError(std::string("a KITTI times file was given for the ") + what + " trajectory " + path +
                      ", which is in " + traj::toString(actual) + " format");
  ro.kitti_times = times;
  Trajectory t = traj::read(path, ro);
  DSLAM_LOG(Debug, what << ": " << path << " (" << traj::toString(actual) << "), " << t.size() << " poses");
  return t;
}

void saveAligned(const Common& o, const Trajectory& aligned, const eval::Alignment& a) {
  traj::WriteOptions wo;
  wo.format = std::filesystem::path(o.save_aligned).extension() == ".csv" ? traj::Format::Euroc : traj::Format::Tum;
  wo.header = "estimate " + o.est + " aligned onto " + o.gt + " (" + eval::toString(a.method) +
              ", scale " + std::to_string(a.scale) + ")";
  traj::write(o.save_aligned, aligned, wo);
  DSLAM_LOG(Info, "aligned estimate written to " << o.save_aligned);
}

void header(const Common& o) {
  std::cout << "ground truth: " << o.gt << "\nestimate:     " << o.est << "\n";
}

/** Prints an ATE or RPE result (JSON or text), then writes the aligned
 *  estimate and the plot when asked; `plot` draws and returns the CSV path. */
template <class Result, class PlotFn>
void report(const Common& o, const Result& r, PlotFn plot) {
  if (o.json) {
    std::cout << eval::toJson(r) << std::endl;
  } else {
    header(o);
    std::cout << eval::toText(r) << std::flush;
  }
  if (!o.save_aligned.empty()) saveAligned(o, r.aligned, r.alignment);
  if (!o.plot.empty()) {
    const std::string csv = plot();
    DSLAM_LOG(Info, "plot written to " << o.plot << " (data: " << csv << ")");
  }
}

void runAte(const Common& o) {
  const Trajectory gt = load(o.gt, o.gt_format, o.gt_times, "ground-truth");
  const Trajectory est = load(o.est, o.est_format, o.est_times, "estimate");
  eval::AteOptions opt;
  opt.max_dt = o.max_dt;
  opt.align = eval::alignFromString(o.align);
  opt.gt_name = o.gt;
  opt.est_name = o.est;
  const auto r = eval::computeAte(gt, est, opt);
  report(o, r, [&] {
    return eval::plot(o.plot, eval::plotRows(gt, r), "ATE " + std::filesystem::path(o.est).filename().string(),
                      "ATE [m]");
  });
}

void runRpe(const Common& o, double delta, const std::string& unit) {
  const Trajectory gt = load(o.gt, o.gt_format, o.gt_times, "ground-truth");
  const Trajectory est = load(o.est, o.est_format, o.est_times, "estimate");
  eval::RpeOptions opt;
  opt.max_dt = o.max_dt;
  opt.align = eval::alignFromString(o.align);
  opt.delta = delta;
  opt.unit = eval::deltaUnitFromString(unit);
  opt.gt_name = o.gt;
  opt.est_name = o.est;
  const auto r = eval::computeRpe(gt, est, opt);
  report(o, r, [&] {
    return eval::plot(o.plot, eval::plotRows(gt, est, r), "RPE " + std::filesystem::path(o.est).filename().string(),
                      "RPE trans. [m] (delta " + (std::ostringstream() << delta).str() + " " + unit + ")");
  });
}

void setup(CLI::App& sub) {
  sub.require_subcommand(1);
  static Common ate_o, rpe_o;
  static double delta = 1;
  static std::string unit = "frames";

  auto* ate = sub.add_subcommand("ate", "Absolute trajectory error (translational, after alignment)");
  addCommon(ate, ate_o, "se3");
  ate->callback([] { runAte(ate_o); });

  auto* rpe = sub.add_subcommand("rpe", "Relative pose error over a fixed delta (translational m, rotational deg)");
  addCommon(rpe, rpe_o, "none");
  rpe->add_option("--delta", delta, "pair distance, in --delta-unit")->capture_default_str()->check(
      CLI::PositiveNumber);
  rpe->add_option("--delta-unit", unit, "frames: associated poses; s: seconds; m: metres of ground-truth path")
      ->capture_default_str()
      ->check(CLI::IsMember({"frames", "s", "m"}));
  rpe->callback([] { runRpe(rpe_o, delta, unit); });

  setupEvalDense(sub);  // cmd_eval_dense.cpp
}

}  // namespace

DSLAM_COMMAND(eval, "Evaluate a trajectory (ATE, RPE) or a dense map against ground truth", setup);
