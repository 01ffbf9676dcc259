#pragma once
// The per-word terms and final transforms of the BoW scores, shared by
// bowScore() (two vectors) and BowDatabase (accumulated over the inverted
// file): the same terms in the same (ascending word) order give the same
// value both ways. KL needs the whole vectors and has no per-word term.
#include <cmath>

#include "dslam/place_recognition/bow_vector.h"

namespace dslam::bowscore {

/** Term of a word present in both vectors with weights x and y (0 for KL). */
inline double wordTerm(ScoringType t, double x, double y) {
  switch (t) {
    case ScoringType::L1: return std::fabs(x - y) - std::fabs(x) - std::fabs(y);
    case ScoringType::L2:
    case ScoringType::DotProduct: return x * y;
    case ScoringType::ChiSquare: return x + y != 0.0 ? x * y / (x + y) : 0.0;
    case ScoringType::Bhattacharyya: return std::sqrt(x * y);
    case ScoringType::KL: return 0;
  }
  return 0;
}

/** Score from the sum of the word terms (every type but KL). */
inline double finish(ScoringType t, double s) {
  switch (t) {
    case ScoringType::L1: return -s / 2.0;
    case ScoringType::L2: return s >= 1 ? 1.0 : 1.0 - std::sqrt(1.0 - s);
    case ScoringType::ChiSquare: return 2.0 * s;
    case ScoringType::Bhattacharyya:
    case ScoringType::DotProduct:
    case ScoringType::KL: return s;
  }
  return s;
}

}  // namespace dslam::bowscore
