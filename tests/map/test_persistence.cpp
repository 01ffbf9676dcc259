// Persistence filters: Rosen et al.'s feature persistence filter against a
// direct evaluation of its posterior, and the object belief updates.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "dslam/map/persistence.h"

using namespace dslam;

namespace {

/** P(T > t | y) by the definition: sum over the interval in which the
 *  feature vanished (Rosen et al. eq. 6-8), exponential prior. */
double bruteForce(const FeaturePersistenceParams& p, double t0, const std::vector<std::pair<double, bool>>& obs,
                  double t) {
  auto S = [&](double x) { return std::exp(-(x - t0) / p.mean_survival_s); };
  auto like = [&](bool present, bool seen) {
    return present ? (seen ? 1 - p.p_miss : p.p_miss) : (seen ? p.p_false_alarm : 1 - p.p_false_alarm);
  };
  const size_t n = obs.size();
  double evidence = 0;
  for (size_t i = 0; i <= n; i++) {  // vanished after obs[i-1], before obs[i] (or after the last one)
    double l = 1;
    for (size_t j = 0; j < n; j++) l *= like(j < i, obs[j].second);
    const double lo = i == 0 ? t0 : obs[i - 1].first;
    const double prob = i == n ? S(lo) : S(lo) - S(obs[i].first);
    evidence += l * prob;
  }
  double all_present = 1;
  for (const auto& o : obs) all_present *= like(true, o.second);
  return all_present * S(t) / evidence;
}

}  // namespace

TEST(FeaturePersistence, MatchesTheDirectPosterior) {
  FeaturePersistenceParams p;
  p.mean_survival_s = 20;
  p.p_miss = 0.2;
  p.p_false_alarm = 0.05;
  std::mt19937 rng(7);
  std::bernoulli_distribution coin(0.6);
  FeaturePersistence f(p, 1.0);
  std::vector<std::pair<double, bool>> obs;
  double t = 1.0;
  EXPECT_NEAR(f.belief(5.0), std::exp(-4.0 / 20), 1e-12);  // no observation: the prior
  for (int k = 0; k < 40; k++) {
    t += 0.5 + 0.1 * (k % 3);
    const bool seen = coin(rng);
    f.update(seen, t);
    obs.push_back({t, seen});
    EXPECT_NEAR(f.belief(t), bruteForce(p, 1.0, obs, t), 1e-9) << "after " << k + 1;
    EXPECT_NEAR(f.belief(t + 3), bruteForce(p, 1.0, obs, t + 3), 1e-9);
  }
  EXPECT_EQ(f.observations(), 40);
}

TEST(FeaturePersistence, SightingsKeepItMissesRemoveItAndItComesBack) {
  FeaturePersistenceParams p;  // defaults: mean survival 1 h, P_M 0.1, P_F 0.01
  FeaturePersistence f(p, 0.0);
  for (int k = 1; k <= 10; k++) f.update(true, k);
  EXPECT_GT(f.belief(10), 0.99);
  int misses = 0;
  double t = 10;
  while (f.belief(t) > 0.5 && misses < 20) {
    f.update(false, ++t);
    misses++;
  }
  EXPECT_LE(misses, 4);  // a few consecutive misses: gone
  for (int k = 0; k < 5; k++) f.update(false, ++t);
  EXPECT_LT(f.belief(t), 0.01);
  // Seen again: a few sightings are false alarms (P_F = 0.01 each) rather than
  // a present feature missed nine times (P_M^9 = 1e-9); the fifth makes
  // presence the better explanation and it is believed back.
  int sightings = 0;
  while (f.belief(t) < 0.5 && sightings < 20) {
    f.update(true, ++t);
    sightings++;
  }
  EXPECT_GE(sightings, 3);
  EXPECT_LE(sightings, 6);
}

TEST(FeaturePersistence, LongHistoriesStayFinite) {
  FeaturePersistence f(FeaturePersistenceParams{}, 0.0);
  for (int k = 1; k <= 20000; k++) f.update(k % 7 != 0, k * 0.1);
  const double b = f.belief(2000.0);
  EXPECT_TRUE(std::isfinite(b));
  EXPECT_GT(b, 0.9);
}

