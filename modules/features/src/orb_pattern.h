#pragma once
/** \file orb_pattern.h
 *  ORB's learned BRIEF pattern (private to the features module). */

namespace dslam::detail {

/** 256 point pairs (x1, y1, x2, y2), coordinates in [-13, 12]. */
extern const int kOrbBitPattern31[256 * 4];

}  // namespace dslam::detail
