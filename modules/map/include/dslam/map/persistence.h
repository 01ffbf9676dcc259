#pragma once
/** \file persistence.h
 *  Persistence filters: the belief that a part of the map is still there.
 *
 *  FeaturePersistence is the feature persistence filter of Rosen, Mason and
 *  Leonard ("Towards lifelong feature-based mapping in semi-static
 *  environments", ICRA 2016), the one Hashemifar and Dantu put into
 *  ORB-SLAM: a feature survives for an unknown time T with a prior survival
 *  function S(t) = P(T > t); at times t_1 < ... < t_N the detector reports
 *  it seen (y = 1) or not (y = 0) while it should be visible, with miss
 *  probability P_M and false-alarm probability P_F. The posterior
 *
 *      P(T > t | y_1..y_N) = L(y | T > t_N) S(t) / p(y_1..y_N),   t >= t_N
 *
 *  is computed recursively in O(1) per observation (their eq. 9-12), in log
 *  space. The prior here is exponential with a mean survival time.
 *
 *  ObjectBelief is Changing-SLAM's per-object Bayes filter: a belief of
 *  existence starting at 0.5, raised by sightings of an object of the same
 *  class near its centroid (a Gaussian likelihood whose spread shrinks with
 *  the object's number of points) and lowered by negative evidence (its
 *  place is in view, not occluded, and nothing of its class is there). */
#include <cstdint>

namespace dslam {

struct FeaturePersistenceParams {
  double mean_survival_s = 3600.0;  ///< prior mean of the exponential survival time (s)
  double p_miss = 0.1;              ///< P(not detected | present)
  double p_false_alarm = 0.01;      ///< P(detected | absent)
};

class FeaturePersistence {
 public:
  FeaturePersistence() = default;
  /** A feature first observed at time t0 (seconds). */
  FeaturePersistence(const FeaturePersistenceParams& p, double t0);

  /** One observation at time t (>= the last one): seen or not seen while it
   *  should have been visible. */
  void update(bool seen, double t);
  /** P(still there at time t >= last observation time | observations). */
  double belief(double t) const;
  double lastTime() const { return t_last_; }
  int observations() const { return n_; }

 private:
  double logS(double t) const;  ///< log of the prior survival function
  FeaturePersistenceParams p_;
  double t0_ = 0, t_last_ = 0;
  double log_a_ = 0;       ///< log prod p(y_i | present)
  double log_b_ = -1e300;  ///< log of the partial evidence sum (absent before t_N)
  int n_ = 0;
};

struct ObjectBeliefParams {
  double sigma_m = 0.5;            ///< spread of the sighting likelihood for a one-point object (m)
  double min_sigma_m = 0.05;       ///< it shrinks as 1/sqrt(points), down to this
  double p_detect = 0.8;           ///< P(a present object in view is detected with points)
  double p_false = 0.1;            ///< P(something of its class seen there though it is gone)
  double p_see_through = 0.1;      ///< P(its place seen through though it is there: an open or thin object,
                                   ///< depth noise); below 1 - p_detect, since depth beyond its place says more
                                   ///< than its points not being found again
  double p_twin = 0.01;            ///< P(its appearance seen elsewhere, moved rigidly, though it is still there)
  double belief_min = 0.01, belief_max = 0.99;  ///< clamps (the belief can always recover)
};

/** Sighting likelihood ratio update: an object of the same class seen
 *  `dist_m` from the centroid of an object of `points` points. */
double objectBeliefSighted(double belief, double dist_m, int points, const ObjectBeliefParams& p);
/** Negative evidence: its place was in view and not occluded, and nothing of
 *  its class was there: its points were not found again (P = 1 - p_detect if
 *  present) or, with `seen_through`, the camera saw through its place or onto
 *  another object there (P = p_see_through if present). */
double objectBeliefMissed(double belief, const ObjectBeliefParams& p, bool seen_through = false);
/** Re-identification: its appearance seen elsewhere, displaced by one rigid
 *  motion (P = p_twin if it is still there, an identical twin; p_detect if
 *  it was moved there). */
double objectBeliefSeenElsewhere(double belief, const ObjectBeliefParams& p);

}  // namespace dslam
