#include "dslam/core/timing.h"

#include "dslam/core/atomic_file.h"

#include <mrpt/system/CTimeLogger.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "dslam/core/error.h"

namespace dslam {

double nowSeconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t n = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + n, v.end());
  if (v.size() % 2) return v[n];
  const double hi = v[n];
  return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + n));
}

struct StageTimer::Impl {
  mutable std::mutex mtx;
  std::vector<std::string> order;
  std::map<std::string, std::vector<std::pair<int, double>>> samples;
  mrpt::system::CTimeLogger tl{true, "dslam"};
};

StageTimer::StageTimer() : impl_(std::make_unique<Impl>()) {}
StageTimer::~StageTimer() {
  if (impl_) impl_->tl.clear(true);  // CTimeLogger dumps its report to stdout unless empty
}

void StageTimer::add(const std::string& stage, int frame, double ms) {
  std::lock_guard<std::mutex> lk(impl_->mtx);
  auto& v = impl_->samples[stage];
  if (v.empty()) impl_->order.push_back(stage);
  v.emplace_back(frame, ms);
  impl_->tl.registerUserMeasure(stage.c_str(), ms * 1e-3);
}

StageStats StageTimer::stats(const std::string& stage) const {
  std::lock_guard<std::mutex> lk(impl_->mtx);
  StageStats s;
  auto it = impl_->samples.find(stage);
  if (it == impl_->samples.end() || it->second.empty()) return s;
  std::vector<double> v;
  for (auto& [f, ms] : it->second) v.push_back(ms);
  s.count = v.size();
  for (double x : v) s.total_ms += x;
  s.mean_ms = s.total_ms / v.size();
  s.min_ms = *std::min_element(v.begin(), v.end());
  s.max_ms = *std::max_element(v.begin(), v.end());
  s.median_ms = median(v);
  return s;
}

std::vector<std::string> StageTimer::stages() const {
  std::lock_guard<std::mutex> lk(impl_->mtx);
  return impl_->order;
}

void StageTimer::writeCsv(const std::string& path) const {
  std::lock_guard<std::mutex> lk(impl_->mtx);
  AtomicOfstream out(path);
  std::ofstream& f = out.stream();
  // frame -> stage -> summed ms (a stage may run several times per frame)
  std::map<int, std::map<std::string, double>> rows;
  for (auto& [stage, v] : impl_->samples)
    for (auto& [fr, ms] : v) rows[fr][stage] += ms;
  f << "frame";
  for (auto& s : impl_->order) f << "," << s << "_ms";
  f << "\n";
  char buf[64];
  for (auto& [fr, m] : rows) {
    f << fr;
    for (auto& s : impl_->order) {
      f << ",";
      if (auto it = m.find(s); it != m.end()) {
        std::snprintf(buf, sizeof(buf), "%.4f", it->second);
        f << buf;
      }
    }
    f << "\n";
  }
  out.commit();
}

void StageTimer::writeMrptCsv(const std::string& path) const {
  std::lock_guard<std::mutex> lk(impl_->mtx);
  impl_->tl.saveToCSVFile(path);
}

std::string StageTimer::summary() const {
  std::ostringstream o;
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%-22s %8s %10s %10s %10s\n", "stage", "count", "median_ms", "mean_ms",
                "max_ms");
  o << buf;
  for (const auto& s : stages()) {
    const StageStats st = stats(s);
    std::snprintf(buf, sizeof(buf), "%-22s %8zu %10.3f %10.3f %10.3f\n", s.c_str(), st.count, st.median_ms,
                  st.mean_ms, st.max_ms);
    o << buf;
  }
  return o.str();
}

}  // namespace dslam
