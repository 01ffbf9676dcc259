#include "dslam/place_recognition/bow_vector.h"

#include <cctype>
#include <cfloat>
#include <cmath>

#include "bow_score.h"
#include "dslam/core/error.h"

namespace dslam {

namespace {

std::string canon(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '_' ? '-' : static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return o;
}

}  // namespace

const char* toString(WeightingType w) {
  switch (w) {
    case WeightingType::TfIdf: return "tf-idf";
    case WeightingType::Tf: return "tf";
    case WeightingType::Idf: return "idf";
    case WeightingType::Binary: return "binary";
  }
  return "?";
}

const char* toString(ScoringType s) {
  switch (s) {
    case ScoringType::L1: return "l1";
    case ScoringType::L2: return "l2";
    case ScoringType::ChiSquare: return "chi-square";
    case ScoringType::KL: return "kl";
    case ScoringType::Bhattacharyya: return "bhattacharyya";
    case ScoringType::DotProduct: return "dot-product";
  }
  return "?";
}

WeightingType weightingFromString(const std::string& s) {
  const std::string c = canon(s);
  if (c == "tf-idf" || c == "tfidf") return WeightingType::TfIdf;
  if (c == "tf") return WeightingType::Tf;
  if (c == "idf") return WeightingType::Idf;
  if (c == "binary") return WeightingType::Binary;
  throw ConfigError("unknown weighting '" + s + "' (expected tf-idf, tf, idf or binary)");
}

ScoringType scoringFromString(const std::string& s) {
  const std::string c = canon(s);
  if (c == "l1" || c == "l1-norm") return ScoringType::L1;
  if (c == "l2" || c == "l2-norm") return ScoringType::L2;
  if (c == "chi-square" || c == "chisquare" || c == "chi2") return ScoringType::ChiSquare;
  if (c == "kl") return ScoringType::KL;
  if (c == "bhattacharyya") return ScoringType::Bhattacharyya;
  if (c == "dot-product" || c == "dot") return ScoringType::DotProduct;
  throw ConfigError("unknown scoring '" + s + "' (expected l1, l2, chi-square, kl, bhattacharyya or dot-product)");
}

WeightingType weightingFromInt(int v) {
  if (v < 0 || v > 3) throw DataError("weighting type " + std::to_string(v) + " out of range 0..3 (tf-idf, tf, idf, binary)");
  return static_cast<WeightingType>(v);
}

ScoringType scoringFromInt(int v) {
  if (v < 0 || v > 5)
    throw DataError("scoring type " + std::to_string(v) +
                    " out of range 0..5 (l1, l2, chi-square, kl, bhattacharyya, dot-product)");
  return static_cast<ScoringType>(v);
}

BowNorm normFor(ScoringType s) {
  switch (s) {
    case ScoringType::L2: return BowNorm::L2;
    case ScoringType::DotProduct: return BowNorm::None;
    default: return BowNorm::L1;
  }
}

void BowVector::addWeight(WordId w, WordValue v) {
  auto it = std::lower_bound(e_.begin(), e_.end(), w, [](const BowEntry& a, WordId b) { return a.word < b; });
  if (it != e_.end() && it->word == w)
    it->weight += v;
  else
    e_.insert(it, BowEntry{w, v});
}

void BowVector::normalize(BowNorm n) {
  if (n == BowNorm::None || e_.empty()) return;
  double norm = 0;
  if (n == BowNorm::L1) {
    for (const auto& e : e_) norm += std::fabs(e.weight);
  } else {
    for (const auto& e : e_) norm += e.weight * e.weight;
    norm = std::sqrt(norm);
  }
  if (norm > 0)
    for (auto& e : e_) e.weight /= norm;
}

size_t FeatureVector::featureCount() const {
  size_t n = 0;
  for (const auto& f : n_) n += f.features.size();
  return n;
}

namespace {

/** Calls f(a_i, b_i) for every word of both vectors, ascending word order. */
template <class F>
void forEachCommon(const BowVector& a, const BowVector& b, F f) {
  auto i = a.begin(), j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (i->word < j->word) {
      ++i;
    } else if (j->word < i->word) {
      ++j;
    } else {
      f(i->weight, j->weight);
      ++i;
      ++j;
    }
  }
}

/** Sum of f(a_i, b_i) over the common words, ascending word order. */
template <class F>
double sumCommon(const BowVector& a, const BowVector& b, F f) {
  double s = 0;
  forEachCommon(a, b, [&](double x, double y) { s += f(x, y); });
  return s;
}

}  // namespace

int commonWords(const BowVector& a, const BowVector& b) {
  int n = 0;
  forEachCommon(a, b, [&](double, double) { ++n; });
  return n;
}

double bowScoreL1(const BowVector& a, const BowVector& b) { return bowScore(ScoringType::L1, a, b); }

double bowScore(ScoringType type, const BowVector& a, const BowVector& b) {
  switch (type) {
    case ScoringType::L1:
    case ScoringType::L2:
    case ScoringType::ChiSquare:
    case ScoringType::Bhattacharyya:
    case ScoringType::DotProduct:
      return bowscore::finish(type, sumCommon(a, b, [type](double x, double y) { return bowscore::wordTerm(type, x, y); }));
    case ScoringType::KL: {
      // DBoW2 KLScoring: words of `a` missing from `b` count as b_i = DBL_EPSILON.
      const double log_eps = std::log(DBL_EPSILON);
      double s = 0;
      auto j = b.begin();
      for (auto i = a.begin(); i != a.end(); ++i) {
        while (j != b.end() && j->word < i->word) ++j;
        const double x = i->weight;
        if (j != b.end() && j->word == i->word) {
          if (x != 0 && j->weight != 0) s += x * std::log(x / j->weight);
        } else if (x != 0) {
          s += x * (std::log(x) - log_eps);
        }
      }
      return s;
    }
  }
  return 0;
}

}  // namespace dslam
