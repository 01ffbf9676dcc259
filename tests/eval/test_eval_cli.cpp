// `dslam eval ate|rpe`: golden numbers through the CLI (--json and text),
// other input formats, --save-aligned, --plot, and error exits.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "dslam/eval/plot.h"
#include "dslam/trajectory/io.h"
#include "test_support.h"

using namespace dslam;
using dslam::test::runDslam;
using dslam::test::tempDir;

namespace {

std::string goldenGt() { return dslam::test::shared("data/eval-golden/freiburg1_xyz-groundtruth.txt"); }
std::string goldenEst() { return dslam::test::shared("data/eval-golden/freiburg1_xyz-rgbdslam.txt"); }

/** Number `key` of the JSON object printed by dslam eval (inside object
 *  `section` if given: trans / rot). NaN if missing or not a number. */
double jsonNum(const std::string& text, const std::string& key, const std::string& section = "") {
  const auto j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return NAN;
  const nlohmann::json& o = section.empty() ? j : j.value(section, nlohmann::json::object());
  if (!o.contains(key) || !o[key].is_number()) return NAN;
  return o[key].get<double>();
}

std::string jsonStr(const std::string& text, const std::string& key) {
  const auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains(key) || !j[key].is_string()) return "";
  return j[key].get<std::string>();
}

void expectGoldenAteJson(const std::string& out) {
  EXPECT_EQ(jsonNum(out, "pairs"), 786) << out;
  EXPECT_NEAR(jsonNum(out, "rmse"), 0.0134735, 1e-6) << out;
  EXPECT_NEAR(jsonNum(out, "mean"), 0.0120295, 1e-6) << out;
  EXPECT_NEAR(jsonNum(out, "median"), 0.0111758, 1e-6) << out;
  EXPECT_NEAR(jsonNum(out, "std"), 0.0060684, 1e-6) << out;
  EXPECT_NEAR(jsonNum(out, "min"), 0.0009387, 1e-6) << out;
  EXPECT_NEAR(jsonNum(out, "max"), 0.0347272, 1e-6) << out;
}

std::string q(const std::string& s) { return "'" + s + "'"; }

}  // namespace

