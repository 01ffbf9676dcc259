#pragma once
/** \file log.h
 *  Levelled logging to stderr: `DSLAM_LOG(Info, "x=" << x);`. The level is
 *  set by `dslam -v` (once: debug, twice: trace) or $DSLAM_LOG_LEVEL. */
#include <sstream>
#include <string>

namespace dslam::log {

enum class Level { Error = 0, Warn = 1, Info = 2, Debug = 3, Trace = 4 };

Level level();
void setLevel(Level l);
Level levelFromString(const std::string& s);  ///< "error"|"warn"|"info"|"debug"|"trace"
inline bool enabled(Level l) { return static_cast<int>(l) <= static_cast<int>(level()); }
void write(Level l, const std::string& msg);

/** Single-line progress display on stderr (frame i/N, fps), rewritten in
 *  place on a terminal, printed every `every` calls otherwise. */
class Progress {
 public:
  Progress(std::string label, size_t total, size_t every = 50);
  void update(size_t done, const std::string& extra = "");
  void finish(const std::string& extra = "");

 private:
  std::string label_;
  size_t total_, every_;
  double t0_;
  bool tty_;
  size_t last_ = 0;
};

}  // namespace dslam::log

#define DSLAM_LOG(LEVEL, EXPR)                                             \
  do {                                                                     \
    if (::dslam::log::enabled(::dslam::log::Level::LEVEL)) {               \
      std::ostringstream dslam_log_oss_;                                   \
      dslam_log_oss_ << EXPR;                                              \
      ::dslam::log::write(::dslam::log::Level::LEVEL, dslam_log_oss_.str()); \
    }                                                                      \
  } while (0)
