#include "dslam/map/map.h"

namespace dslam {

namespace {
std::atomic<int64_t> g_next_kf{0}, g_next_pt{0};
}

Map::Map(int64_t id_) : id(id_) {}
Map::~Map() { clear(); }

int64_t Map::nextKeyFrameId() { return g_next_kf++; }
int64_t Map::nextPointId() { return g_next_pt++; }
int64_t& Map::objectIdCounter() {
  static int64_t next = 0;
  return next;
}
void Map::reserveIds(int64_t kf, int64_t pt) {
  int64_t cur = g_next_kf.load();
  while (cur <= kf && !g_next_kf.compare_exchange_weak(cur, kf + 1)) {
  }
  cur = g_next_pt.load();
  while (cur <= pt && !g_next_pt.compare_exchange_weak(cur, pt + 1)) {
  }
}

void Map::addKeyFrame(const KeyFramePtr& kf) {
  if (!origin_) origin_ = kf;
  kfs_[kf->id] = kf;
  all_kfs_[kf->id] = kf;
}

void Map::addPoint(const MapPointPtr& p) { points_[p->id] = p; }

void Map::eraseKeyFrame(KeyFrame* kf) { kfs_.erase(kf->id); }

void Map::erasePoint(MapPoint* p) { points_.erase(p->id); }

KeyFramePtr Map::keyframe(int64_t i) const {
  auto it = all_kfs_.find(i);
  return it == all_kfs_.end() ? nullptr : it->second;
}

MapPointPtr Map::point(int64_t i) const {
  auto it = points_.find(i);
  return it == points_.end() ? nullptr : it->second;
}

void Map::absorb(Map& other, const SE3& T_this_other) {
  const SE3 T_other_this = T_this_other.inverse();
  for (auto& [id, kf] : other.all_kfs_) {
    kf->setPose(kf->T_cw() * T_other_this);
    kf->map = this;
    all_kfs_[id] = kf;
    if (other.kfs_.count(id)) kfs_[id] = kf;
  }
  for (auto& [id, p] : other.points_) {
    p->pos = T_this_other * p->pos;
    p->normal = T_this_other.rotation() * p->normal;
    p->map = this;
    points_[id] = p;
  }
  for (auto& [id, o] : other.objects_) {
    o->refresh();  // centroid and box from the moved points
    objects_[id] = o;
  }
  other.kfs_.clear();
  other.all_kfs_.clear();
  other.points_.clear();
  other.objects_.clear();
  other.origin_.reset();
}

void Map::clear() {
  // Break shared_ptr cycles (points <-> replaced links, keyframe point slots).
  for (auto& [i, kf] : all_kfs_) {
    for (auto& p : kf->points) p.reset();
  }
  for (auto& [i, p] : points_) p->replaced.reset();
  objects_.clear();
  points_.clear();
  kfs_.clear();
  all_kfs_.clear();
  origin_.reset();
}

}  // namespace dslam
