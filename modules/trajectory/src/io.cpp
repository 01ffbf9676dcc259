#include "dslam/trajectory/io.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "dslam/core/atomic_file.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/text_lines.h"
#include "dslam/core/yaml_util.h"

namespace dslam::traj {

Format formatFromString(const std::string& s) {
  if (s == "auto") return Format::Auto;
  if (s == "tum") return Format::Tum;
  if (s == "kitti") return Format::Kitti;
  if (s == "euroc") return Format::Euroc;
  throw ConfigError("unknown trajectory format '" + s + "' (valid: auto, tum, kitti, euroc)");
}

const char* toString(Format f) {
  switch (f) {
    case Format::Auto: return "auto";
    case Format::Tum: return "tum";
    case Format::Kitti: return "kitti";
    case Format::Euroc: return "euroc";
  }
  return "?";
}

namespace {

struct Line {
  int lineno;
  std::vector<std::string> fields;
};

/** Data lines split on whitespace and/or commas; '#' starts a comment
 *  anywhere; blank and comment-only lines are skipped. */
std::vector<Line> readLines(const std::string& path) {
  std::vector<Line> out;
  for (auto& l : readDataLines(path, "trajectory file", true)) out.push_back({l.lineno, splitFields(l.text, true)});
  return out;
}

double num(const std::string& path, const Line& l, size_t i) {
  auto v = yamlu::parseDouble(l.fields[i]);
  if (!v) throw DataError(path + ":" + std::to_string(l.lineno) + ": field " + std::to_string(i + 1) + " is not a number: '" + l.fields[i] + "'");
  if (!std::isfinite(*v)) throw DataError(path + ":" + std::to_string(l.lineno) + ": field " + std::to_string(i + 1) + " is not finite: '" + l.fields[i] + "'");
  return *v;
}

void need(const std::string& path, const Line& l, size_t n, const char* fmt) {
  if (l.fields.size() < n)
    throw DataError(path + ":" + std::to_string(l.lineno) + ": expected " + std::to_string(n) + " values (" + fmt +
                    "), got " + std::to_string(l.fields.size()));
}

SE3 fromQuat(double qw, double qx, double qy, double qz, const Eigen::Vector3d& t, const std::string& path, const Line& l) {
  Eigen::Quaterniond q(qw, qx, qy, qz);
  if (q.norm() < 1e-6) throw DataError(path + ":" + std::to_string(l.lineno) + ": zero quaternion");
  return SE3(q.normalized(), t);
}

SE3 from3x4(const std::string& path, const Line& l, size_t off) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 4; c++) T(r, c) = num(path, l, off + r * 4 + c);
  Eigen::Matrix3d R = T.block<3, 3>(0, 0);
  if (!isOrthonormal(R, 1e-2))
    throw DataError(path + ":" + std::to_string(l.lineno) +
                    ": the 3x3 block is not a rotation (R^T R differs from the identity by more than 0.01)");
  // Re-orthonormalise (KITTI files are printed with ~6 digits).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) throw DataError(path + ":" + std::to_string(l.lineno) + ": rotation has determinant < 0");
  return SE3(R, Eigen::Vector3d(T.block<3, 1>(0, 3)));
}

}  // namespace

TimestampFix normalizeTimestamps(Trajectory& t, const std::string& what) {
  TimestampFix fix;
  const size_t n = t.size();
  double latest = -std::numeric_limits<double>::infinity();
  bool sorted = true;
  for (size_t i = 0; i < n; i++) {
    if (i > 0 && !(t.stamps[i] > t.stamps[i - 1])) sorted = false;
    if (t.stamps[i] < latest) fix.reordered++;
    latest = std::max(latest, t.stamps[i]);
  }
  if (sorted) return fix;
  std::vector<size_t> idx(n);
  for (size_t i = 0; i < n; i++) idx[i] = i;
  std::stable_sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return t.stamps[a] < t.stamps[b]; });
  Trajectory out;
  for (size_t k = 0; k < n; k++) {
    // of equal times, the last in file order (the stable sort keeps it last)
    if (k + 1 < n && t.stamps[idx[k + 1]] == t.stamps[idx[k]]) {
      fix.repeated++;
      continue;
    }
    out.push_back(t.stamps[idx[k]], t.poses[idx[k]]);
  }
  t = std::move(out);
  if (!what.empty() && (fix.repeated || fix.reordered))
    DSLAM_LOG(Warn, what << ": " << fix.repeated << " repeated timestamp(s) (the last pose of each kept) and "
                         << fix.reordered << " out-of-order line(s) (sorted by time), as the TUM benchmark tools do");
  return fix;
}

Format detectFormat(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".csv") return Format::Euroc;
  auto lines = readLines(path);
  if (lines.empty()) throw DataError("trajectory file has no data lines: " + path);
  const auto& first = lines.front();
  const size_t n = first.fields.size();
  if (n == 12 || n == 13) return Format::Kitti;
  if (n >= 8) {
    const auto t0 = yamlu::parseDouble(first.fields[0]);
    return t0 && *t0 > 1e14 ? Format::Euroc : Format::Tum;
  }
  throw DataError(path + ":" + std::to_string(lines.front().lineno) + ": cannot tell the trajectory format from " +
                  std::to_string(n) + " columns (TUM: 8, KITTI: 12 or 13, EuRoC: >= 8 comma separated)");
}

