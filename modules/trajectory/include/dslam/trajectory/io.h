#pragma once
/** \file io.h
 *  Trajectory files: TUM (`t tx ty tz qx qy qz qw`), KITTI (3x4 row-major
 *  per line; optional times file, or 13 columns with the time first) and
 *  EuRoC CSV (`t[ns], px, py, pz, qw, qx, qy, qz, ...`).
 *
 *  Readers reject NaN/inf values, short lines, non-numeric fields and
 *  timestamps that do not increase, with "file:line: what" messages. */
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
  bool require_increasing = true;
};

/** Detects the format from the extension (.csv -> EuRoC) and the number of
 *  columns of the first data line (8 -> TUM, 12/13 -> KITTI). */
Format detectFormat(const std::string& path);

Trajectory read(const std::string& path, const ReadOptions& opt = {});
Trajectory readTum(const std::string& path, bool require_increasing = true);
Trajectory readKitti(const std::string& path, const std::string& times_path = "", double rate = 10.0,
                     bool require_increasing = true);
Trajectory readEuroc(const std::string& path, bool require_increasing = true);

struct WriteOptions {
  Format format = Format::Tum;
  bool kitti_with_times = false;  ///< KITTI: write 13 columns (time first)
  std::string header;             ///< comment lines written first ("# " prefixed per line; not for KITTI)
};
void write(const std::string& path, const Trajectory& t, const WriteOptions& opt = {});
void writeTum(const std::string& path, const Trajectory& t, const std::string& header = "");

}  // namespace dslam::traj
