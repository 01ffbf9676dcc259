#include "dslam/map/map_point.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dslam/core/descriptor.h"
#include "dslam/map/keyframe.h"
#include "dslam/map/map.h"

namespace dslam {

MapPoint::MapPoint(int64_t id_, const Eigen::Vector3d& p, KeyFrame* ref, Map* m)
    : id(id_), first_kf_id(ref ? ref->id : -1), map(m), pos(p), ref_kf(ref) {}

void MapPoint::addObservation(KeyFrame* kf, int idx) {
  if (obs_.count(kf->id)) return;
  obs_[kf->id] = {kf, idx};
  n_obs_ += (kf->u_right.size() > static_cast<size_t>(idx) && kf->u_right[idx] >= 0) ? 2 : 1;
}

void MapPoint::eraseObservation(KeyFrame* kf) {
  auto it = obs_.find(kf->id);
  if (it == obs_.end()) return;
  const int idx = it->second.second;
  n_obs_ -= (kf->u_right.size() > static_cast<size_t>(idx) && kf->u_right[idx] >= 0) ? 2 : 1;
  obs_.erase(it);
  if (ref_kf == kf) ref_kf = obs_.empty() ? nullptr : obs_.begin()->second.first;
  if (n_obs_ <= 2) setBad();
}

int MapPoint::indexIn(const KeyFrame* kf) const {
  auto it = obs_.find(kf->id);
  return it == obs_.end() ? -1 : it->second.second;
}

void MapPoint::computeDistinctiveDescriptor() {
  std::vector<const uint8_t*> ds;
  ds.reserve(obs_.size());
  for (const auto& [id_, o] : obs_)
    if (!o.first->bad) ds.push_back(o.first->descriptors.ptr<uint8_t>(o.second));
  if (ds.empty()) return;
  const size_t n = ds.size();
  std::vector<int> dist(n * n, 0);
  for (size_t i = 0; i < n; i++)
    for (size_t j = i + 1; j < n; j++) dist[i * n + j] = dist[j * n + i] = descriptorDistance(ds[i], ds[j]);
  int best = 256;
  size_t best_i = 0;
  std::vector<int> row(n);
  for (size_t i = 0; i < n; i++) {
    std::copy(dist.begin() + i * n, dist.begin() + (i + 1) * n, row.begin());
    std::sort(row.begin(), row.end());
    const int med = row[(n - 1) / 2];
    if (med < best) {
      best = med;
      best_i = i;
    }
  }
  std::copy(ds[best_i], ds[best_i] + 32, desc.begin());
}

std::vector<const uint8_t*> MapPoint::descriptorViews(size_t max_views) const {
  std::vector<const uint8_t*> v{desc.data()};
  for (const auto& [id_, o] : obs_) {
    if (v.size() > max_views) break;
    const KeyFrame* kf = o.first;
    if (kf && !kf->bad && o.second >= 0 && o.second < kf->descriptors.rows)
      v.push_back(kf->descriptors.ptr<uint8_t>(o.second));
  }
  return v;
}

void MapPoint::updateNormalAndDepth() {
  if (obs_.empty() || !ref_kf) return;
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  int cnt = 0;
  for (const auto& [id_, o] : obs_) {
    Eigen::Vector3d v = pos - o.first->center();
    const double len = v.norm();
    if (len > 0) n += v / len;
    cnt++;
  }
  const Eigen::Vector3d pc = pos - ref_kf->center();
  const float dist = static_cast<float>(pc.norm());
  const int ridx = indexIn(ref_kf);
  if (ridx < 0) return;
  const int level = ref_kf->keys_un[ridx].octave;
  const auto& sc = *ref_kf->scale;
  const float level_scale = sc.scale[level];
  max_dist = dist * level_scale;
  min_dist = max_dist / sc.scale[sc.n_levels - 1];
  if (cnt > 0 && n.norm() > 0) normal = n.normalized();
}

int MapPoint::predictScale(float dist, float log_scale_factor, int n_levels) const {
  const float ratio = max_dist / std::max(dist, 1e-6f);
  int s = static_cast<int>(std::ceil(std::log(ratio) / log_scale_factor));
  return std::clamp(s, 0, n_levels - 1);
}

void MapPoint::setBad() {
  if (bad) return;
  bad = true;
  auto obs = obs_;
  obs_.clear();
  n_obs_ = 0;
  for (const auto& [id_, o] : obs) o.first->erasePoint(o.second);
  if (map) map->erasePoint(this);
}

void MapPoint::replaceWith(const std::shared_ptr<MapPoint>& other) {
  if (!other || other.get() == this) return;
  auto obs = obs_;
  obs_.clear();
  n_obs_ = 0;
  bad = true;
  replaced = other;
  for (const auto& [id_, o] : obs) {
    KeyFrame* kf = o.first;
    if (!other->isIn(kf)) {
      kf->points[o.second] = other;
      other->addObservation(kf, o.second);
    } else {
      kf->erasePoint(o.second);
    }
  }
  other->n_found += n_found;
  other->n_visible += n_visible;
  other->computeDistinctiveDescriptor();
  if (map) map->erasePoint(this);
}

std::shared_ptr<MapPoint> MapPoint::resolve(std::shared_ptr<MapPoint> p) {
  for (int guard = 0; p && p->bad && p->replaced && guard < 64; guard++) p = p->replaced;
  return p;
}

}  // namespace dslam
