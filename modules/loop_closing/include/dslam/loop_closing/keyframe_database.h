#pragma once
/** \file keyframe_database.h
 *  Keyframes indexed by their bag of words (ORB-SLAM KeyFrameDatabase) over
 *  dslam::BowDatabase: loop candidates (with covisibility-group score
 *  accumulation) and relocalisation candidates. One database serves all maps
 *  of an atlas, so a loop candidate in another map means "merge". */
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "dslam/map/keyframe.h"
#include "dslam/place_recognition/bow_database.h"
#include "dslam/place_recognition/vocabulary.h"

namespace dslam {

class KeyFrameDatabase {
 public:
  explicit KeyFrameDatabase(std::shared_ptr<const Vocabulary> voc);

  const Vocabulary& vocabulary() const { return *voc_; }
  /** Fills kf->bow / kf->feat (levelsup = levels - 2, ORB-SLAM's depth-2 grouping). */
  /** Bag of words of a keyframe from the keypoints that may take part in
   *  place recognition: not dynamic, and without an inactive map point
   *  (people and moved objects do not vote). */
  void computeBow(KeyFrame* kf) const;
  /** Bag of words of descriptors; with `use`, only rows i with use[i] != 0. */
  void computeBow(const cv::Mat& descriptors, BowVector& bow, FeatureVector& feat,
                  const std::vector<char>* use = nullptr) const;

  void add(KeyFrame* kf);
  void erase(KeyFrame* kf);
  void clear();
  size_t size() const;

  /** ORB-SLAM DetectLoopCandidates: keyframes not connected to kf sharing
   *  >= 80% of the best shared-word count, scoring >= min_score, grouped with
   *  their 10 best covisibles; groups scoring >= 75% of the best group give
   *  their best keyframe. `same_map` restricts to kf's map (true) or to the
   *  other maps (false, merge candidates). */
  std::vector<KeyFrame*> detectLoopCandidates(KeyFrame* kf, double min_score, bool same_map) const;
  /** ORB-SLAM DetectRelocalizationCandidates (restricted to `map` if given). */
  std::vector<KeyFrame*> detectRelocalizationCandidates(const BowVector& bow, const Map* map) const;

 private:
  std::vector<KeyFrame*> groupAccumulate(const std::vector<std::pair<KeyFrame*, double>>& scored,
                                         const std::function<bool(KeyFrame*)>& keep) const;
  std::shared_ptr<const Vocabulary> voc_;
  BowDatabase db_;
  mutable std::mutex mtx_;
  std::map<int64_t, KeyFrame*> kfs_;
};

}  // namespace dslam
