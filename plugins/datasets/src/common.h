#pragma once
/** \file common.h
 *  Helpers shared by the dataset readers (internal to plugins/datasets). */
#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "dslam/core/se3.h"
#include "dslam/core/trajectory.h"

namespace dslam::ds {

/** Max |t_frame - t_gt| when attaching a ground-truth pose to a frame
 *  (the TUM benchmark's association threshold). */
constexpr double kGtMaxDt = 0.02;

/** cv::imread with a DataError naming the frame, what and the path, and
 *  whether the file is missing or unreadable. */
cv::Mat readImage(const std::string& path, size_t frame, const std::string& what, int flags);

/** Ground-truth pose nearest to t if within max_dt (gt stamps sorted). */
std::optional<SE3> nearestPose(const Trajectory& gt, double t, double max_dt = kGtMaxDt);

/** Throws DataError("<where>: timestamps must increase ...") unless strictly increasing. */
void requireIncreasing(const std::vector<double>& stamps, const std::string& where);

/** Lines of a text file without '\r', with their 1-based numbers; skips
 *  blank lines and '#' comments. Throws DataError if it cannot be opened. */
struct TextLine {
  int lineno;
  std::string text;
};
std::vector<TextLine> readDataLines(const std::string& file, const std::string& hint = "");

/** Splits on spaces, tabs and (if `commas`) commas; drops empty fields. */
std::vector<std::string> splitFields(const std::string& s, bool commas = false);

/** Files with extension `ext` (".png") in a folder, sorted by name. */
std::vector<std::string> listFiles(const std::string& dir, const std::string& ext);

/** "%.6f" */
std::string fmtStamp(double t);

}  // namespace dslam::ds
