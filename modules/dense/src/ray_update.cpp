// discreteRayUpdate(): OctoMap's discretised point-cloud update with a bit
// cube instead of hash sets (ray_update.h).
#include "ray_update.h"

#include <algorithm>

namespace dslam::dense {

namespace {
constexpr size_t kMaxCubeBytes = size_t{64} << 20;
uint64_t pack(const octomap::OcTreeKey& k) { return (uint64_t{k[0]} << 32) | (uint64_t{k[1]} << 16) | uint64_t{k[2]}; }
}  // namespace

VoxelKeySet::VoxelKeySet(int half) : half_(std::max(half, 0)), side_(2 * static_cast<size_t>(half_) + 1) {
  const size_t cells = side_ * side_ * side_;
  if (cells / 8 <= kMaxCubeBytes) bits_.resize((cells + 63) / 64);
}

void VoxelKeySet::reset(const octomap::OcTreeKey& centre) {
  centre_ = centre;
  std::fill(bits_.begin(), bits_.end(), 0);
  hashed_.clear();
}

bool VoxelKeySet::index(const octomap::OcTreeKey& k, size_t& i) const {
  if (bits_.empty()) return false;
  size_t c[3];
  for (int a = 0; a < 3; a++) {
    const int d = static_cast<int>(k[a]) - static_cast<int>(centre_[a]) + half_;
    if (d < 0 || d >= static_cast<int>(side_)) return false;
    c[a] = static_cast<size_t>(d);
  }
  i = (c[0] * side_ + c[1]) * side_ + c[2];
  return true;
}

bool VoxelKeySet::insert(const octomap::OcTreeKey& k) {
  size_t i;
  if (!index(k, i)) return hashed_.insert(pack(k)).second;
  uint64_t& w = bits_[i >> 6];
  const uint64_t m = uint64_t{1} << (i & 63);
  if (w & m) return false;
  w |= m;
  return true;
}

bool VoxelKeySet::contains(const octomap::OcTreeKey& k) const {
  size_t i;
  if (!index(k, i)) return hashed_.count(pack(k)) > 0;
  return (bits_[i >> 6] >> (i & 63)) & 1;
}

void discreteRayUpdate(const octomap::OcTree& tree, const octomap::Pointcloud& cloud, const octomap::point3d& origin,
                       double max_range, VoxelKeySet& seen, VoxelKeySet& occupied, RayUpdate& out) {
  out.free.clear();
  out.occupied.clear();
  const octomap::OcTreeKey centre = tree.coordToKey(origin);
  seen.reset(centre);
  occupied.reset(centre);
  std::vector<octomap::point3d> ends;  // one per voxel hit, its centre (computeDiscreteUpdate)
  ends.reserve(cloud.size() / 4);
  for (size_t i = 0; i < cloud.size(); i++) {
    const octomap::OcTreeKey k = tree.coordToKey(cloud[i]);
    if (seen.insert(k)) ends.push_back(tree.keyToCoord(k));
  }
  std::vector<char> in_range(ends.size(), 0);
  for (size_t i = 0; i < ends.size(); i++) {
    if ((ends[i] - origin).norm() > max_range) continue;
    in_range[i] = 1;
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(ends[i], key) && occupied.insert(key)) out.occupied.push_back(key);
  }
  seen.reset(centre);  // from here on: the free keys
  octomap::KeyRay ray;
  for (size_t i = 0; i < ends.size(); i++) {
    const octomap::point3d end =
        in_range[i] ? ends[i] : origin + (ends[i] - origin).normalized() * static_cast<float>(max_range);
    if (!tree.computeRayKeys(origin, end, ray)) continue;
    for (const octomap::OcTreeKey& k : ray)
      if (!occupied.contains(k) && seen.insert(k)) out.free.push_back(k);
  }
}

}  // namespace dslam::dense