Trajectory readTum(const std::string& path, bool normalize) {
  Trajectory t;
  const auto lines = readLines(path);
  for (const auto& l : lines) {
    need(path, l, 8, "timestamp tx ty tz qx qy qz qw");
    // Extra columns are allowed (TUM's tools ignore them), but a KITTI pose
    // row would be read as a pose at the time of its first number.
    if ((l.fields.size() == 12 || l.fields.size() == 13) && lines.front().fields.size() < 12)
      throw DataError(path + ":" + std::to_string(l.lineno) + ": " + std::to_string(l.fields.size()) +
                      " columns, a KITTI pose row, in a TUM file (line " + std::to_string(lines.front().lineno) +
                      " has " + std::to_string(lines.front().fields.size()) + "); one format per file");
    const double stamp = num(path, l, 0);
    t.push_back(stamp, fromQuat(num(path, l, 7), num(path, l, 4), num(path, l, 5), num(path, l, 6),
                                {num(path, l, 1), num(path, l, 2), num(path, l, 3)}, path, l));
  }
  if (normalize) normalizeTimestamps(t, path);
  return t;
}

Trajectory readKitti(const std::string& path, const std::string& times_path, double rate, bool normalize) {
  std::vector<double> times;
  if (!times_path.empty()) {
    for (const auto& l : readLines(times_path)) times.push_back(num(times_path, l, 0));
    if (times.empty()) throw DataError("KITTI times file has no times: " + times_path);
  }
  Trajectory t;
  size_t i = 0;
  bool used_times = false;
  for (const auto& l : readLines(path)) {
    need(path, l, 12, "3x4 row-major pose");
    double stamp;
    size_t off = 0;
    if (l.fields.size() >= 13) {
      stamp = num(path, l, 0);
      off = 1;
    } else if (!times.empty()) {
      if (i >= times.size())
        throw DataError(times_path + ": has " + std::to_string(times.size()) + " times but " + path + " has more poses");
      stamp = times[i];
      used_times = true;
    } else {
      stamp = static_cast<double>(i) / rate;
    }
    t.push_back(stamp, from3x4(path, l, off));
    i++;
  }
  if (used_times && i != times.size())
    throw DataError(times_path + ": has " + std::to_string(times.size()) + " times but " + path + " has " +
                    std::to_string(i) + " poses");
  if (normalize) normalizeTimestamps(t, path);
  return t;
}

Trajectory readEuroc(const std::string& path, bool normalize) {
  Trajectory t;
  for (const auto& l : readLines(path)) {
    need(path, l, 8, "timestamp[ns], px, py, pz, qw, qx, qy, qz");
    const double stamp = num(path, l, 0) * 1e-9;
    t.push_back(stamp, fromQuat(num(path, l, 4), num(path, l, 5), num(path, l, 6), num(path, l, 7),
                                {num(path, l, 1), num(path, l, 2), num(path, l, 3)}, path, l));
  }
  if (normalize) normalizeTimestamps(t, path);
  return t;
}

Trajectory read(const std::string& path, const ReadOptions& opt) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw DataError("trajectory file not found: " + path);
  Format f = opt.format == Format::Auto ? detectFormat(path) : opt.format;
  Trajectory t;
  switch (f) {
    case Format::Tum: t = readTum(path, opt.normalize_timestamps); break;
    case Format::Kitti: t = readKitti(path, opt.kitti_times, opt.kitti_rate, opt.normalize_timestamps); break;
    case Format::Euroc: t = readEuroc(path, opt.normalize_timestamps); break;
    case Format::Auto: break;
  }
  if (t.empty()) throw DataError("trajectory file has no poses: " + path);
  return t;
}

void write(const std::string& path, const Trajectory& t, const WriteOptions& opt) {
  AtomicOfstream out(path);  // complete or not there: never a truncated file
  std::ofstream& f = out.stream();
  auto header = [&](const char* prefix) {
    std::istringstream in(opt.header);
    std::string l;
    while (std::getline(in, l)) f << prefix << l << "\n";
  };
  char buf[512];
  switch (opt.format) {
    case Format::Auto:
    case Format::Tum:
      header("# ");
      for (size_t i = 0; i < t.size(); i++) {
        const auto& q = t.poses[i].quaternion();
        const auto& p = t.poses[i].translation();
        std::snprintf(buf, sizeof(buf), "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t.stamps[i], p.x(), p.y(), p.z(),
                      q.x(), q.y(), q.z(), q.w());
        f << buf;
      }
      break;
    case Format::Kitti:
      for (size_t i = 0; i < t.size(); i++) {
        const Eigen::Matrix4d M = t.poses[i].matrix();
        if (opt.kitti_with_times) {
          std::snprintf(buf, sizeof(buf), "%.9f ", t.stamps[i]);
          f << buf;
        }
        for (int r = 0; r < 3; r++)
          for (int c = 0; c < 4; c++) {
            std::snprintf(buf, sizeof(buf), "%.12e%s", M(r, c), (r == 2 && c == 3) ? "\n" : " ");
            f << buf;
          }
      }
      break;
    case Format::Euroc:
      header("# ");
      f << "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []\n";
      for (size_t i = 0; i < t.size(); i++) {
        const auto& q = t.poses[i].quaternion();
        const auto& p = t.poses[i].translation();
        std::snprintf(buf, sizeof(buf), "%lld,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n",
                      static_cast<long long>(std::llround(t.stamps[i] * 1e9)), p.x(), p.y(), p.z(), q.w(), q.x(),
                      q.y(), q.z());
        f << buf;
      }
      break;
  }
  out.commit();
}

void writeTum(const std::string& path, const Trajectory& t, const std::string& header) {
  write(path, t, WriteOptions{Format::Tum, false, header});
}

}  // namespace dslam::traj