TEST(EvalCli, GoldenAteJson) {
  const auto r = runDslam("eval ate " + q(goldenGt()) + " " + q(goldenEst()) + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(r.out.front(), '{') << r.out;  // nothing but the JSON object on stdout/stderr
  EXPECT_EQ(jsonStr(r.out, "metric"), "ate") << r.out;
  EXPECT_EQ(jsonStr(r.out, "align"), "se3") << r.out;
  EXPECT_EQ(jsonNum(r.out, "max_dt"), 0.02);
  EXPECT_EQ(jsonNum(r.out, "scale"), 1.0);
  expectGoldenAteJson(r.out);
}

TEST(EvalCli, GoldenAteText) {
  const auto r = runDslam("eval ate " + q(goldenGt()) + " " + q(goldenEst()));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("max_dt 0.02 s, alignment se3, 786 pose pairs"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("rmse   0.0134735 m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("median 0.0111758 m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("max    0.0347272 m"), std::string::npos) << r.out;
}

TEST(EvalCli, GoldenRpeJson) {
  const auto r =
      runDslam("eval rpe " + q(goldenGt()) + " " + q(goldenEst()) + " --delta 1 --delta-unit frames --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(jsonStr(r.out, "metric"), "rpe") << r.out;
  EXPECT_EQ(jsonStr(r.out, "delta_unit"), "frames") << r.out;
  EXPECT_EQ(jsonNum(r.out, "pairs"), 785) << r.out;
  EXPECT_EQ(jsonNum(r.out, "associated"), 786) << r.out;
  EXPECT_NEAR(jsonNum(r.out, "rmse", "trans"), 0.0057592, 1e-6) << r.out;
  EXPECT_NEAR(jsonNum(r.out, "rmse", "rot"), 0.35283, 5e-6) << r.out;  // reference has 5 decimals
}

TEST(EvalCli, GoldenInOtherFormats) {
  const std::string d = tempDir("evalcli");
  const Trajectory est = traj::read(goldenEst());
  traj::WriteOptions k;
  k.format = traj::Format::Kitti;
  k.kitti_with_times = true;
  traj::write(d + "/k13.txt", est, k);
  k.kitti_with_times = false;
  traj::write(d + "/k12.txt", est, k);
  dslam::test::writeKittiTimes(d + "/times.txt", est.stamps);
  traj::write(d + "/est.csv", est, {traj::Format::Euroc, false, ""});
  // The ground truth as EuRoC too (read with an explicit format).
  traj::write(d + "/gt_euroc.txt", traj::read(goldenGt()), {traj::Format::Euroc, false, ""});

  const std::string gt = q(goldenGt());
  for (const std::string& args :
       {"eval ate " + gt + " " + q(d + "/k13.txt") + " --json",
        "eval ate " + gt + " " + q(d + "/k12.txt") + " --est-kitti-times " + q(d + "/times.txt") + " --json",
        "eval ate " + gt + " " + q(d + "/k12.txt") + " --est-format kitti --est-kitti-times " + q(d + "/times.txt") +
            " --json",
        "eval ate " + gt + " " + q(d + "/est.csv") + " --json",
        "eval ate " + q(d + "/gt_euroc.txt") + " --gt-format euroc " + q(d + "/est.csv") + " --json"}) {
    SCOPED_TRACE(args);
    const auto r = runDslam(args);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    expectGoldenAteJson(r.out);
  }
  const auto r = runDslam("eval rpe " + gt + " " + q(d + "/est.csv") + " --delta 1 --delta-unit frames --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NEAR(jsonNum(r.out, "rmse", "trans"), 0.0057592, 1e-6) << r.out;
}

TEST(EvalCli, SaveAlignedWritesTheAlignedEstimate) {
  const std::string d = tempDir("evalcli");
  const auto r = runDslam("eval ate " + q(goldenGt()) + " " + q(goldenEst()) + " --save-aligned " +
                          q(d + "/aligned.txt") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Trajectory a = traj::read(d + "/aligned.txt");
  EXPECT_EQ(a.size(), traj::read(goldenEst()).size());
  // Already aligned: evaluating without alignment gives the same ATE.
  const auto r2 = runDslam("eval ate " + q(goldenGt()) + " " + q(d + "/aligned.txt") + " --align none --json");
  ASSERT_EQ(r2.exit_code, 0) << r2.out;
  expectGoldenAteJson(r2.out);
}

TEST(EvalCli, Errors) {
  const std::string d = tempDir("evalcli");
  // No time overlap.
  dslam::test::writeFile(d + "/far.txt", "10.0 0 0 0 0 0 0 1\n10.1 0 0 0 0 0 0 1\n10.2 0 0 0 0 0 0 1\n");
  auto r = runDslam("eval ate " + q(goldenGt()) + " " + q(d + "/far.txt"));
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("error: no ground-truth pose within max_dt 0.02 s of any of the 3 estimate poses"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find(d + "/far.txt"), std::string::npos) << r.out;
  // Bad line.
  dslam::test::writeFile(d + "/bad.txt", "1305031102.16 0 0 0 0 0 0 1\n1305031102.2 0 0 x 0 0 0 1\n");
  r = runDslam("eval ate " + q(goldenGt()) + " " + q(d + "/bad.txt"));
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find(d + "/bad.txt:2: field 4 is not a number: 'x'"), std::string::npos) << r.out;
  // Missing file.
  r = runDslam("eval rpe " + q(goldenGt()) + " " + q(d + "/missing.txt"));
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("not found: " + d + "/missing.txt"), std::string::npos) << r.out;
  // Times file for a TUM trajectory.
  r = runDslam("eval ate " + q(goldenGt()) + " " + q(goldenEst()) + " --est-kitti-times " + q(d + "/far.txt"));
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("KITTI times file was given for the estimate trajectory"), std::string::npos) << r.out;
  // Invalid option values are usage errors.
  r = runDslam("eval ate " + q(goldenGt()) + " " + q(goldenEst()) + " --align affine");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("--align"), std::string::npos) << r.out;
  r = runDslam("eval rpe " + q(goldenGt()) + " " + q(goldenEst()) + " --delta 1 --delta-unit deg");
  EXPECT_NE(r.exit_code, 0);
  r = runDslam("eval rpe " + q(goldenGt()) + " " + q(goldenEst()) + " --delta 1.5");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("delta in frames must be an integer"), std::string::npos) << r.out;
}

TEST(EvalCli, PlotWritesPngAndCsv) {
  if (eval::findPlotPython().empty()) GTEST_SKIP() << "no python3 with matplotlib (apt-get install python3-matplotlib)";
  const std::string d = tempDir("evalplot");
  const auto r =
      runDslam("eval ate " + q(goldenGt()) + " " + q(goldenEst()) + " --json --plot " + q(d + "/ate.png"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  ASSERT_TRUE(std::filesystem::exists(d + "/ate.png")) << r.out;
  EXPECT_GT(std::filesystem::file_size(d + "/ate.png"), 10000u);
  EXPECT_EQ(dslam::test::readFile(d + "/ate.png").substr(1, 3), "PNG");
  const std::string csv = dslam::test::readFile(d + "/ate.csv");
  EXPECT_EQ(csv.rfind("t,gt_x,gt_y,gt_z,est_x,est_y,est_z,error\n", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 787);  // header + 786 pairs

  const auto p = runDslam("eval rpe " + q(goldenGt()) + " " + q(goldenEst()) + " --delta 0.5 --delta-unit s --plot " +
                          q(d + "/rpe.png"));
  ASSERT_EQ(p.exit_code, 0) << p.out;
  EXPECT_GT(std::filesystem::file_size(d + "/rpe.png"), 10000u);
}

TEST(EvalCli, PlotWithoutMatplotlibStillWritesCsv) {
  const std::string d = tempDir("evalplot");
  const auto r = dslam::test::run("DSLAM_PYTHON=/nonexistent/python3 '" + dslam::test::dslamExe() + "' eval ate " +
                                  q(goldenGt()) + " " + q(goldenEst()) + " --plot " + q(d + "/ate.png"));
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("apt-get install python3-matplotlib"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("rmse   0.0134735 m"), std::string::npos) << r.out;  // results printed first
  EXPECT_FALSE(std::filesystem::exists(d + "/ate.png"));
  const std::string csv = dslam::test::readFile(d + "/ate.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 787);
}
