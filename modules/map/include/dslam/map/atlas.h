#pragma once
/** \file atlas.h
 *  dslam::Atlas, the default MapManager (ORB-SLAM3 Atlas): several maps, one
 *  of them current; a new map when tracking is lost and relocalisation
 *  fails; maps are merged by the loop closer when place recognition links
 *  them. save()/load() write / read every map to a binary file (format
 *  "DSLAMATL", versioned; corrupt or foreign files are refused with a
 *  message). Registered as a plugin by plugins/map_managers. */
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dslam/core/map_manager.h"
#include "dslam/map/map.h"

namespace dslam {

class Atlas : public MapManager {
  DEFINE_MRPT_OBJECT(Atlas, dslam)
 public:
  Atlas();
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;

  std::shared_ptr<Map> currentMap() override;
  std::shared_ptr<Map> createMap() override;
  std::vector<std::shared_ptr<Map>> maps() const override;
  void reset() override;
  bool isActive(const MapPoint& p) const override { return p.active; }
  void save(const std::string& path) const override;
  void load(const std::string& path) override;

  void eraseMap(const std::shared_ptr<Map>& m) override;
  void setCurrent(const std::shared_ptr<Map>& m);
  std::shared_ptr<Map> map(int64_t id) const;

  /** Scale pyramid and intrinsics given to loaded keyframes must match the
   *  running system's; load() checks them against these when set. */
  void setExpectedCamera(const CameraIntrinsics& cam, std::shared_ptr<const ScaleLevels> scale) override {
    exp_cam_ = cam;
    exp_scale_ = std::move(scale);
  }

  /** 2: map points carry their object, maps their MapObjects; version 1
   *  files (no objects) still load. */
  static constexpr uint32_t kFileVersion = 2;

 private:
  std::vector<std::shared_ptr<Map>> maps_;
  std::shared_ptr<Map> current_;
  int64_t next_map_id_ = 0;
  std::optional<CameraIntrinsics> exp_cam_;
  std::shared_ptr<const ScaleLevels> exp_scale_;
};

}  // namespace dslam
