#pragma once
/** \file filtering_map_manager.h
 *  Base of map managers that filter another one (the persistence filters):
 *  maps, saving and loading are the inner map manager's (a dslam::Atlas by
 *  default); isActive() is the inner one's and the filter's own decision
 *  (the `active` flag the filters set on map points); onKeyFrame() runs the
 *  inner one's first. Filters chain: [Atlas] <- object filter <- point filter. */
#include <memory>

#include "dslam/core/error.h"
#include "dslam/core/map_manager.h"
#include "dslam/map/atlas.h"

namespace dslam {

class FilteringMapManager : public MapManager {
 public:
  bool filtersAnother() const override { return true; }
  void setInner(std::shared_ptr<MapManager> inner) override {
    if (!inner) throw ConfigError(std::string(GetRuntimeClass()->className) + ": no map manager to filter");
    inner_ = std::move(inner);
  }
  MapManager& inner() {
    if (!inner_) inner_ = std::make_shared<Atlas>();
    return *inner_;
  }
  const MapManager& inner() const { return const_cast<FilteringMapManager*>(this)->inner(); }

  std::shared_ptr<Map> currentMap() override { return inner().currentMap(); }
  std::shared_ptr<Map> createMap() override { return inner().createMap(); }
  std::vector<std::shared_ptr<Map>> maps() const override { return inner().maps(); }
  void eraseMap(const std::shared_ptr<Map>& m) override { inner().eraseMap(m); }
  void reset() override { inner().reset(); }
  bool isActive(const MapPoint& p) const override { return inner().isActive(p); }
  void onKeyFrame(const std::shared_ptr<KeyFrame>& kf) override { inner().onKeyFrame(kf); }
  void onTrackingLost(const std::shared_ptr<Map>& m) override { inner().onTrackingLost(m); }
  bool wantsKeyFrame(const std::shared_ptr<Map>& m, const Frame& f, const SE3& T_cw, const CameraIntrinsics& cam,
                     const std::vector<std::shared_ptr<MapPoint>>& matched) override {
    return inner().wantsKeyFrame(m, f, T_cw, cam, matched);
  }
  void save(const std::string& path) const override { inner().save(path); }
  void load(const std::string& path) override { inner().load(path); }
  void setExpectedCamera(const CameraIntrinsics& cam, std::shared_ptr<const ScaleLevels> scale) override {
    inner().setExpectedCamera(cam, std::move(scale));
  }

 private:
  std::shared_ptr<MapManager> inner_;
};

}  // namespace dslam
