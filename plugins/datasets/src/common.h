#pragma once
/** \file common.h
 *  Helpers shared by the dataset readers (internal to plugins/datasets). */
#include <opencv2/core.hpp>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "dslam/core/se3.h"
#include "dslam/core/text_lines.h"
#include "dslam/core/trajectory.h"

namespace dslam::ds {

/** Max |t_frame - t_gt| when attaching a ground-truth pose to a frame
 *  (the TUM benchmark's association threshold). */
constexpr double kGtMaxDt = 0.02;

/** cv::imread with a DataError naming the frame, what and the path, and
 *  whether the file is missing or unreadable. */
cv::Mat readImage(const std::string& path, size_t frame, const std::string& what, int flags);
/** readImage(path, frame, what, cv::IMREAD_UNCHANGED) of a camera image:
 *  8-bit grey, colour or colour + alpha (a 16-bit image is a DataError). */
cv::Mat readCameraImage(const std::string& path, size_t frame, const std::string& what);
/** readImage of a depth image: 16-bit single channel (anything else, e.g. a
 *  3-channel 16-bit PNG, is a DataError). */
cv::Mat readDepthImage(const std::string& path, size_t frame);

/** Ground-truth pose nearest to t if within max_dt (gt stamps sorted). */
std::optional<SE3> nearestPose(const Trajectory& gt, double t, double max_dt = kGtMaxDt);

/** What a list reader did to make its lines usable, as TUM's tools do. */
struct OrderFix {
  size_t repeated = 0;   ///< lines whose timestamp an earlier line had (the last line of each time kept)
  size_t reordered = 0;  ///< lines earlier in time than a line before them (sorted)
  size_t skipped = 0;    ///< lines without a file name (associate.py skips them)
};

/** Orders list entries as TUM's associate.py sees them (it reads a list into
 *  a dict keyed by time and sorts the keys): sorted by `key(e)`, of equal
 *  keys the last in file order kept. Returns what changed; `reportOrderFix`
 *  says it in one warning. */
template <class E, class Key>
OrderFix sortKeepLast(std::vector<E>& v, Key key) {
  OrderFix fix;
  bool sorted = true;
  for (size_t i = 1; i < v.size(); i++) {
    if (!(key(v[i]) > key(v[i - 1]))) sorted = false;
  }
  if (sorted) return fix;
  auto latest = key(v.front());
  for (size_t i = 1; i < v.size(); i++) {
    if (key(v[i]) < latest) fix.reordered++;
    if (key(v[i]) > latest) latest = key(v[i]);
  }
  std::stable_sort(v.begin(), v.end(), [&](const E& a, const E& b) { return key(a) < key(b); });
  std::vector<E> out;
  out.reserve(v.size());
  for (size_t k = 0; k < v.size(); k++) {
    if (k + 1 < v.size() && key(v[k + 1]) == key(v[k])) {
      fix.repeated++;
      continue;
    }
    out.push_back(std::move(v[k]));
  }
  v = std::move(out);
  return fix;
}

/** One warning "<file>: N repeated timestamp(s) ..., M out-of-order ..., K
 *  line(s) without a file skipped, as the TUM benchmark tools do"; nothing
 *  if nothing changed. */
void reportOrderFix(const std::string& file, const OrderFix& fix);

/** Throws DataError("frame index i out of range (n frames)") unless i < n. */
void requireFrameIndex(size_t i, size_t n);

/** Throws DataError("<where>: timestamps must increase ...") unless strictly increasing. */
void requireIncreasing(const std::vector<double>& stamps, const std::string& where);



/** Files with extension `ext` (".png") in a folder, sorted by name. */
std::vector<std::string> listFiles(const std::string& dir, const std::string& ext);

/** "%.6f" */
std::string fmtStamp(double t);

}  // namespace dslam::ds
