// `dslam ablate` end to end on a tiny study (synthetic walking_xyz, 60 frames
// at 320x240): every cell runs and the tables are written; --resume skips
// finished cells; a study killed halfway finishes on --resume without
// redoing its finished cells; cells run one by one through GNU parallel and
// --collect give the tables of a single-process run; a crashing cell is
// recorded and the others go on; a bad study file stops before anything runs.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "test_support.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

/** Scenes are rendered once per build tree and shared by the tests here. */
std::string sceneCache() { return (fs::path(DSLAM_TEST_BINARY_DIR) / "test_data" / "ablate_scenes").string(); }

std::string studyFile(const std::string& dir, bool three_variants) {
  const std::string f = dir + "/study.yaml";
  test::writeFile(f, test::cat("name: tiny\n",
                               "description: Crowd-SLAM with and without the adaptive feature count\n",
                               "bases:\n",
                               "  crowd: ", test::source("config/pipelines/synthetic/crowd_slam.yaml"), "\n",
                               "variants:\n",
                               "  no_afc: {base: crowd, overlay: [{remove: feature_count}]}\n",
                               three_variants ? "  fewer: {base: crowd, overlay: [{set: {features.n_features: 800}}]}\n" : "",
                               "datasets:\n",
                               "  wx: {scenario: ", test::source("config/scenarios/walking_xyz.yaml"),
                               ", frames: 60, resolution: 320x240, right: false}\n"));
  return f;
}

test::CmdResult ablate(const std::string& args) {
  return test::runDslam("ablate " + args + " --scene-cache '" + sceneCache() + "'");
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> v;
  std::istringstream in(text);
  std::string l;
  while (std::getline(in, l)) v.push_back(l);
  return v;
}

/** The section of results.md from `from` to the next "## " heading. */
std::string section(const std::string& md, const std::string& from) {
  const size_t a = md.find(from);
  if (a == std::string::npos) return "";
  const size_t b = md.find("\n## ", a + 1);
  return md.substr(a, b == std::string::npos ? std::string::npos : b - a);
}

/** results.csv without the columns that depend on timing (median_ms, fps,
 *  peak_mb, wall_s): what a deterministic (sequential) run reproduces. */
std::vector<std::string> deterministicCsv(const std::string& csv) {
  std::vector<std::string> out;
  for (const auto& l : lines(csv)) {
    std::vector<std::string> f;
    std::stringstream ss(l);
    std::string x;
    while (std::getline(ss, x, ',')) f.push_back(x);
    std::string keep;
    for (size_t i = 0; i < f.size() && i < 16; i++) keep += f[i] + ",";  // up to max_feature_count
    out.push_back(keep);
  }
  return out;
}

size_t doneCells(const std::string& out) {
  size_t n = 0;
  std::error_code ec;
  if (!fs::exists(out + "/cells", ec)) return 0;
  for (const auto& e : fs::directory_iterator(out + "/cells"))
    if (fs::exists(e.path() / "done")) n++;
  return n;
}

/** Starts `exe ablate study` (one job) in the background, output to `log`,
 *  and waits until its first cell is done. Its pid; -1 (after a gtest
 *  failure naming the log) if it exited before. */
pid_t startAndWaitForACell(const std::string& exe, const std::string& study, const std::string& out,
                           const std::string& log) {
  const pid_t pid =
      test::spawnLogged({exe, "ablate", study, "--out", out, "--jobs", "1", "--scene-cache", sceneCache()}, log);
  const auto t0 = std::chrono::steady_clock::now();
  int status = 0;
  while (doneCells(out) < 1 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(300)) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      ADD_FAILURE() << "the study ended before its first cell was done:\n" << test::readFile(log);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return pid;
}

/** Processes whose command line mentions `s` (the study's output folder):
 *  one line each, "pid state command line" (state from /proc/PID/stat). */
std::vector<std::string> processesMentioning(const std::string& s) {
  std::vector<std::string> found;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos || name == std::to_string(::getpid())) continue;
    std::ifstream f(e.path() / "cmdline", std::ios::binary);
    std::string c((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (c.find(s) == std::string::npos) continue;
    std::replace(c.begin(), c.end(), '\0', ' ');
    std::ifstream st(e.path() / "stat");
    std::string stat;
    std::getline(st, stat);
    const size_t paren = stat.rfind(')');
    const std::string state = paren == std::string::npos || paren + 2 >= stat.size() ? "?" : stat.substr(paren + 2, 1);
    found.push_back(name + " " + state + " " + c);
  }
  return found;
}

}  // namespace

