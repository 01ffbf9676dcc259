// traj::associate: TUM associate.py semantics (greedy one-to-one, smallest
// |dt| first, strict |dt| < max_dt), checked on hand-made cases and against a
// literal O(n^2) transcription of associate.py on random stamps.
#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>

#include "dslam/core/error.h"
#include "dslam/trajectory/associate.h"
#include "test_support.h"

using dslam::traj::associate;
using Pairs = std::vector<std::pair<size_t, size_t>>;

namespace {

/** associate.py, transcribed: sort (|a-b|, a, b) candidates, take greedily. */
Pairs reference(const std::vector<double>& a, const std::vector<double>& b, double max_dt) {
  std::vector<std::tuple<double, double, double, size_t, size_t>> c;
  for (size_t i = 0; i < a.size(); i++)
    for (size_t j = 0; j < b.size(); j++)
      if (std::abs(a[i] - b[j]) < max_dt) c.emplace_back(std::abs(a[i] - b[j]), a[i], b[j], i, j);
  std::sort(c.begin(), c.end());
  std::vector<char> ua(a.size()), ub(b.size());
  Pairs out;
  for (auto& [d, ta, tb, i, j] : c) {
    if (ua[i] || ub[j]) continue;
    ua[i] = ub[j] = 1;
    out.emplace_back(i, j);
  }
  std::sort(out.begin(), out.end(), [&](auto& x, auto& y) { return a[x.first] < a[y.first]; });
  return out;
}

}  // namespace

TEST(Associate, MatchesWithinMaxDtOnly) {
  EXPECT_EQ(associate({0.0, 1.0, 2.0}, {0.005, 1.01, 2.3}, 0.02), (Pairs{{0, 0}, {1, 1}}));
  EXPECT_EQ(associate({0.0, 1.0, 2.0}, {0.005, 1.01, 2.3}, 0.5), (Pairs{{0, 0}, {1, 1}, {2, 2}}));
}

TEST(Associate, HugeTimestampsWhereTPlusMaxDtRoundsToT) {
  // Near 1e15 s the spacing of doubles is 0.125 s: ta + 0.04 == ta, and
  // identical stamps were not associated.
  const double t = 1e15 + 1000;
  EXPECT_EQ(associate({t, t + 0.125}, {t, t + 0.125}, 0.02), (Pairs{{0, 0}, {1, 1}}));
}

TEST(Associate, ThresholdIsStrict) {
  // 1/64 is exact in binary: |dt| == max_dt is not a match.
  EXPECT_TRUE(associate({0.0}, {0.015625}, 0.015625).empty());
  EXPECT_EQ(associate({0.0}, {0.015625}, 0.0156251), (Pairs{{0, 0}}));
}

TEST(Associate, OneToOneSmallestDtFirst) {
  // Both a stamps are within max_dt of b[0]; the closer one (a[1]) gets it and
  // a[0] stays unmatched although it is within max_dt.
  EXPECT_EQ(associate({0.0, 0.003}, {0.002}, 0.02), (Pairs{{1, 0}}));
  // The closest candidate wins even if it is not the first in time.
  EXPECT_EQ(associate({1.0}, {0.995, 1.003}, 0.02), (Pairs{{0, 1}}));
  // Greedy, not nearest-neighbour per element: (a0,b0)=0.004 is taken first,
  // then a1 can only have b1 (0.006), not its nearest b0.
  EXPECT_EQ(associate({0.0, 0.010}, {0.004, 0.016}, 0.02), (Pairs{{0, 0}, {1, 1}}));
  // Each index at most once.
  const Pairs p = associate({0.0, 0.001, 0.002, 0.003}, {0.0015}, 0.02);
  EXPECT_EQ(p.size(), 1u);
}

TEST(Associate, TiesGoToTheEarlierStamp) {
  // Exactly equal |dt| (binary-exact values): the smaller b stamp wins...
  EXPECT_EQ(associate({1.0}, {0.9921875, 1.0078125}, 0.02), (Pairs{{0, 0}}));
  // ...and on the a side the smaller a stamp.
  EXPECT_EQ(associate({0.9921875, 1.0078125}, {1.0}, 0.02), (Pairs{{0, 0}}));
}

TEST(Associate, UnsortedInputAndSortedOutput) {
  EXPECT_EQ(associate({2.0, 0.0, 1.0}, {1.001, 2.001, 0.001}, 0.02), (Pairs{{1, 2}, {2, 0}, {0, 1}}));
}

TEST(Associate, EmptyAndNoOverlap) {
  EXPECT_TRUE(associate({}, {1.0}, 0.02).empty());
  EXPECT_TRUE(associate({1.0}, {}, 0.02).empty());
  EXPECT_TRUE(associate({0.0, 1.0, 2.0}, {10.0, 11.0}, 0.02).empty());
}

TEST(Associate, BadArguments) {
  EXPECT_THROW(associate({1.0}, {1.0}, 0.0), dslam::ConfigError);
  EXPECT_THROW(associate({1.0}, {1.0}, -0.1), dslam::ConfigError);
  EXPECT_THROW(associate({1.0}, {1.0}, NAN), dslam::ConfigError);
  EXPECT_THROW(associate({1.0, NAN}, {1.0}, 0.02), dslam::DataError);
}

TEST(Associate, MatchesAssociatePyOnRandomStamps) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; trial++) {
    // Stamps on a coarse grid (many exact ties) plus jitter in some trials.
    std::uniform_int_distribution<int> grid(0, 400);
    std::uniform_real_distribution<double> jit(-0.004, 0.004);
    std::vector<double> a, b;
    for (int i = 0; i < 150; i++) a.push_back(1305031102.0 + grid(rng) * 0.0078125 + (trial % 2 ? jit(rng) : 0.0));
    for (int i = 0; i < 120; i++) b.push_back(1305031102.0 + grid(rng) * 0.0078125 + (trial % 2 ? jit(rng) : 0.0));
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
    b.erase(std::unique(b.begin(), b.end()), b.end());
    const Pairs ref = reference(a, b, 0.02);
    EXPECT_GT(ref.size(), 50u);
    EXPECT_EQ(associate(a, b, 0.02), ref) << "trial " << trial;
  }
}
