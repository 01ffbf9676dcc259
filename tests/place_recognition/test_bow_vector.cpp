// BowVector / FeatureVector and the DBoW2 scores against dense formulas.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <map>
#include <random>

#include "dslam/core/error.h"
#include "dslam/place_recognition/bow_vector.h"
#include "vocab_test_util.h"

using namespace dslam;

namespace {

BowVector make(std::map<WordId, double> m) {
  std::vector<BowEntry> e;
  for (auto& [w, v] : m) e.push_back({w, v});
  return BowVector(std::move(e));
}


double dense(const BowVector& a, const BowVector& b, ScoringType s) {
  std::map<WordId, std::pair<double, double>> u;
  for (const auto& e : a) u[e.word].first = e.weight;
  for (const auto& e : b) u[e.word].second = e.weight;
  double r = 0;
  switch (s) {
    case ScoringType::L1:
      for (auto& [w, p] : u) r += std::fabs(p.first - p.second);
      return 1.0 - 0.5 * r;
    case ScoringType::L2:
      for (auto& [w, p] : u) r += (p.first - p.second) * (p.first - p.second);
      // DBoW2 maps the distance ||a - b|| = sqrt(2 - 2 a.b) to 1 - sqrt(1 - a.b).
      return 1.0 - std::sqrt(r / 2.0);
    case ScoringType::ChiSquare:
      for (auto& [w, p] : u)
        if (p.first + p.second > 0) r += (p.first - p.second) * (p.first - p.second) / (p.first + p.second);
      return 1.0 - 0.5 * r;
    case ScoringType::Bhattacharyya:
      for (auto& [w, p] : u) r += std::sqrt(p.first * p.second);
      return r;
    case ScoringType::DotProduct:
      for (auto& [w, p] : u) r += p.first * p.second;
      return r;
    case ScoringType::KL:
      for (auto& [w, p] : u)
        if (p.first > 0) r += p.first * std::log(p.first / (p.second > 0 ? p.second : DBL_EPSILON));
      return r;
  }
  return 0;
}

}  // namespace

TEST(BowVector, AddWeightKeepsSortedUniqueWords) {
  BowVector v;
  v.addWeight(7, 1.0);
  v.addWeight(2, 0.5);
  v.addWeight(7, 2.0);
  v.addWeight(4, 0.25);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0].word, 2u);
  EXPECT_EQ(v[1].word, 4u);
  EXPECT_EQ(v[2].word, 7u);
  EXPECT_DOUBLE_EQ(v.weight(7), 3.0);
  EXPECT_DOUBLE_EQ(v.weight(5), 0.0);
  EXPECT_EQ(v.find(5), nullptr);
  v.normalize(BowNorm::L1);
  EXPECT_DOUBLE_EQ(v.weight(7), 3.0 / 3.75);
  EXPECT_DOUBLE_EQ(v.weight(2), 0.5 / 3.75);
  v.normalize(BowNorm::L2);
  double n2 = 0;
  for (const auto& e : v) n2 += e.weight * e.weight;
  EXPECT_NEAR(n2, 1.0, 1e-12);
}

TEST(BowVector, L1ScoreKnownValues) {
  const BowVector a = make({{1, 0.5}, {2, 0.25}, {3, 0.25}});
  const BowVector b = make({{2, 0.5}, {3, 0.25}, {9, 0.25}});
  // |a-b|_1 = 0.5 + 0.25 + 0 + 0.25 = 1.0 -> 1 - 0.5 = 0.5
  EXPECT_DOUBLE_EQ(bowScoreL1(a, b), 0.5);
  EXPECT_DOUBLE_EQ(bowScoreL1(a, a), 1.0);
  EXPECT_DOUBLE_EQ(bowScoreL1(a, make({{5, 1.0}})), 0.0);
  EXPECT_EQ(commonWords(a, b), 2);
  EXPECT_DOUBLE_EQ(bowScore(ScoringType::L1, a, b), bowScoreL1(b, a));
}

TEST(BowVector, AllScoringsMatchDenseFormulas) {
  std::mt19937 rng(5);
  for (ScoringType s : {ScoringType::L1, ScoringType::L2, ScoringType::ChiSquare, ScoringType::KL,
                        ScoringType::Bhattacharyya, ScoringType::DotProduct}) {
    for (int t = 0; t < 20; ++t) {
      const BowVector a = test::randomVector(rng, 60, 150, normFor(s));
      const BowVector b = test::randomVector(rng, 60, 150, normFor(s));
      EXPECT_NEAR(bowScore(s, a, b), dense(a, b, s), 1e-9) << toString(s);
      if (s != ScoringType::KL && s != ScoringType::DotProduct) {
        // L2: 1 - sqrt(1 - a.a) turns the 1e-16 rounding of a.a into ~1e-8.
        EXPECT_NEAR(bowScore(s, a, a), 1.0, s == ScoringType::L2 ? 3e-8 : 1e-12) << toString(s);
      }
    }
  }
}

TEST(BowVector, EnumNamesRoundTrip) {
  for (int i = 0; i < 4; ++i) EXPECT_EQ(weightingFromString(toString(weightingFromInt(i))), weightingFromInt(i));
  for (int i = 0; i < 6; ++i) EXPECT_EQ(scoringFromString(toString(scoringFromInt(i))), scoringFromInt(i));
  EXPECT_EQ(weightingFromString("TF_IDF"), WeightingType::TfIdf);
  EXPECT_THROW(weightingFromString("bm25"), ConfigError);
  EXPECT_THROW(scoringFromInt(6), DataError);
  EXPECT_EQ(normFor(ScoringType::L2), BowNorm::L2);
  EXPECT_EQ(normFor(ScoringType::DotProduct), BowNorm::None);
  EXPECT_EQ(normFor(ScoringType::ChiSquare), BowNorm::L1);
}

TEST(FeatureVector, FindAndCount) {
  FeatureVector fv({FeatureNode{3, {0, 4}}, FeatureNode{8, {1}}, FeatureNode{11, {2, 3, 5}}});
  EXPECT_EQ(fv.featureCount(), 6u);
  ASSERT_NE(fv.find(11), nullptr);
  EXPECT_EQ(fv.find(11)->features.size(), 3u);
  EXPECT_EQ(fv.find(4), nullptr);
}
