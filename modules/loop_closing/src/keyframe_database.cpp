#include "dslam/loop_closing/keyframe_database.h"

#include <algorithm>

#include "dslam/map/map.h"

namespace dslam {

KeyFrameDatabase::KeyFrameDatabase(std::shared_ptr<const Vocabulary> voc) : voc_(std::move(voc)), db_(*voc_) {}

void KeyFrameDatabase::computeBow(const cv::Mat& descriptors, BowVector& bow, FeatureVector& feat,
                                  const std::vector<char>* use) const {
  if (descriptors.empty()) {
    bow.clear();
    feat.clear();
    return;
  }
  if (descriptors.type() != CV_8U || descriptors.cols != 32 || !descriptors.isContinuous()) {
    voc_->transform(descriptors, bow, feat, std::max(1, voc_->levels() - 2));  // reports the problem
    return;
  }
  voc_->transform(descriptors.ptr<uint8_t>(), static_cast<size_t>(descriptors.rows), descriptors.step[0], bow, &feat,
                  std::max(1, voc_->levels() - 2), use);
}

void KeyFrameDatabase::computeBow(KeyFrame* kf) const {
  if (!kf->bow.empty()) return;
  std::vector<char> use(kf->size(), 1);
  bool all = true;
  for (size_t i = 0; i < kf->size(); i++) {
    const MapPointPtr& mp = kf->points[i];
    use[i] = kf->usable(i) && !(mp && !mp->active);
    all &= use[i] != 0;
  }
  computeBow(kf->descriptors, kf->bow, kf->feat, all ? nullptr : &use);
}

void KeyFrameDatabase::add(KeyFrame* kf) {
  std::lock_guard<std::mutex> lk(mtx_);
  if (kfs_.count(kf->id)) return;
  db_.add(kf->id, kf->bow);
  kfs_[kf->id] = kf;
}

void KeyFrameDatabase::erase(KeyFrame* kf) {
  std::lock_guard<std::mutex> lk(mtx_);
  if (kfs_.erase(kf->id)) db_.erase(kf->id);
}

void KeyFrameDatabase::clear() {
  std::lock_guard<std::mutex> lk(mtx_);
  db_.clear();
  kfs_.clear();
}

size_t KeyFrameDatabase::size() const {
  std::lock_guard<std::mutex> lk(mtx_);
  return kfs_.size();
}

std::vector<KeyFrame*> KeyFrameDatabase::groupAccumulate(const std::vector<std::pair<KeyFrame*, double>>& scored,
                                                         const std::function<bool(KeyFrame*)>& keep) const {
  std::map<int64_t, double> score_of;
  for (const auto& [kf, sc] : scored) score_of[kf->id] = sc;
  std::vector<std::pair<double, KeyFrame*>> acc;
  double best_acc = 0;
  for (const auto& [kf, sc] : scored) {
    double a = sc;
    double best = sc;
    KeyFrame* best_kf = kf;
    for (KeyFrame* nb : kf->bestCovisibles(10)) {
      auto it = score_of.find(nb->id);
      if (it == score_of.end() || !keep(nb)) continue;
      a += it->second;
      if (it->second > best) {
        best = it->second;
        best_kf = nb;
      }
    }
    acc.emplace_back(a, best_kf);
    best_acc = std::max(best_acc, a);
  }
  std::vector<KeyFrame*> out;
  std::map<int64_t, bool> seen;
  for (const auto& [a, kf] : acc)
    if (a > 0.75 * best_acc && !seen[kf->id]) {
      seen[kf->id] = true;
      out.push_back(kf);
    }
  return out;
}

std::vector<KeyFrame*> KeyFrameDatabase::detectLoopCandidates(KeyFrame* kf, double min_score, bool same_map) const {
  std::lock_guard<std::mutex> lk(mtx_);
  std::map<int64_t, bool> connected;
  for (const auto& [id, c] : kf->connections()) connected[id] = true;
  auto keep = [&](KeyFrame* o) {
    if (o->bad || o->id == kf->id || connected.count(o->id)) return false;
    return same_map ? o->map == kf->map : o->map != kf->map;
  };
  BowCandidateParams bp;
  bp.min_common_ratio = 0.8;
  bp.min_score = min_score;
  const BowCandidates c = db_.candidates(kf->bow, bp, [&](BowEntryId id) {
    auto it = kfs_.find(id);
    return it != kfs_.end() && keep(it->second);
  });
  std::vector<std::pair<KeyFrame*, double>> scored;
  for (const auto& m : c.matches) scored.emplace_back(kfs_.at(m.id), m.score);
  return groupAccumulate(scored, keep);
}

std::vector<KeyFrame*> KeyFrameDatabase::detectRelocalizationCandidates(const BowVector& bow, const Map* map) const {
  std::lock_guard<std::mutex> lk(mtx_);
  auto keep = [&](KeyFrame* o) { return !o->bad && (!map || o->map == map); };
  BowCandidateParams bp;
  bp.min_common_ratio = 0.8;
  const BowCandidates c = db_.candidates(bow, bp, [&](BowEntryId id) {
    auto it = kfs_.find(id);
    return it != kfs_.end() && keep(it->second);
  });
  std::vector<std::pair<KeyFrame*, double>> scored;
  for (const auto& m : c.matches) scored.emplace_back(kfs_.at(m.id), m.score);
  return groupAccumulate(scored, keep);
}

}  // namespace dslam
