#pragma once
/** \file trajectory.h
 *  A timed sequence of camera poses T_wc (camera-to-world). File I/O lives
 *  in dslam/trajectory/io.h. */
#include <cstddef>
#include <vector>

#include "dslam/core/se3.h"

namespace dslam {

struct Trajectory {
  std::vector<double> stamps;  ///< seconds
  std::vector<SE3> poses;      ///< T_wc

  size_t size() const { return poses.size(); }
  bool empty() const { return poses.empty(); }
  void push_back(double t, const SE3& T) {
    stamps.push_back(t);
    poses.push_back(T);
  }
  void clear() {
    stamps.clear();
    poses.clear();
  }
  /** Length of the path through the positions, metres. */
  double pathLength() const {
    double L = 0;
    for (size_t i = 1; i < poses.size(); i++)
      L += (poses[i].translation() - poses[i - 1].translation()).norm();
    return L;
  }
};

}  // namespace dslam
