#pragma once
/** \file associate.h
 *  Timestamp association with the semantics of the TUM RGB-D benchmark's
 *  associate.py: every pair (i, j) with |a[i] - b[j]| < max_dt is a
 *  candidate; candidates are taken greedily, smallest |dt| first (ties: the
 *  smaller a stamp, then the smaller b stamp), each index used at most once.
 *
 *  This is the one implementation used by the trajectory evaluator
 *  (dslam::eval) and meant for dataset readers (rgb/depth lists). */
#include <cstddef>
#include <utility>
#include <vector>

namespace dslam::traj {

/** Greedy one-to-one association of two timestamp lists (seconds).
 *  The lists need not be sorted. Returns (index into a, index into b) pairs
 *  sorted by a[i]. Throws ConfigError if max_dt is not a positive finite
 *  number and DataError if a stamp is not finite. An empty result is not an
 *  error here: callers decide (the evaluator reports it). */
std::vector<std::pair<size_t, size_t>> associate(const std::vector<double>& a, const std::vector<double>& b,
                                                 double max_dt);

}  // namespace dslam::traj
