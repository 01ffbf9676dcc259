// docs/results.md, "KITTI: SE(3) and Sim(3) alignment": the stereo baseline
// on the 51-frame KITTI clip, evaluated as the page prints it. The clip's
// stereo scale and its poses.txt disagree by ~7% (an independent SGBM + PnP
// odometry finds the same, scripts/independent/stereo_scale_check.cpp), so
// the Sim(3) scale is ~0.93 and the SE(3) ATE is dominated by it. The page
// once gave 0.07-0.09 m at scale 0.954 with Sim(3); the printed commands give
// ~0.19 m at ~0.93, and an independent evaluator (numpy Umeyama,
// scripts/independent/umeyama_ate.py) agrees with dslam eval.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <regex>

#include "test_support.h"

using namespace dslam;

namespace {

nlohmann::json evalAte(const std::string& gt, const std::string& est, const char* align) {
  const auto r = test::runDslam(test::cat("eval ate '", gt, "' '", est, "' --align ", align, " --json"));
  EXPECT_EQ(r.exit_code, 0) << r.out;
  return nlohmann::json::parse(r.out.substr(r.out.find('{')));
}

}  // namespace

TEST(ResultsKitti, Sim3FigureReproducesAndAnIndependentEvaluatorAgrees) {
  DSLAM_REQUIRE_SHARED("data/kitti-stereo-51/poses.txt");
  const std::string kd = test::shared("data/kitti-stereo-51");
  const std::string out = test::tempDir("results_kitti") + "/run";
  const auto run = test::runDslam(test::cat("run '", test::source("config/pipelines/orbslam_baseline_stereo.yaml"),
                                            "' --dataset '", kd, "' --out '", out, "' --no-progress"));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  const auto sum = nlohmann::json::parse(test::readFile(out + "/summary.json"));
  EXPECT_EQ(sum["tracked"], 51);

  const std::string gt = kd + "/poses.txt", est = out + "/trajectory.txt";
  const auto se3 = evalAte(gt, est, "se3"), sim3 = evalAte(gt, est, "sim3");
  const double scale = sim3["scale"].get<double>(), sim3_rmse = sim3["rmse"].get<double>();
  std::cout << "KITTI 51: ATE SE(3) " << se3["rmse"] << " m, Sim(3) " << sim3_rmse << " m at scale " << scale << "\n";
  // The reconstruction is ~7% longer than poses.txt (scale < 1: the estimate is shrunk onto the ground truth).
  EXPECT_GT(scale, 0.90);
  EXPECT_LT(scale, 0.96);
  EXPECT_LT(sim3_rmse, 0.25);
  EXPECT_GT(sim3_rmse, 0.10);  // not the 0.07-0.09 m the page used to give
  EXPECT_GT(se3["rmse"].get<double>(), 3 * sim3_rmse);  // SE(3) is dominated by the scale

  // The independent evaluator (numpy only) gives the same numbers.
  std::string py;
  for (const char* p : {"python3", "/usr/bin/python3"})
    if (test::run(test::cat(p, " -c 'import numpy' 2>/dev/null")).exit_code == 0) {
      py = p;
      break;
    }
  ASSERT_FALSE(py.empty()) << "python3 with numpy is needed (apt-get install python3-numpy)";
  const auto ind = test::run(test::cat(py, " '", test::source("scripts/independent/umeyama_ate.py"), "' '", gt, "' '", est, "'"));
  ASSERT_EQ(ind.exit_code, 0) << ind.out;
  std::smatch m;
  const std::string text = ind.out;
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"(sim3: (\d+) pairs, rmse ([0-9.]+) m, max ([0-9.]+) m, scale ([0-9.]+))")))
      << text;
  EXPECT_EQ(std::stoi(m[1]), sim3["pairs"].get<int>());
  EXPECT_NEAR(std::stod(m[2]), sim3_rmse, 1e-3);
  EXPECT_NEAR(std::stod(m[4]), scale, 1e-3);
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"(se3: \d+ pairs, rmse ([0-9.]+) m)"))) << text;
  EXPECT_NEAR(std::stod(m[1]), se3["rmse"].get<double>(), 1e-3);
}
