#pragma once
/** \file ray_update.h (internal to modules/dense)
 *  The key sets OctoMap's OcTree::insertPointCloud(..., discretize=true)
 *  updates, computed without its hash sets: a bit cube around the sensor
 *  de-duplicates the ray keys (OctoMap's KeySet insertions were 80 % of the
 *  integration time). Tested against OcTree::computeDiscreteUpdate() in
 *  tests/dense/test_dense.cpp. */
#include <octomap/OcTree.h>

#include <cstdint>
#include <unordered_set>
#include <vector>

namespace dslam::dense {

/** A set of voxel keys, a bit cube of `half` voxels on each side of a
 *  centre key, keys outside it (or all keys, when the cube would exceed
 *  64 MB: fine voxels and long rays) in a hash set. */
class VoxelKeySet {
 public:
  explicit VoxelKeySet(int half);
  /** Empties the set and centres the cube on `centre`. */
  void reset(const octomap::OcTreeKey& centre);
  /** Inserts `k`; true if it was not in the set. */
  bool insert(const octomap::OcTreeKey& k);
  bool contains(const octomap::OcTreeKey& k) const;
  bool usesCube() const { return !bits_.empty(); }

 private:
  int half_;
  size_t side_;
  octomap::OcTreeKey centre_;
  std::vector<uint64_t> bits_;
  std::unordered_set<uint64_t> hashed_;
  bool index(const octomap::OcTreeKey& k, size_t& i) const;
};

/** Free and occupied keys of one point cloud, each once, free disjoint
 *  from occupied. */
struct RayUpdate {
  std::vector<octomap::OcTreeKey> free, occupied;
};

/** The sets of OcTree::computeDiscreteUpdate(cloud, origin, ..., max_range)
 *  (max_range > 0): the cloud reduced to one point per voxel (its centre);
 *  centres within max_range occupied; the voxels on the rays to them free
 *  unless occupied; rays to farther centres cut at max_range, clearing
 *  only. `tree` gives the resolution only; `seen` and `occupied` are
 *  scratch sets of at least ceil(max_range / resolution) + 2 voxels half
 *  size (reused between calls). */
void discreteRayUpdate(const octomap::OcTree& tree, const octomap::Pointcloud& cloud, const octomap::point3d& origin,
                       double max_range, VoxelKeySet& seen, VoxelKeySet& occupied, RayUpdate& out);

}  // namespace dslam::dense
