#pragma once
/** \file io.h
 *  Trajectory files: TUM (`t tx ty tz qx qy qz qw`), KITTI (3x4 row-major
 *  per line; optional times file, or 13 columns with the time first) and
 *  EuRoC CSV (`t[ns], px, py, pz, qw, qx, qy, qz, ...`).
 *
 *  Files are read as the public tools read them (TUM's evaluate_ate.py and
 *  associate.py, evo): '#' starts a comment anywhere on a line, fields are
 *  separated by blanks, tabs or commas, CRLF line ends and trailing blanks are
 *  fine, columns after the ones a format needs are ignored, numbers may use
 *  scientific notation. Timestamps follow TUM's semantics (the tools read a
 *  file into a dict keyed by time): lines are ordered by time, and of lines
 *  with the same timestamp the last one counts; one warning says when a file
 *  needed this. Readers reject NaN/inf values, short lines and non-numeric
 *  fields with "file:line: what" messages. */
#include <string>

#include "dslam/core/trajectory.h"

namespace dslam::traj {

enum class Format { Auto, Tum, Kitti, Euroc };
Format formatFromString(const std::string& s);  ///< "auto"|"tum"|"kitti"|"euroc"
const char* toString(Format f);

struct ReadOptions {
  Format format = Format::Auto;
  std::string kitti_times;   ///< KITTI: times file (one time per line); empty: 13-column lines or `kitti_rate`
  double kitti_rate = 10.0;  ///< KITTI without times: t = i / rate
  /** true: sort by time and keep the last of repeated timestamps (TUM tools);
   *  false: poses in file order, as they are. */
  bool normalize_timestamps = true;
};

/** TUM timestamp semantics for poses in file order: stably sorted by time,
 *  and of equal timestamps only the last (in file order) is kept. Counts what
 *  it did; `what` names the file in the one warning it logs ("" = silent). */
struct TimestampFix {
  size_t repeated = 0;   ///< poses dropped because a later line has the same time
  size_t reordered = 0;  ///< lines whose time is earlier than a line before them
};
TimestampFix normalizeTimestamps(Trajectory& t, const std::string& what = "");

/** Detects the format from the extension (.csv -> EuRoC) and the first data
 *  line: 12/13 columns -> KITTI; >= 8 columns -> EuRoC when the time is in
 *  nanoseconds (> 1e14), TUM otherwise (extra TUM columns are ignored). */
Format detectFormat(const std::string& path);

Trajectory read(const std::string& path, const ReadOptions& opt = {});
Trajectory readTum(const std::string& path, bool normalize_timestamps = true);
Trajectory readKitti(const std::string& path, const std::string& times_path = "", double rate = 10.0,
                     bool normalize_timestamps = true);
Trajectory readEuroc(const std::string& path, bool normalize_timestamps = true);

struct WriteOptions {
  Format format = Format::Tum;
  bool kitti_with_times = false;  ///< KITTI: write 13 columns (time first)
  std::string header;             ///< comment lines written first ("# " prefixed per line; not for KITTI)
};
void write(const std::string& path, const Trajectory& t, const WriteOptions& opt = {});
void writeTum(const std::string& path, const Trajectory& t, const std::string& header = "");

}  // namespace dslam::traj
