#include "dslam/core/log.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <mutex>

#include "dslam/core/error.h"
#include "dslam/core/timing.h"

namespace dslam::log {
namespace {
std::atomic<int> g_level{[] {
  if (const char* e = std::getenv("DSLAM_LOG_LEVEL"); e && *e) {
    try {
      return static_cast<int>(levelFromString(e));
    } catch (...) {
    }
  }
  return static_cast<int>(Level::Info);
}()};
std::mutex g_mtx;
const char* tag(Level l) {
  switch (l) {
    case Level::Error: return "[error] ";
    case Level::Warn: return "[warn]  ";
    case Level::Info: return "[info]  ";
    case Level::Debug: return "[debug] ";
    case Level::Trace: return "[trace] ";
  }
  return "";
}
}  // namespace

Level level() { return static_cast<Level>(g_level.load()); }
void setLevel(Level l) { g_level = static_cast<int>(l); }

Level levelFromString(const std::string& s) {
  if (s == "error") return Level::Error;
  if (s == "warn" || s == "warning") return Level::Warn;
  if (s == "info") return Level::Info;
  if (s == "debug") return Level::Debug;
  if (s == "trace") return Level::Trace;
  throw ConfigError("unknown log level '" + s + "' (valid: error, warn, info, debug, trace)");
}

void write(Level l, const std::string& msg) {
  std::lock_guard<std::mutex> lk(g_mtx);
  std::cerr << tag(l) << msg << "\n";
}

Progress::Progress(std::string label, size_t total, size_t every)
    : label_(std::move(label)), total_(total), every_(every ? every : 1), t0_(nowSeconds()),
      tty_(isatty(STDERR_FILENO)) {}

void Progress::update(size_t done, const std::string& extra) {
  if (!enabled(Level::Info)) return;
  if (!tty_ && done != total_ && done - last_ < every_ && done != 1) return;
  last_ = done;
  const double dt = nowSeconds() - t0_;
  const double fps = dt > 0 ? done / dt : 0;
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s %zu/%zu (%.1f fps)", label_.c_str(), done, total_, fps);
  std::lock_guard<std::mutex> lk(g_mtx);
  if (tty_)
    std::cerr << "\r" << buf << (extra.empty() ? "" : " " + extra) << "\033[K" << std::flush;
  else
    std::cerr << buf << (extra.empty() ? "" : " " + extra) << "\n";
}

void Progress::finish(const std::string& extra) {
  if (!enabled(Level::Info)) return;
  const double dt = nowSeconds() - t0_;
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s done: %zu frames in %.2f s (%.1f fps)", label_.c_str(), total_, dt,
                dt > 0 ? total_ / dt : 0.0);
  std::lock_guard<std::mutex> lk(g_mtx);
  std::cerr << (tty_ ? "\r" : "") << buf << (extra.empty() ? "" : " " + extra) << (tty_ ? "\033[K\n" : "\n");
}

}  // namespace dslam::log