TEST(Ablate, RunsEveryCellWritesTheTablesAndResumes) {
  const std::string dir = test::tempDir("ablate_run");
  const std::string study = studyFile(dir, true);
  const std::string out = dir + "/out";
  const auto r = ablate("'" + study + "' --out '" + out + "' --jobs 2");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("study tiny: 3 cells; running 3 with 2 jobs"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[3/3] ok"), std::string::npos) << r.out;

  // Every cell keeps its resolved config, log, run outputs and result.
  for (const char* id : {"crowd.wx.r0", "no_afc.wx.r0", "fewer.wx.r0"}) {
    const std::string c = out + "/cells/" + id;
    for (const char* f : {"done", "config.yaml", "cell.json", "log.txt", "result.json", "aligned.txt",
                          "run/summary.json", "run/trajectory.txt", "run/config.resolved.yaml"})
      EXPECT_TRUE(fs::exists(c + "/" + f)) << c << "/" << f;
    const auto res = nlohmann::json::parse(test::readFile(c + "/result.json"));
    EXPECT_EQ(res["status"], "ok") << res.dump();
    EXPECT_EQ(res["frames"], 60);
    EXPECT_GE(res["tracked"].get<int>(), 55);
    EXPECT_LT(res["ate_rmse"].get<double>(), 0.05) << id;  // the dynamic variants stay well under the baseline's error
    EXPECT_GT(res["rpe_trans_rmse"].get<double>(), 0.0);
    EXPECT_GT(res["peak_mb"].get<double>(), 20.0);  // wait4 ru_maxrss of the run
    EXPECT_LT(res["peak_mb"].get<double>(), 4000.0);
    EXPECT_GT(res["min_usable_keypoints"].get<double>(), 100.0);
    EXPECT_GE(res["max_feature_count"].get<double>(), std::string(id) == "fewer.wx.r0" ? 800.0 : 1000.0);
  }
  // The variant's config is the overlay's result.
  const std::string cfg = test::readFile(out + "/cells/no_afc.wx.r0/config.yaml");
  EXPECT_EQ(cfg.find("AdaptiveFeatureCount"), std::string::npos);
  EXPECT_NE(test::readFile(out + "/cells/crowd.wx.r0/config.yaml").find("AdaptiveFeatureCount"), std::string::npos);
  EXPECT_NE(test::readFile(out + "/cells/fewer.wx.r0/config.yaml").find("n_features: 800"), std::string::npos);

  const auto csv = lines(test::readFile(out + "/results.csv"));
  ASSERT_EQ(csv.size(), 4u);
  EXPECT_EQ(csv[1].rfind("tiny,crowd,crowd,wx,,0,crowd.wx.r0,ok,", 0), 0u) << csv[1];
  const std::string md = test::readFile(out + "/results.md");
  EXPECT_NE(md.find("| variant | reference | wx | ratio (geometric mean) |"), std::string::npos) << md;
  EXPECT_NE(md.find("| no_afc | crowd | 0.0"), std::string::npos) << md;
  EXPECT_NE(md.find("x) |"), std::string::npos) << md;  // ratios to the base
  EXPECT_NE(md.find("(commit "), std::string::npos) << md;
  const auto js = nlohmann::json::parse(test::readFile(out + "/results.json"));
  EXPECT_EQ(js["runs"].size(), 3u);
  EXPECT_EQ(js["groups"].size(), 3u);
  EXPECT_TRUE(fs::file_size(out + "/plots/ate.png") > 1000) << r.out;
  EXPECT_TRUE(fs::file_size(out + "/plots/trajectories_wx.png") > 1000) << r.out;

  // --resume: nothing runs again.
  const auto before = test::readFile(out + "/cells/crowd.wx.r0/result.json");
  struct stat st0 {};
  ::stat((out + "/cells/crowd.wx.r0/done").c_str(), &st0);
  const auto again = ablate("'" + study + "' --out '" + out + "' --resume");
  ASSERT_EQ(again.exit_code, 0) << again.out;
  EXPECT_NE(again.out.find("3 finished earlier (--resume); running 0"), std::string::npos) << again.out;
  struct stat st1 {};
  ::stat((out + "/cells/crowd.wx.r0/done").c_str(), &st1);
  EXPECT_EQ(st0.st_mtim.tv_sec, st1.st_mtim.tv_sec);
  EXPECT_EQ(st0.st_mtim.tv_nsec, st1.st_mtim.tv_nsec);
  EXPECT_EQ(test::readFile(out + "/cells/crowd.wx.r0/result.json"), before);

  // Without --resume a finished study is not silently run again.
  const auto refused = ablate("'" + study + "' --out '" + out + "'");
  EXPECT_EQ(refused.exit_code, 1) << refused.out;
  EXPECT_NE(refused.out.find("--resume"), std::string::npos) << refused.out;

  // Edited study: the changed variant is stale and runs again, the others not.
  test::writeFile(study, test::readFile(study) + "evaluation: {rpe_delta: 0.5}\n");
  const auto edited = ablate("'" + study + "' --out '" + out + "' --resume --only 'crowd.*'");
  ASSERT_EQ(edited.exit_code, 0) << edited.out;
  EXPECT_NE(edited.out.find("running 1 with 1 job"), std::string::npos) << edited.out;
}

TEST(Ablate, KilledHalfwayThenResumedFinishesWithoutRedoingCells) {
  const std::string dir = test::tempDir("ablate_kill");
  const std::string study = studyFile(dir, true);
  const std::string out = dir + "/out";
  // Render the scene first so that the study starts running cells at once.
  ASSERT_EQ(ablate("'" + study + "' --out '" + out + "' --prepare").exit_code, 0);
  // Kill it (SIGKILL: no clean-up at all) as soon as the first cell is done.
  const pid_t pid = startAndWaitForACell(test::dslamExe(), study, out, dir + "/ablate.log");
  ASSERT_GT(pid, 0);
  int status = 0;
  ::kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  const size_t done = doneCells(out);
  ASSERT_GE(done, 1u);
  ASSERT_LT(done, 3u) << "the study finished before it could be killed";
  // The running cell's `dslam run` died with the study (PR_SET_PDEATHSIG).
  // SIGKILL is delivered at once, but a loaded machine can take seconds to
  // tear a big process down (CI once saw one left after 2 s): wait up to 60 s.
  std::vector<std::string> left = processesMentioning(out);
  for (int i = 0; i < 6000 && !left.empty(); i++) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    left = processesMentioning(out);
  }
  EXPECT_TRUE(left.empty()) << "still running 60 s after the study was killed:\n" << [&] {
    std::string all;
    for (const auto& l : left) all += l + "\n";
    return all;
  }();

  std::map<std::string, std::string> finished;  // cell -> result.json
  for (const auto& e : fs::directory_iterator(out + "/cells"))
    if (fs::exists(e.path() / "done")) finished[e.path().filename().string()] = test::readFile((e.path() / "result.json").string());

  const auto r = ablate("'" + study + "' --out '" + out + "' --resume");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find(std::to_string(done) + " finished earlier (--resume); running " + std::to_string(3 - done)),
            std::string::npos)
      << r.out;
  EXPECT_EQ(doneCells(out), 3u);
  for (const auto& [cell, json] : finished)
    EXPECT_EQ(test::readFile(out + "/cells/" + cell + "/result.json"), json) << cell << " was run again";
  EXPECT_EQ(lines(test::readFile(out + "/results.csv")).size(), 4u);
}

