#pragma once
/** \file timing.h
 *  Per-stage, per-frame timing. StageTimer keeps every sample (for medians)
 *  and mirrors them into an mrpt::system::CTimeLogger (kept out of this
 *  header). */
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace dslam {

double nowSeconds();  ///< monotonic clock, seconds

struct StageStats {
  size_t count = 0;
  double mean_ms = 0, median_ms = 0, min_ms = 0, max_ms = 0, total_ms = 0;
};

class StageTimer {
 public:
  StageTimer();
  ~StageTimer();
  /** Records `ms` for `stage` in frame `frame`. Thread safe. */
  void add(const std::string& stage, int frame, double ms);
  StageStats stats(const std::string& stage) const;
  std::vector<std::string> stages() const;  ///< in order of first use
  /** CSV: frame,<stage1>,<stage2>,... (ms; empty cell if the stage did not run). */
  void writeCsv(const std::string& path) const;
  /** CTimeLogger summary CSV (MRPT format). */
  void writeMrptCsv(const std::string& path) const;
  std::string summary() const;  ///< one line per stage: median/mean/max ms

  /** RAII timing of a block: `{ auto t = timer.scope("orb", i); ... }`, or
   *  `StageTimer::Scope t(timer_ptr, "local_ba", i);` with a timer that may be
   *  null (then nothing is recorded). Records when the block is left, also by
   *  an exception. */
  class Scope {
   public:
    Scope(StageTimer* t, std::string stage, int frame)
        : t_(t), stage_(std::move(stage)), frame_(frame), t0_(nowSeconds()) {}
    Scope(StageTimer& t, std::string stage, int frame) : Scope(&t, std::move(stage), frame) {}
    ~Scope() {
      if (t_) t_->add(stage_, frame_, (nowSeconds() - t0_) * 1e3);
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageTimer* t_;
    std::string stage_;
    int frame_;
    double t0_;
  };
  Scope scope(const std::string& stage, int frame) { return Scope(*this, stage, frame); }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/** Median of a vector (copy; 0 for empty). */
double median(std::vector<double> v);

}  // namespace dslam
