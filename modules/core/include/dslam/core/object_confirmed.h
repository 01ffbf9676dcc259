#pragma once
/** \file object_confirmed.h
 *  When an object of the semantic map is confirmed rather than tentative:
 *  the one rule behind `outputs.objects_min_sightings` /
 *  `objects_confirm_points` (what objects.json holds, MapObject::confirmed)
 *  and `dslam eval objects --min-sightings` / `--confirm-points` (scoring
 *  that trade-off from a run that wrote every object). */
#include <cstddef>

namespace dslam {

/** Seen by at least `min_sightings` keyframes, or of at least
 *  `confirm_points` map points (0 = no such exception). */
inline bool objectConfirmed(int sightings, size_t points, int min_sightings, size_t confirm_points) {
  return sightings >= min_sightings || (confirm_points > 0 && points >= confirm_points);
}

}  // namespace dslam
