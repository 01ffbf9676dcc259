#include "test_support.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <vector>

#include "dslam/core/paths.h"

namespace fs = std::filesystem;

namespace dslam::test {

std::string shared(const std::string& rel) {
  const std::string p = (fs::path(sharedDir()) / rel).string();
  if (fs::exists(p)) return p;
  const char* allow = std::getenv("DSLAM_ALLOW_MISSING_SHARED");
  if (allow && std::string(allow) == "1") {
    std::cerr << "[skip] shared data missing: " << p << "\n";
    return "";
  }
  ADD_FAILURE() << "shared data missing: " << p
                << " (set DSLAM_SHARED_DIR; DSLAM_ALLOW_MISSING_SHARED=1 skips such tests)";
  return "";
}

std::string source(const std::string& rel) {
  const char* e = std::getenv("DSLAM_SOURCE_DIR");
  return (fs::path(e && *e ? e : DSLAM_TEST_SOURCE_DIR) / rel).string();
}

namespace {
struct TempDirs {
  std::mutex m;
  std::vector<std::string> dirs;
  ~TempDirs() {
    if (std::getenv("DSLAM_KEEP_TEST_DIRS")) return;
    for (auto& d : dirs) {
      std::error_code ec;
      fs::remove_all(d, ec);
    }
  }
} g_temp;
}  // namespace

std::string tempDir(const std::string& tag) {
  std::string tmpl = (fs::temp_directory_path() / ("dslam_" + tag + "_XXXXXX")).string();
  std::vector<char> buf(tmpl.begin(), tmpl.end());
  buf.push_back('\0');
  if (!mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed for " + tmpl);
  std::lock_guard<std::mutex> lk(g_temp.m);
  g_temp.dirs.emplace_back(buf.data());
  return g_temp.dirs.back();
}

std::string dslamExe() {
  const char* e = std::getenv("DSLAM_EXE");
  if (e && *e) return e;
  return DSLAM_TEST_EXE_PATH;
}

CmdResult run(const std::string& cmdline) {
  CmdResult r;
  FILE* p = popen((cmdline + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

CmdResult runDslam(const std::string& args) { return run("\"" + dslamExe() + "\" " + args); }

int spawnLogged(std::vector<std::string> args, const std::string& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
    }
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

std::string readFile(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void writeFile(const std::string& path, const std::string& content) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream f(path);
  f << content;
}

void writeKittiTimes(const std::string& path, const std::vector<double>& stamps, int decimals) {
  std::string times;
  char buf[64];
  for (double t : stamps) {
    std::snprintf(buf, sizeof(buf), "%.*f\n", decimals, t);
    times += buf;
  }
  writeFile(path, times);
}

}  // namespace dslam::test
