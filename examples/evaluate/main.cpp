// evaluate GROUND_TRUTH ESTIMATE [--align se3|sim3|none] [--delta SECONDS]
//
// ATE and RPE of an estimated trajectory against ground truth with
// dslam::eval (TUM, KITTI with 13 columns, or EuRoC files; format detected),
// the same computation as `dslam eval ate|rpe`.
#include <dslam/core/error.h>
#include <dslam/eval/eval.h>
#include <dslam/trajectory/io.h>

#include <cstdio>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
  std::string gt_file, est_file, align = "se3";
  double delta = 1.0;
  for (int i = 1; i < argc; i++) {
    const std::string a = argv[i];
    if (a == "--align" && i + 1 < argc) align = argv[++i];
    else if (a == "--delta" && i + 1 < argc) delta = std::stod(argv[++i]);
    else if (gt_file.empty() && a[0] != '-') gt_file = a;
    else if (est_file.empty() && a[0] != '-') est_file = a;
    else {
      std::cerr << "usage: evaluate GROUND_TRUTH ESTIMATE [--align se3|sim3|none] [--delta SECONDS]\n";
      return 2;
    }
  }
  if (est_file.empty()) {
    std::cerr << "usage: evaluate GROUND_TRUTH ESTIMATE [--align se3|sim3|none] [--delta SECONDS]\n";
    return 2;
  }
  try {
    const dslam::Trajectory gt = dslam::traj::read(gt_file);
    const dslam::Trajectory est = dslam::traj::read(est_file);

    dslam::eval::AteOptions ao;
    ao.align = dslam::eval::alignFromString(align);
    ao.gt_name = gt_file;
    ao.est_name = est_file;
    const dslam::eval::AteResult ate = dslam::eval::computeAte(gt, est, ao);
    std::printf("ATE  (%s): rmse %.4f m, mean %.4f, median %.4f, max %.4f over %zu pairs", align.c_str(),
                ate.stats.rmse, ate.stats.mean, ate.stats.median, ate.stats.max, ate.stats.count);
    if (ao.align == dslam::eval::Align::Sim3) std::printf(", scale %.4f", ate.alignment.scale);
    std::printf("\n");

    dslam::eval::RpeOptions ro;
    ro.delta = delta;
    ro.unit = dslam::eval::DeltaUnit::Seconds;
    ro.gt_name = gt_file;
    ro.est_name = est_file;
    const dslam::eval::RpeResult rpe = dslam::eval::computeRpe(gt, est, ro);
    std::printf("RPE  (%.3g s): translation rmse %.4f m, rotation rmse %.3f deg over %zu pairs\n", delta,
                rpe.trans.rmse, rpe.rot.rmse, rpe.trans.count);
  } catch (const dslam::Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
