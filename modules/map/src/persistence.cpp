#include "dslam/map/persistence.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dslam {

namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

double logSumExp(double a, double b) {
  if (a == kNegInf) return b;
  if (b == kNegInf) return a;
  const double m = std::max(a, b);
  return m + std::log(std::exp(a - m) + std::exp(b - m));
}

}  // namespace

FeaturePersistence::FeaturePersistence(const FeaturePersistenceParams& p, double t0)
    : p_(p), t0_(t0), t_last_(t0), log_a_(0), log_b_(kNegInf), n_(0) {}

double FeaturePersistence::logS(double t) const {
  return -std::max(0.0, t - t0_) / std::max(1e-9, p_.mean_survival_s);
}

void FeaturePersistence::update(bool seen, double t) {
  t = std::max(t, t_last_);
  // Probability that the feature vanished in (t_last, t]: S(t_last) - S(t).
  const double ls0 = logS(t_last_), ls1 = logS(t);
  const double log_vanish = ls1 < ls0 ? ls0 + std::log1p(-std::exp(ls1 - ls0)) : kNegInf;
  const double log_absent = std::log(seen ? p_.p_false_alarm : 1.0 - p_.p_false_alarm);
  const double log_present = std::log(seen ? 1.0 - p_.p_miss : p_.p_miss);
  log_b_ = logSumExp(log_b_, log_a_ + log_vanish) + log_absent;
  log_a_ += log_present;
  t_last_ = t;
  n_++;
}

double FeaturePersistence::belief(double t) const {
  const double log_evidence = logSumExp(log_b_, log_a_ + logS(t_last_));
  const double b = std::exp(log_a_ + logS(std::max(t, t_last_)) - log_evidence);
  return std::clamp(b, 0.0, 1.0);
}

namespace {

/** Bayes update of P(still there) with the likelihoods of an observation if
 *  present and if absent, clamped so that it can always recover. */
double bayesBelief(double belief, double present, double absent, const ObjectBeliefParams& p) {
  const double b = belief * present / (belief * present + (1 - belief) * absent);
  return std::clamp(b, p.belief_min, p.belief_max);
}

}  // namespace

double objectBeliefSighted(double belief, double dist_m, int points, const ObjectBeliefParams& p) {
  const double sigma = std::max(p.min_sigma_m, p.sigma_m / std::sqrt(std::max(1, points)));
  const double present = p.p_detect * std::exp(-0.5 * dist_m * dist_m / (sigma * sigma));
  return bayesBelief(belief, present, p.p_false, p);
}

double objectBeliefMissed(double belief, const ObjectBeliefParams& p, bool seen_through) {
  return bayesBelief(belief, seen_through ? p.p_see_through : 1 - p.p_detect, 1 - p.p_false, p);
}

double objectBeliefSeenElsewhere(double belief, const ObjectBeliefParams& p) {
  return bayesBelief(belief, p.p_twin, p.p_detect, p);
}

}  // namespace dslam