TEST(Ablate, ExecutableReplacedMidStudyStartsNoFurtherCell) {
  // A rebuild while a study runs replaces the dslam file: the cells after it
  // would run another build (or, as before this test, fail to start with exit
  // code 127). The study starts no further cell, says why, exits 1, and
  // --resume finishes it with the new build.
  const std::string dir = test::tempDir("ablate_rebuilt");
  const std::string study = studyFile(dir, true);
  const std::string out = dir + "/out";
  ASSERT_EQ(ablate("'" + study + "' --out '" + out + "' --prepare").exit_code, 0);
  const std::string exe = dir + "/dslam";  // a copy we can replace (RUNPATH is absolute)
  fs::copy_file(test::dslamExe(), exe);
  // The new build is copied beforehand: copying it after the first cell
  // could take longer than the second cell on a loaded machine, and the
  // study would then start the third with the old file.
  fs::copy_file(test::dslamExe(), exe + ".new");
  const std::string log = dir + "/ablate.log";
  const pid_t pid = startAndWaitForACell(exe, study, out, log);
  ASSERT_GT(pid, 0);
  int status = 0;
  // Replace the file as a linker does (a new file under the old name).
  fs::rename(exe + ".new", exe);
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1) << test::readFile(log);
  const std::string text = test::readFile(log);
  EXPECT_NE(text.find("the dslam executable " + exe + " was replaced or removed while the study ran"), std::string::npos)
      << text;
  EXPECT_EQ(text.find("cannot execute"), std::string::npos) << text;
  const size_t done = doneCells(out);
  EXPECT_GE(done, 1u);
  EXPECT_LT(done, 3u) << text;
  for (const auto& e : fs::directory_iterator(out + "/cells")) {
    if (!fs::exists(e.path() / "done")) continue;
    EXPECT_EQ(nlohmann::json::parse(test::readFile((e.path() / "result.json").string()))["status"], "ok") << e.path();
  }
  const auto r = test::run(test::cat("'", exe, "' ablate '", study, "' --out '", out, "' --scene-cache '", sceneCache(),
                                     "' --resume 2>&1"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(doneCells(out), 3u);
}

TEST(Ablate, CellsThroughGnuParallelGiveTheTablesOfASingleProcessRun) {
  ASSERT_EQ(test::run("parallel --version > /dev/null 2>&1").exit_code, 0)
      << "GNU parallel is missing: scripts/install_deps.sh installs it (Debian package parallel)";
  const std::string dir = test::tempDir("ablate_parallel");
  const std::string study = studyFile(dir, false);
  const std::string single = dir + "/single", par = dir + "/parallel";
  const auto s = ablate("'" + study + "' --out '" + single + "'");
  ASSERT_EQ(s.exit_code, 0) << s.out;

  const auto plan = test::run(test::cat("('", test::dslamExe(), "' ablate '", study, "' --plan 2>/dev/null)"));
  ASSERT_EQ(plan.exit_code, 0) << plan.out;
  EXPECT_EQ(plan.out, "crowd.wx.r0\nno_afc.wx.r0\n");
  const auto p = test::run(test::cat("'", test::dslamExe(), "' ablate '", study, "' --plan 2>/dev/null | parallel --will-cite -j 2 '",
                                     test::dslamExe(), "' ablate '", study, "' --out '", par, "' --scene-cache '", sceneCache(),
                                     "' --cell {}"));
  ASSERT_EQ(p.exit_code, 0) << p.out;
  EXPECT_EQ(doneCells(par), 2u);
  EXPECT_FALSE(fs::exists(par + "/results.md"));  // cells do not aggregate
  const auto c = ablate("'" + study + "' --out '" + par + "' --collect");
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_NE(c.out.find("collected 2 of 2 cells"), std::string::npos) << c.out;

  const std::string md1 = test::readFile(single + "/results.md"), md2 = test::readFile(par + "/results.md");
  ASSERT_FALSE(section(md1, "## ATE RMSE").empty()) << md1;
  EXPECT_EQ(section(md1, "## ATE RMSE"), section(md2, "## ATE RMSE"));
  EXPECT_EQ(md1.substr(0, md1.find("\n## ")), md2.substr(0, md2.find("\n## ")));  // title and provenance
  EXPECT_EQ(deterministicCsv(test::readFile(single + "/results.csv")), deterministicCsv(test::readFile(par + "/results.csv")));

  // A cell by its index (sbatch --array): finished, so --resume skips it.
  const auto idx = ablate("'" + study + "' --out '" + par + "' --cell-index 1 --resume");
  ASSERT_EQ(idx.exit_code, 0) << idx.out;
  EXPECT_NE(idx.out.find("no_afc.wx.r0: finished earlier (--resume), skipped"), std::string::npos) << idx.out;
  EXPECT_EQ(ablate("'" + study + "' --out '" + par + "' --cell-index 2").exit_code, 1);
  EXPECT_EQ(ablate("'" + study + "' --out '" + par + "' --cell nope.wx.r0").exit_code, 1);
}

TEST(Ablate, ACrashingCellIsRecordedAndTheOthersGoOn) {
  const std::string dir = test::tempDir("ablate_crash");
  const std::string study = studyFile(dir, true);
  const std::string out = dir + "/out";
  // A dslam that crashes (SIGSEGV) when it runs the no_afc variant.
  const std::string wrapper = dir + "/crashing_dslam.sh";
  test::writeFile(wrapper, test::cat("#!/bin/sh\ncase \"$2\" in *no_afc*) kill -SEGV $$ ;; esac\nexec '",
                                     test::dslamExe(), "' \"$@\"\n"));
  fs::permissions(wrapper, fs::perms::owner_all);
  const auto r = ablate("'" + study + "' --out '" + out + "' --jobs 2 --dslam '" + wrapper + "'");
  EXPECT_EQ(r.exit_code, 1) << r.out;  // some cell failed
  EXPECT_NE(r.out.find("FAILED  no_afc.wx.r0  dslam run killed by signal 11"), std::string::npos) << r.out;
  EXPECT_EQ(doneCells(out), 3u);
  const auto res = nlohmann::json::parse(test::readFile(out + "/cells/no_afc.wx.r0/result.json"));
  EXPECT_EQ(res["status"], "failed");
  EXPECT_EQ(res["exit_code"], 128 + SIGSEGV);
  EXPECT_EQ(nlohmann::json::parse(test::readFile(out + "/cells/crowd.wx.r0/result.json"))["status"], "ok");
  EXPECT_EQ(nlohmann::json::parse(test::readFile(out + "/cells/fewer.wx.r0/result.json"))["status"], "ok");
  const std::string md = test::readFile(out + "/results.md");
  EXPECT_NE(md.find("## Failed runs"), std::string::npos) << md;
  EXPECT_NE(md.find("| no_afc | crowd | failed |"), std::string::npos) << md;
  // --resume runs the failed cell again (and only it).
  const auto again = ablate("'" + study + "' --out '" + out + "' --resume");
  EXPECT_EQ(again.exit_code, 0) << again.out;
  EXPECT_NE(again.out.find("2 finished earlier (--resume); running 1"), std::string::npos) << again.out;
}

TEST(Ablate, BadStudyFileStopsBeforeAnythingRuns) {
  const std::string dir = test::tempDir("ablate_bad");
  const std::string out = dir + "/out";
  struct Case {
    std::string text, want;
  };
  const std::string base = test::source("config/pipelines/synthetic/crowd_slam.yaml");
  const std::string scen = test::source("config/scenarios/walking_xyz.yaml");
  const std::vector<Case> cases = {
      {test::cat("bases: {crowd: ", base, "}\nvariants:\n  v: {base: crowd, overlay: [{remove: feature_cnt}]}\n",
                 "datasets: {wx: ", scen, "}\n"),
       "study.yaml:3: 'variants.v.overlay[0].remove': no module 'feature_cnt', did you mean 'feature_count'?"},
      {test::cat("bases: {crowd: ", base, "}\ndatasets:\n  tum: ", dir, "/no/such/folder\n"),
       "study.yaml:3: 'datasets.tum': dataset not found: " + dir + "/no/such/folder"},
      {test::cat("bases: {crowd: ", base, "}\ndatasets: {wx: ", scen, "}\njobs: 3\n"), "study.yaml:3: 'jobs': unknown key 'jobs'"},
  };
  for (const auto& c : cases) {
    test::writeFile(dir + "/study.yaml", c.text);
    const auto r = ablate("'" + dir + "/study.yaml' --out '" + out + "'");
    EXPECT_EQ(r.exit_code, 1) << r.out;
    EXPECT_NE(r.out.find(c.want), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(out)) << "something ran for:\n" << c.text;
  }
}

TEST(Ablate, PrepareRendersTheDatasetsOfTheSelectedCellsOnly) {
  const std::string dir = test::tempDir("ablate_prepare");
  const std::string scen = test::source("config/scenarios/walking_xyz.yaml");
  test::writeFile(dir + "/study.yaml",
                  test::cat("bases: {crowd: ", test::source("config/pipelines/synthetic/crowd_slam.yaml"), "}\n",
                            "datasets:\n",
                            "  a: {scenario: ", scen, ", frames: 5, resolution: 160x120, right: false}\n",
                            "  b: {scenario: ", scen, ", frames: 6, resolution: 160x120, right: false}\n"));
  const std::string cache = dir + "/cache";
  auto prepare = [&](const std::string& only) {
    return test::runDslam("ablate '" + dir + "/study.yaml' --out '" + dir + "/out' --scene-cache '" + cache +
                          "' --prepare" + only);
  };
  const auto one = prepare(" --only 'crowd.b.*'");
  ASSERT_EQ(one.exit_code, 0) << one.out;
  EXPECT_EQ(one.out.find("a: "), std::string::npos) << one.out;
  EXPECT_NE(one.out.find("b: " + cache), std::string::npos) << one.out;
  EXPECT_EQ(std::distance(fs::directory_iterator(cache), fs::directory_iterator{}), 1) << one.out;
  const auto all = prepare("");
  ASSERT_EQ(all.exit_code, 0) << all.out;
  EXPECT_NE(all.out.find("a: " + cache), std::string::npos) << all.out;
  EXPECT_EQ(std::distance(fs::directory_iterator(cache), fs::directory_iterator{}), 2) << all.out;
}
