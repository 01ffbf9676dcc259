#include "dslam/map/keyframe.h"

#include <algorithm>
#include <cmath>

#include "dslam/map/map.h"

namespace dslam {

ScaleLevels ScaleLevels::make(int n, float f) {
  ScaleLevels s;
  s.n_levels = n;
  s.scale_factor = f;
  s.log_scale_factor = std::log(f);
  s.scale.resize(n);
  s.inv_scale.resize(n);
  s.sigma2.resize(n);
  s.inv_sigma2.resize(n);
  float sc = 1.f;
  for (int i = 0; i < n; i++) {
    s.scale[i] = sc;
    s.inv_scale[i] = 1.f / sc;
    s.sigma2[i] = sc * sc;
    s.inv_sigma2[i] = 1.f / (sc * sc);
    sc *= f;
  }
  return s;
}

KeyFrame::KeyFrame(int64_t id_, const Frame& f, const SE3& T_cw, const CameraIntrinsics& c,
                   std::shared_ptr<const ScaleLevels> sc, Map* m)
    : id(id_),
      frame_index(f.index()),
      timestamp(f.timestamp()),
      map(m),
      keys_un(f.keypoints_un),
      descriptors(f.descriptors.clone()),
      depth(f.depth),
      u_right(f.u_right),
      meta(f.meta),
      cam(c),
      scale(std::move(sc)),
      grid(f.keypoints_un, c.bounds),
      points(f.keypoints_un.size()) {
  setPose(T_cw);
}

void KeyFrame::erasePoint(const MapPoint* p) {
  for (auto& q : points)
    if (q.get() == p) q.reset();
}

std::vector<MapPointPtr> KeyFrame::validPoints() const {
  std::vector<MapPointPtr> out;
  for (const auto& p : points)
    if (p && !p->bad) out.push_back(p);
  return out;
}

int KeyFrame::trackedPoints(int min_obs) const {
  int n = 0;
  for (const auto& p : points)
    if (p && !p->bad && (min_obs <= 0 || p->numObservations() >= min_obs)) n++;
  return n;
}

bool KeyFrame::unprojectStereo(size_t i, Eigen::Vector3d& Xw) const {
  if (i >= depth.size() || depth[i] <= 0) return false;
  const float z = depth[i];
  Xw = T_wc_ * backProject(cam, keys_un[i].pt, z);
  return true;
}

float KeyFrame::sceneMedianDepth() const {
  std::vector<float> zs;
  const Eigen::Vector3d r2 = T_cw_.rotation().row(2).transpose();
  const double tz = T_cw_.translation().z();
  for (const auto& p : points)
    if (p && !p->bad) zs.push_back(static_cast<float>(r2.dot(p->pos) + tz));
  if (zs.empty()) return 0.f;
  std::nth_element(zs.begin(), zs.begin() + zs.size() / 2, zs.end());
  return zs[zs.size() / 2];
}

void KeyFrame::addConnection(KeyFrame* kf, int w) {
  auto it = conn_.find(kf->id);
  if (it != conn_.end() && it->second.second == w) return;
  conn_[kf->id] = {kf, w};
  updateBestCovisibles();
}

void KeyFrame::eraseConnection(KeyFrame* kf) {
  if (conn_.erase(kf->id)) updateBestCovisibles();
}

void KeyFrame::updateBestCovisibles() {
  std::vector<std::pair<int, KeyFrame*>> v;
  v.reserve(conn_.size());
  for (const auto& [id_, c] : conn_) v.emplace_back(c.second, c.first);
  // Highest weight first; ties by id for determinism.
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second->id < b.second->id;
  });
  ordered_conn_.clear();
  ordered_weights_.clear();
  for (auto& e : v) {
    ordered_conn_.push_back(e.second);
    ordered_weights_.push_back(e.first);
  }
}

std::vector<KeyFrame*> KeyFrame::bestCovisibles(size_t n) const {
  if (ordered_conn_.size() <= n) return ordered_conn_;
  return std::vector<KeyFrame*>(ordered_conn_.begin(), ordered_conn_.begin() + n);
}

std::vector<KeyFrame*> KeyFrame::covisiblesByWeight(int w) const {
  std::vector<KeyFrame*> out;
  for (size_t i = 0; i < ordered_conn_.size() && ordered_weights_[i] >= w; i++) out.push_back(ordered_conn_[i]);
  return out;
}

int KeyFrame::weight(const KeyFrame* kf) const {
  auto it = conn_.find(kf->id);
  return it == conn_.end() ? 0 : it->second.second;
}

void KeyFrame::updateConnections() {
  std::map<int64_t, std::pair<KeyFrame*, int>> counter;
  for (const auto& p : points) {
    if (!p || p->bad) continue;
    for (const auto& [kid, o] : p->observations()) {
      if (kid == id || o.first->bad) continue;
      auto& c = counter[kid];
      c.first = o.first;
      c.second++;
    }
  }
  if (counter.empty()) return;
  constexpr int kTh = 15;
  int nmax = 0;
  KeyFrame* kfmax = nullptr;
  std::map<int64_t, std::pair<KeyFrame*, int>> kept;
  for (const auto& [kid, c] : counter) {
    if (c.second > nmax) {
      nmax = c.second;
      kfmax = c.first;
    }
    if (c.second >= kTh) {
      kept[kid] = c;
      c.first->addConnection(this, c.second);
    }
  }
  if (kept.empty() && kfmax) {
    kept[kfmax->id] = {kfmax, nmax};
    kfmax->addConnection(this, nmax);
  }
  conn_ = kept;
  updateBestCovisibles();
  if (first_connection_ && id != map->origin()->id && !ordered_conn_.empty()) {
    parent = ordered_conn_.front();
    parent->children[id] = this;
    first_connection_ = false;
  }
}

void KeyFrame::changeParent(KeyFrame* p) {
  if (parent) parent->children.erase(id);
  parent = p;
  if (p) p->children[id] = this;
}

void KeyFrame::setBad() {
  if (bad || (map && map->origin() && map->origin()->id == id)) return;
  for (const auto& [kid, c] : conn_) c.first->eraseConnection(this);
  for (size_t i = 0; i < points.size(); i++)
    if (points[i]) {
      auto p = points[i];
      points[i].reset();
      p->eraseObservation(this);
    }
  conn_.clear();
  ordered_conn_.clear();
  ordered_weights_.clear();

  // Update the spanning tree: reassign children to the covisible candidate
  // parent with the highest weight (ORB-SLAM KeyFrame::SetBadFlag).
  std::map<int64_t, KeyFrame*> candidates;
  if (parent) candidates[parent->id] = parent;
  while (!children.empty()) {
    bool found = false;
    int best_w = -1;
    KeyFrame *best_child = nullptr, *best_parent = nullptr;
    for (const auto& [cid, child] : children) {
      if (child->bad) continue;
      for (KeyFrame* cov : child->covisibles()) {
        if (!candidates.count(cov->id)) continue;
        const int w = child->weight(cov);
        if (w > best_w) {
          best_w = w;
          best_child = child;
          best_parent = cov;
          found = true;
        }
      }
    }
    if (!found) break;
    best_child->changeParent(best_parent);
    candidates[best_child->id] = best_child;
    children.erase(best_child->id);
  }
  for (const auto& [cid, child] : std::map<int64_t, KeyFrame*>(children)) child->changeParent(parent);
  children.clear();
  if (parent) {
    parent->children.erase(id);
    T_cp = T_cw_ * parent->T_wc();
  }
  bad = true;
  if (map) map->eraseKeyFrame(this);
}

}  // namespace dslam
