// `dslam run` outputs under stress: SIGINT / SIGTERM mid-run finish every
// output for the frames processed; SIGKILL leaves a trajectory that `dslam
// eval` reads; events.jsonl stays valid JSON whatever an error message holds.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "dslam/trajectory/io.h"
#include "synth_cache.h"
#include "test_support.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

size_t countLines(const std::string& path) {
  std::ifstream f(path);
  size_t n = 0;
  std::string l;
  while (std::getline(f, l)) n++;
  return n;
}

/** Starts `dslam run` in the background (output to log). */
pid_t spawnRun(const std::string& pipeline, const std::string& dataset, const std::string& out,
               const std::string& log) {
  return test::spawnLogged({test::dslamExe(), "run", pipeline, "--dataset", dataset, "--out", out, "--no-progress"},
                           log);
}

/** Waits until `file` has at least `lines` lines (false after 120 s or if the
 *  process ended first). */
bool waitForLines(pid_t pid, const std::string& file, size_t lines) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(120)) {
    if (countLines(file) >= lines) return true;
    int st = 0;
    if (waitpid(pid, &st, WNOHANG) == pid) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

int waitExit(pid_t pid) {
  int st = 0;
  waitpid(pid, &st, 0);
  if (WIFEXITED(st)) return WEXITSTATUS(st);
  if (WIFSIGNALED(st)) return 128 + WTERMSIG(st);
  return -1;
}

const int kFrames = 300;

std::string scene() { return test::syntheticSequence("static_office", kFrames, 640, 480); }

}  // namespace

class InterruptedRun : public testing::TestWithParam<int> {};

TEST_P(InterruptedRun, StopSignalWritesEveryOutputForTheFramesProcessed) {
  const int sig = GetParam();
  const std::string out = test::tempDir("interrupt") + "/run";
  const pid_t pid = spawnRun(test::source("config/pipelines/orbslam_baseline.yaml"), scene(), out, out + ".log");
  ASSERT_TRUE(waitForLines(pid, out + "/frames.csv", 60)) << test::readFile(out + ".log");
  kill(pid, sig);
  EXPECT_EQ(waitExit(pid), 128 + sig) << test::readFile(out + ".log");

  const auto sum = nlohmann::json::parse(test::readFile(out + "/summary.json"));
  EXPECT_EQ(sum.at("finished"), false);
  EXPECT_EQ(sum.at("stopped_by"), sig == SIGINT ? "SIGINT" : "SIGTERM");
  const size_t frames = sum.at("frames").get<size_t>();
  EXPECT_GE(frames, 59u);
  EXPECT_LT(frames, static_cast<size_t>(kFrames));
  EXPECT_EQ(countLines(out + "/frames.csv"), frames + 1);  // header + one line per frame
  // The final, keyframe-corrected trajectory replaced the incremental one.
  const std::string traj_text = test::readFile(out + "/trajectory.txt");
  EXPECT_NE(traj_text.find("run stopped early"), std::string::npos);
  EXPECT_EQ(traj_text.find("RUN NOT FINISHED"), std::string::npos);
  const Trajectory t = traj::read(out + "/trajectory.txt");
  EXPECT_EQ(t.size(), sum.at("tracked").get<size_t>());
  EXPECT_TRUE(fs::exists(out + "/map.ply"));
  EXPECT_LT(sum.at("ate_rmse").get<double>(), 0.01);
  for (const auto& e : fs::directory_iterator(out))  // no temporary file left behind
    EXPECT_EQ(e.path().string().find(".tmp."), std::string::npos) << e.path();
}

INSTANTIATE_TEST_SUITE_P(Signals, InterruptedRun, testing::Values(SIGINT, SIGTERM),
                         [](const testing::TestParamInfo<int>& i) { return i.param == SIGINT ? "Sigint" : "Sigterm"; });

TEST(KilledRun, LeavesATrajectoryThatEvalReads) {
  const std::string out = test::tempDir("killed") + "/run";
  const pid_t pid = spawnRun(test::source("config/pipelines/orbslam_baseline.yaml"), scene(), out, out + ".log");
  ASSERT_TRUE(waitForLines(pid, out + "/frames.csv", 80)) << test::readFile(out + ".log");
  kill(pid, SIGKILL);
  EXPECT_EQ(waitExit(pid), 128 + SIGKILL);
  EXPECT_FALSE(fs::exists(out + "/summary.json"));  // never a summary of an unfinished run
  const std::string text = test::readFile(out + "/trajectory.txt");
  EXPECT_NE(text.find("RUN NOT FINISHED"), std::string::npos);
  const Trajectory t = traj::read(out + "/trajectory.txt");
  EXPECT_GE(t.size(), 75u);
  const auto r = test::runDslam("eval ate '" + scene() + "/groundtruth.txt' '" + out + "/trajectory.txt' --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  EXPECT_GE(j.at("pairs").get<int>(), 75);
  EXPECT_LT(j.at("rmse").get<double>(), 0.01);
}

TEST(RunEvents, ErrorMessagesWithControlCharactersStayValidJson) {
  // A dataset folder whose name holds a tab and a quote: the skipped frame's
  // error names the missing file, and events.jsonl must still parse (the old
  // hand-written escaper only handled " \ and newline).
  const std::string d = test::tempDir("events") + "/data\tset \"x\"";
  fs::create_directories(d + "/rgb");
  fs::create_directories(d + "/depth");
  const std::string src = scene();
  for (const char* f : {"rgb.txt", "depth.txt", "groundtruth.txt", "camera.yaml"}) fs::copy_file(src + "/" + f, d + "/" + f);
  std::ifstream rgb(src + "/rgb.txt"), depth(src + "/depth.txt");
  std::string l;
  int n = 0;
  while (std::getline(rgb, l) && n < 40) {
    if (l.empty() || l[0] == '#') continue;
    const std::string name = l.substr(l.find(' ') + 1);
    if (n != 20) fs::create_symlink(src + "/" + name, d + "/" + name);  // frame 20 is missing
    n++;
  }
  while (std::getline(depth, l)) {
    if (l.empty() || l[0] == '#') continue;
    const std::string name = l.substr(l.find(' ') + 1);
    if (fs::exists(src + "/" + name)) fs::create_symlink(src + "/" + name, d + "/" + name);
  }
  const std::string pipe = test::tempDir("events") + "/p.yaml";
  nlohmann::json path = d;  // a JSON string literal is a valid YAML double-quoted scalar
  test::writeFile(pipe, "pipeline: {name: tab_test}\n"
                        "dataset:\n  type: dslam::TumDataset\n  on_bad_frame: skip\n  max_frames: 30\n"
                        "  params: {path: " + path.dump() + "}\n"
                        "modules: []\n");
  const std::string out = test::tempDir("events") + "/out";
  const auto r = test::runDslam("run '" + pipe + "' --out '" + out + "' --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  std::ifstream ev(out + "/events.jsonl");
  int bad = 0, lines = 0;
  while (std::getline(ev, l)) {
    lines++;
    const auto j = nlohmann::json::parse(l);  // throws (fails the test) on invalid JSON
    if (j.at("event") == "bad_frame") {
      bad++;
      EXPECT_NE(j.at("error").get<std::string>().find("data\tset \"x\""), std::string::npos) << l;
    }
  }
  EXPECT_EQ(bad, 1);
  EXPECT_GE(lines, 2);
  const auto sum = nlohmann::json::parse(test::readFile(out + "/summary.json"));
  EXPECT_EQ(sum.at("frames"), 29);
  EXPECT_EQ(sum.at("finished"), true);
}
