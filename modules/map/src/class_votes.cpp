#include "dslam/map/class_votes.h"

#include "dslam/map/keyframe.h"
#include "dslam/map/map_object.h"

namespace dslam {

void PointClassVotes::add(const KeyFrame& kf, const LtdaParams& p) {
  for (size_t i = 0; i < kf.points.size() && i < kf.meta.size(); i++) {
    const MapPointPtr& mp = kf.points[i];
    const KeypointMeta& m = kf.meta[i];
    if (!mp || mp->bad || m.label == KpLabel::Dynamic || !isObjectClass(m.class_id, p)) continue;
    Entry& e = votes_[mp->id];
    if (e.point.expired()) e.point = mp;
    bool found = false;
    for (auto& [c, n] : e.counts)
      if (c == m.class_id) n++, found = true;
    if (!found) e.counts.emplace_back(m.class_id, 1);
  }
  if (votes_.size() > 2 * pruned_size_ + 4096) prune();
}

int PointClassVotes::votes(const MapPoint& mp, int c) const {
  auto it = votes_.find(mp.id);
  if (it == votes_.end()) return 0;
  for (const auto& [k, n] : it->second.counts)
    if (k == c) return n;
  return 0;
}

int PointClassVotes::classOf(const MapPoint& mp, int now) const {
  auto it = votes_.find(mp.id);
  if (it == votes_.end()) return now;
  const auto& counts = it->second.counts;
  int best = now, best_n = 0;
  for (const auto& [c, n] : counts)
    if (c == now) best_n = n;
  for (const auto& [c, n] : counts)  // first class with the most votes (counts keep first-vote order)
    if (n > best_n) best = c, best_n = n;
  return best;
}

void PointClassVotes::prune() {
  for (auto it = votes_.begin(); it != votes_.end();) {
    auto mp = it->second.point.lock();
    if (!mp || mp->bad)
      it = votes_.erase(it);
    else
      ++it;
  }
  pruned_size_ = votes_.size();
}

}  // namespace dslam