TEST(ObjectBelief, SightingsRaiseMissesLowerFarSightingsBarelyCount) {
  ObjectBeliefParams p;
  double b = 0.5;
  b = objectBeliefSighted(b, 0.02, 100, p);
  EXPECT_GT(b, 0.85);
  const double near = objectBeliefSighted(0.5, 0.05, 100, p);
  const double far = objectBeliefSighted(0.5, 0.5, 100, p);  // 0.5 m off a 100-point object
  EXPECT_GT(near, far);
  EXPECT_LT(far, 0.5);  // a same-class object that far away is not this one
  // Few points: a wider likelihood, the same offset still supports it.
  EXPECT_GT(objectBeliefSighted(0.5, 0.3, 1, p), objectBeliefSighted(0.5, 0.3, 100, p));
  // Negative evidence: each miss multiplies the odds by (1 - 0.8) / (1 - 0.1);
  // three bring a confident (0.9) object below 0.3.
  double c = 0.9;
  c = objectBeliefMissed(c, p);
  EXPECT_NEAR(c / (1 - c), 9.0 * 0.2 / 0.9, 1e-9);
  c = objectBeliefMissed(c, p);
  c = objectBeliefMissed(c, p);
  EXPECT_LT(c, 0.3);
  // Clamped: it can always come back.
  for (int k = 0; k < 50; k++) c = objectBeliefMissed(c, p);
  EXPECT_DOUBLE_EQ(c, p.belief_min);
  EXPECT_GT(objectBeliefSighted(c, 0.0, 50, p), 0.05);
}

TEST(ObjectBelief, TheUpperClampSetsHowManyMissesAnObjectSeenOftenNeeds) {
  // Sightings at the centroid (odds x8 each) take the belief to the clamp.
  const auto missesBelow = [](ObjectBeliefParams p, double threshold) {
    double b = 0.5;
    for (int k = 0; k < 30; k++) b = objectBeliefSighted(b, 0.0, 200, p);
    EXPECT_DOUBLE_EQ(b, p.belief_max);
    int n = 0;
    while (b >= threshold && n < 100) {
      b = objectBeliefMissed(b, p);
      n++;
    }
    return n;
  };
  ObjectBeliefParams p;  // belief_max 0.99: odds 99 x (0.2 / 0.9)^n below 0.25 needs n = 4
  EXPECT_EQ(missesBelow(p, 0.2), 4);
  p.belief_max = 0.95;  // odds 19: n = 3
  EXPECT_EQ(missesBelow(p, 0.2), 3);
  p.belief_max = 0.999;  // odds 999: n = 6
  EXPECT_EQ(missesBelow(p, 0.2), 6);
}

TEST(ObjectBelief, PlaceSeenThroughWeighsMoreThanPointsNotFound) {
  ObjectBeliefParams p;  // p_detect 0.8, p_false 0.1, p_see_through 0.1
  // Seen through: the odds fall by p_see_through / (1 - p_false), not (1 - p_detect) / (1 - p_false).
  const double through = objectBeliefMissed(0.84, p, true), points = objectBeliefMissed(0.84, p, false);
  EXPECT_NEAR(through / (1 - through), 0.84 / 0.16 * 0.1 / 0.9, 1e-9);
  EXPECT_NEAR(points / (1 - points), 0.84 / 0.16 * 0.2 / 0.9, 1e-9);
  // A confident object (0.84) whose points are not found once and whose place is
  // then seen through falls below the 0.2 threshold; two misses of its points
  // alone leave it above (the shift scene's chair fragment: 0.84 -> 0.54 -> 0.205).
  EXPECT_LT(objectBeliefMissed(points, p, true), 0.2);
  EXPECT_GT(objectBeliefMissed(points, p, false), 0.2);
  // With p_see_through = 1 - p_detect both are the same evidence.
  p.p_see_through = 1 - p.p_detect;
  EXPECT_DOUBLE_EQ(objectBeliefMissed(0.6, p, true), objectBeliefMissed(0.6, p, false));
}
