#include "common.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/png.h"

namespace fs = std::filesystem;

namespace dslam::ds {

cv::Mat readImage(const std::string& path, size_t frame, const std::string& what, int flags) {
  cv::Mat m;
  std::string damage;
  if (fileExists(path)) {
    try {
      m = readImageFile(path, flags, &damage);  // PNG through the fast decoder (dslam/core/png.h)
    } catch (const cv::Exception& e) {
      // e.what() is several lines ("OpenCV(4.6.0) file:line: error: ..."); the condition and function are enough.
      throw DataError("frame " + std::to_string(frame) + ": cannot read " + what + " " + path + " (OpenCV: " + e.err +
                      (e.func.empty() ? "" : " in " + e.func) + ")");
    }
    if (m.empty())
      throw DataError("frame " + std::to_string(frame) + ": cannot read " + what + " " + path +
                      " (" + unreadableImageReason(damage) + ")");
    return m;
  }
  throw DataError("frame " + std::to_string(frame) + ": " + what + " " + path + " is missing");
}

cv::Mat readCameraImage(const std::string& path, size_t frame, const std::string& what) {
  cv::Mat m = readImage(path, frame, what, cv::IMREAD_UNCHANGED);
  if (m.depth() != CV_8U)
    throw DataError("frame " + std::to_string(frame) + ": " + what + " " + path + " is " +
                    (m.depth() == CV_16U ? "16" : "not 8") + "-bit; camera images must be 8-bit grey or colour");
  return m;
}

cv::Mat readDepthImage(const std::string& path, size_t frame) {
  cv::Mat m = readImage(path, frame, "depth image", cv::IMREAD_UNCHANGED);
  if (m.type() != CV_16UC1)
    throw DataError("frame " + std::to_string(frame) + ": depth image " + path + " is not 16-bit single channel");
  return m;
}

std::optional<SE3> nearestPose(const Trajectory& gt, double t, double max_dt) {
  if (gt.empty()) return std::nullopt;
  auto it = std::lower_bound(gt.stamps.begin(), gt.stamps.end(), t);
  size_t best = gt.size();
  double bd = max_dt;
  for (auto c : {it, it == gt.stamps.begin() ? it : it - 1}) {
    if (c == gt.stamps.end()) continue;
    const double d = std::abs(*c - t);
    if (d < bd) {
      bd = d;
      best = static_cast<size_t>(c - gt.stamps.begin());
    }
  }
  if (best == gt.size()) return std::nullopt;
  return gt.poses[best];
}

void reportOrderFix(const std::string& file, const OrderFix& fix) {
  if (!fix.repeated && !fix.reordered && !fix.skipped) return;
  DSLAM_LOG(Warn, file << ": " << fix.repeated << " repeated timestamp(s) (the last line of each kept), "
                       << fix.reordered << " out-of-order line(s) (sorted by time), " << fix.skipped
                       << " line(s) without a file name skipped, as the TUM benchmark tools do");
}

void requireFrameIndex(size_t i, size_t n) {
  if (i >= n)
    throw DataError("frame index " + std::to_string(i) + " out of range (" + std::to_string(n) + " frames)");
}

void requireIncreasing(const std::vector<double>& s, const std::string& where) {
  for (size_t i = 1; i < s.size(); i++)
    if (!(s[i] > s[i - 1]))
      throw DataError(where + ": timestamps must increase, but frame " + std::to_string(i) + " has " + fmtStamp(s[i]) +
                      " after " + fmtStamp(s[i - 1]) + " (frame " + std::to_string(i - 1) + ")");
}

std::vector<std::string> listFiles(const std::string& dir, const std::string& ext) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ext) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::string fmtStamp(double t) { return formatNumber("%.6f", t); }

}  // namespace dslam::ds
