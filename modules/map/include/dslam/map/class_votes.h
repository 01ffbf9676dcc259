#pragma once
/** \file class_votes.h
 *  Label fusion of map points across keyframes (ours, beyond
 *  Changing-SLAM): how many keyframes labelled each map point's keypoint
 *  with each class. A keyframe whose detector missed an object labels that
 *  object's keypoints with the class of a box behind it (a plant in front of
 *  a refrigerator, the plant's box missed); with the votes, a point labelled
 *  plant by most keyframes stays the plant's. Kept by the object
 *  persistence filter (option `label_votes`), not saved with the atlas: a
 *  loaded map's points start without votes. */
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

namespace dslam {

class KeyFrame;
class MapPoint;
struct LtdaParams;
struct ObjectCandidate;

class PointClassVotes {
 public:
  /** Counts the classes `kf` gives its map points' keypoints (object
   *  classes of `p` only, dynamic keypoints left out). Call once per keyframe. */
  void add(const KeyFrame& kf, const LtdaParams& p);
  /** The class of `mp` by the votes: the class most keyframes gave it when
   *  it has strictly more votes than `now` (the class it is labelled with
   *  in the keyframe at hand, or the one it was created with), else `now`. */
  int classOf(const MapPoint& mp, int now) const;
  /** Votes of `mp` for class `c`. */
  int votes(const MapPoint& mp, int c) const;
  /** Drops the entries of points gone (bad or freed). */
  void prune();
  size_t size() const { return votes_.size(); }

 private:
  struct Entry {
    std::weak_ptr<MapPoint> point;
    std::vector<std::pair<int, int>> counts;  ///< (class, keyframes), few entries
  };
  std::unordered_map<int64_t, Entry> votes_;  ///< by point id (ids are never reused)
  size_t pruned_size_ = 0;  ///< size after the last prune
};

/** objectCandidates (map_object.h) with label fusion: records the labels
 *  of `kf` in `votes`; a map point whose votes overrule the class it has in
 *  `kf` (or was created with; PointClassVotes::classOf) is left out of the
 *  candidates, so it stays in the object it is in, or, with `follow_votes`,
 *  joins the candidates of the class the votes give it, with no instance id
 *  (clustered), not counted as labelled in `kf`. */
std::vector<ObjectCandidate> objectCandidates(const KeyFrame& kf, const LtdaParams& p,
                                             std::vector<ObjectCandidate>* small, PointClassVotes& votes,
                                             bool follow_votes = false);

}  // namespace dslam
