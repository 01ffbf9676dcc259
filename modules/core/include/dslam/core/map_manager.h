#pragma once
/** \file map_manager.h
 *  Interface of map managers (Atlas, persistence filter). The map data
 *  structures (Map, KeyFrame, MapPoint) live in modules/map. */
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/plugin.h"

namespace dslam {

class Map;
class MapPoint;
struct Frame;
class KeyFrame;
struct CameraIntrinsics;
struct ScaleLevels;
class SE3;

class MapManager : public Plugin {
  DEFINE_VIRTUAL_MRPT_OBJECT(MapManager)
 public:
  const char* interfaceName() const override { return "MapManager"; }
  /** The map tracking works in. Never null after reset(). */
  virtual std::shared_ptr<Map> currentMap() = 0;
  /** Starts a new map (tracking lost and relocalisation failed) and makes it current. */
  virtual std::shared_ptr<Map> createMap() = 0;
  virtual std::vector<std::shared_ptr<Map>> maps() const = 0;
  /** Removes a map (after it was merged into another one). */
  virtual void eraseMap(const std::shared_ptr<Map>& m) = 0;
  /** Drops every map and starts an empty one. */
  virtual void reset() = 0;
  /** Whether a map point may take part in tracking, relocalisation and loop
   *  closing (a persistence filter deactivates points of moved objects). */
  virtual bool isActive(const MapPoint& p) const {
    (void)p;
    return true;
  }
  /** Called after local mapping has finished a keyframe (its points,
   *  covisibility and objects are up to date), in the mapping thread;
   *  persistence bookkeeping. Lock the keyframe's map to change it. */
  virtual void onKeyFrame(const std::shared_ptr<KeyFrame>& kf) { (void)kf; }
  /** Called once when tracking is lost in map `m` (the tracking thread;
   *  lock the map to change it): what was seen before may have changed by
   *  the time the camera relocalises. */
  virtual void onTrackingLost(const std::shared_ptr<Map>& m) { (void)m; }
  /** Called in the tracking thread after a frame tracked in map `m` that
   *  did not become a keyframe (pose `T_cw`, camera `cam`; `matched[i]`: the
   *  map point keypoint i is matched to, null for none and for outliers; lock
   *  `m` to read the points' mapping state): true makes the next frame a
   *  keyframe, if mapping accepts one (an object filter asks when a detected
   *  object the map has too few established points on is in view, or the
   *  place of an object not seen for long). */
  virtual bool wantsKeyFrame(const std::shared_ptr<Map>& m, const Frame& f, const SE3& T_cw, const CameraIntrinsics& cam,
                             const std::vector<std::shared_ptr<MapPoint>>& matched) {
    (void)m;
    (void)f;
    (void)T_cw;
    (void)cam;
    (void)matched;
    return false;
  }
  /** Map managers that filter another one (persistence filters) keep its
   *  maps and add their own decisions; the pipeline gives each filter the
   *  map manager listed before it (or a dslam::Atlas). */
  virtual bool filtersAnother() const { return false; }
  virtual void setInner(std::shared_ptr<MapManager> inner) { (void)inner; }
  /** Intrinsics and scale pyramid of the running system: load() checks the
   *  saved keyframes against them. */
  virtual void setExpectedCamera(const CameraIntrinsics& cam, std::shared_ptr<const ScaleLevels> scale) {
    (void)cam;
    (void)scale;
  }
  /** Saves / loads every map. Throw Error with a message on failure. */
  virtual void save(const std::string& path) const = 0;
  virtual void load(const std::string& path) = 0;
};

}  // namespace dslam
