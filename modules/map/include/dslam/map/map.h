#pragma once
/** \file map.h
 *  One map: keyframes and map points (ORB-SLAM3 Map). A single
 *  `update_mutex` protects the whole map: tracking holds it while it tracks
 *  a frame, local mapping and loop closing while they change the map (not
 *  while an optimiser runs on a copy). Containers are keyed by id so every
 *  iteration order is deterministic. */
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "dslam/map/keyframe.h"
#include "dslam/map/map_object.h"
#include "dslam/map/map_point.h"

namespace dslam {

class Map {
 public:
  explicit Map(int64_t id);
  ~Map();
  const int64_t id;

  std::recursive_mutex update_mutex;

  void addKeyFrame(const KeyFramePtr& kf);
  void addPoint(const MapPointPtr& p);
  /** Moves a bad keyframe to the graveyard (kept alive: trajectories reference it). */
  void eraseKeyFrame(KeyFrame* kf);
  void erasePoint(MapPoint* p);

  const std::map<int64_t, KeyFramePtr>& keyframes() const { return kfs_; }
  const std::map<int64_t, MapPointPtr>& points() const { return points_; }
  size_t numKeyFrames() const { return kfs_.size(); }
  size_t numPoints() const { return points_.size(); }
  KeyFramePtr keyframe(int64_t id) const;
  MapPointPtr point(int64_t id) const;
  KeyFramePtr origin() const { return origin_; }
  /** Objects of the semantic map (long-term data association, map_object.h). */
  std::map<int64_t, MapObjectPtr>& objects() { return objects_; }
  const std::map<int64_t, MapObjectPtr>& objects() const { return objects_; }
  /** Keyframes ever created in this map, including erased ones. */
  const std::map<int64_t, KeyFramePtr>& allKeyFramesEver() const { return all_kfs_; }

  /** Incremented by loop closure / merges / global BA (ORB-SLAM mnBigChangeIdx). */
  std::atomic<int> big_change{0};

  /** Unique ids across all maps of the process. */
  static int64_t nextKeyFrameId();
  static int64_t nextPointId();
  /** Object ids, unique across maps (kept when maps merge). */
  static int64_t& objectIdCounter();
  /** For loading saved maps: ids continue after `kf` / `pt`. */
  static void reserveIds(int64_t kf, int64_t pt);

  void clear();

  /** Moves every keyframe (live and erased), point and object of `other`
   *  into this map, transforming them by T_this_other (world of `other` ->
   *  world of this map); `other` is left empty. Map merging. */
  void absorb(Map& other, const SE3& T_this_other);

 private:
  std::map<int64_t, KeyFramePtr> kfs_, all_kfs_;
  std::map<int64_t, MapPointPtr> points_;
  std::map<int64_t, MapObjectPtr> objects_;
  KeyFramePtr origin_;
};

using MapPtr = std::shared_ptr<Map>;

}  // namespace dslam
