#include "dslam/map/map_object.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <tuple>

#include <Eigen/Geometry>

#include "dslam/core/descriptor.h"
#include "dslam/map/class_votes.h"
#include "dslam/map/keyframe.h"

namespace dslam {

namespace {

/** The mean of the points within `r` of `m`, their per-axis median (`m`
 *  itself when none is). */
Eigen::Vector3d meanNear(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& m, double r) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  size_t n = 0;
  for (const auto& x : pts)
    if ((x - m).squaredNorm() <= r * r) {
      sum += x;
      n++;
    }
  return n ? Eigen::Vector3d(sum / static_cast<double>(n)) : m;
}

}  // namespace

size_t MapObject::refresh() {
  std::map<int64_t, MapPointPtr> alive;
  for (const auto& [pid, p] : points) {
    MapPointPtr q = MapPoint::resolve(p);
    if (q && !q->bad && (q->map_object < 0 || q->map_object == id)) alive[q->id] = q;  // not taken by another
  }
  points = std::move(alive);
  std::vector<Eigen::Vector3d> xs;
  xs.reserve(points.size());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& [id, p] : points) {
    xs.push_back(p->pos);
    sum += p->pos;
  }
  Eigen::Vector3d median;
  robustBox(xs, box_min, box_max, 0.05, centroid_radius > 0 ? &median : nullptr);  // sorts each axis once
  if (!xs.empty()) centroid = centroid_radius > 0 ? meanNear(xs, median, centroid_radius)
                                                 : Eigen::Vector3d(sum / static_cast<double>(xs.size()));
  return points.size();
}

void MapObject::setActive(bool a) {
  active = a;
  for (const auto& [id, p] : points) p->active = a;
}

void MapObject::addPoint(const MapPointPtr& mp) {
  points[mp->id] = mp;
  mp->map_object = id;
  mp->active = active;
}

void robustBox(const std::vector<Eigen::Vector3d>& pts, Eigen::Vector3d& lo, Eigen::Vector3d& hi, double fraction,
               Eigen::Vector3d* median) {
  lo.setZero();
  hi.setZero();
  if (median) median->setZero();
  if (pts.empty()) return;
  const size_t n = pts.size();
  const size_t k = std::max<size_t>(1, static_cast<size_t>(std::lround(fraction * static_cast<double>(n))));
  std::vector<double> v(n);
  for (int a = 0; a < 3; a++) {
    for (size_t i = 0; i < n; i++) v[i] = pts[i][a];
    std::sort(v.begin(), v.end());
    // Median of the k smallest and of the k largest.
    lo[a] = k % 2 ? v[k / 2] : 0.5 * (v[k / 2 - 1] + v[k / 2]);
    hi[a] = k % 2 ? v[n - 1 - k / 2] : 0.5 * (v[n - k / 2] + v[n - 1 - k / 2]);
    if (median) (*median)[a] = n % 2 ? v[n / 2] : 0.5 * (v[n / 2] + v[n / 2 - 1]);
  }
}

namespace {

/** Single-linkage clusters of `idx` (positions into pts) with radius r. */
std::vector<std::vector<size_t>> clusters(const std::vector<Eigen::Vector3d>& pts, double r) {
  const size_t n = pts.size();
  std::vector<int> comp(n, -1);
  std::vector<std::vector<size_t>> out;
  for (size_t s = 0; s < n; s++) {
    if (comp[s] >= 0) continue;
    const int c = static_cast<int>(out.size());
    out.push_back({s});
    comp[s] = c;
    for (size_t q = 0; q < out[c].size(); q++) {
      const size_t a = out[c][q];
      for (size_t b = 0; b < n; b++)
        if (comp[b] < 0 && (pts[a] - pts[b]).squaredNorm() <= r * r) {
          comp[b] = c;
          out[c].push_back(b);
        }
    }
    std::sort(out[c].begin(), out[c].end());
  }
  return out;
}

}  // namespace

bool isObjectClass(int c, const LtdaParams& p) {
  if (c < 0) return false;
  if (std::find(p.ignore_classes.begin(), p.ignore_classes.end(), c) != p.ignore_classes.end()) return false;
  if (p.classes.empty()) return c <= kLastCocoThing;  // stuff (walls, floor) makes no objects
  return std::find(p.classes.begin(), p.classes.end(), c) != p.classes.end();
}

namespace {

std::vector<ObjectCandidate> candidatesOf(const KeyFrame& kf, const LtdaParams& p, std::vector<ObjectCandidate>* small,
                                          const PointClassVotes* votes, bool follow_votes) {
  // (class, instance) -> keypoint indices, in keypoint order.
  std::map<std::pair<int, int>, std::vector<size_t>> groups;
  std::vector<char> labelled_now(kf.points.size(), 0);  // its class from this keyframe's labels
  for (size_t i = 0; i < kf.points.size(); i++) {
    const MapPointPtr& mp = kf.points[i];
    if (!mp || mp->bad) continue;
    int c = -1, inst = -1;
    if (i < kf.meta.size() && kf.meta[i].label != KpLabel::Dynamic) {
      c = kf.meta[i].class_id;
      inst = kf.meta[i].object_id;
      labelled_now[i] = c >= 0;
    }
    if (c < 0) {  // the class the point was created with
      c = mp->class_id;
      inst = mp->object_id;
    }
    if (votes) {  // most keyframes gave it another class: left out, or that class (no instance of this keyframe)
      const int v = votes->classOf(*mp, c);
      if (v != c) {
        if (!follow_votes) continue;
        c = v;
        inst = -1;
        labelled_now[i] = 0;
      }
    }
    if (!isObjectClass(c, p) || mp->label == KpLabel::Dynamic) continue;
    groups[{c, inst}].push_back(i);
  }
  std::vector<ObjectCandidate> out;
  auto emit = [&](int c, int inst, std::vector<size_t> idx) {
    const bool too_small = static_cast<int>(idx.size()) < p.min_points;
    if (too_small && !small) return;
    if (too_small) {  // a small view counts only with this keyframe's labels (a detection now)
      idx.erase(std::remove_if(idx.begin(), idx.end(), [&](size_t i) { return !labelled_now[i]; }), idx.end());
      if (idx.empty()) return;
    }
    ObjectCandidate cand;
    cand.class_id = c;
    cand.source_id = inst;
    float x0 = std::numeric_limits<float>::max(), y0 = x0, x1 = -x0, y1 = -x0;
    for (size_t i : idx) {
      cand.points.push_back(kf.points[i]);
      cand.centroid += kf.points[i]->pos;
      const cv::Point2f& u = kf.keys_un[i].pt;
      x0 = std::min(x0, u.x);
      y0 = std::min(y0, u.y);
      x1 = std::max(x1, u.x);
      y1 = std::max(y1, u.y);
    }
    cand.centroid /= static_cast<double>(idx.size());
    cand.box = cv::Rect2f(x0, y0, x1 - x0, y1 - y0);
    (too_small ? *small : out).push_back(std::move(cand));
  };
  for (const auto& [key, idx] : groups) {
    std::vector<Eigen::Vector3d> xs;
    for (size_t i : idx) xs.push_back(kf.points[i]->pos);
    auto cls = clusters(xs, p.cluster_m);
    if (key.second >= 0 && cls.size() > 1) {  // one instance: its largest cluster (stray points left out)
      size_t best = 0;
      for (size_t k = 1; k < cls.size(); k++)
        if (cls[k].size() > cls[best].size()) best = k;
      cls = {cls[best]};
    }
    for (const auto& cl : cls) {
      std::vector<size_t> sub;
      for (size_t k : cl) sub.push_back(idx[k]);
      emit(key.first, key.second, sub);
    }
  }
  return out;
}

}  // namespace

std::vector<ObjectCandidate> objectCandidates(const KeyFrame& kf, const LtdaParams& p,
                                             std::vector<ObjectCandidate>* small) {
  return candidatesOf(kf, p, small, nullptr, false);
}

std::vector<ObjectCandidate> objectCandidates(const KeyFrame& kf, const LtdaParams& p, std::vector<ObjectCandidate>* small,
                                             PointClassVotes& votes, bool follow_votes) {
  votes.add(kf, p);
  return candidatesOf(kf, p, small, &votes, follow_votes);
}

namespace {

/** Recomputes a candidate's centroid from its points' current positions
 *  (bad points dropped); false if none is left. */
bool refreshCandidate(ObjectCandidate& c) {
  c.points.erase(std::remove_if(c.points.begin(), c.points.end(), [](const MapPointPtr& mp) { return !mp || mp->bad; }),
                 c.points.end());
  if (c.points.empty()) return false;
  c.centroid.setZero();
  for (const auto& mp : c.points) c.centroid += mp->pos;
  c.centroid /= static_cast<double>(c.points.size());
  return true;
}

}  // namespace

std::vector<ObjectCandidate> SmallCandidatePool::add(std::vector<ObjectCandidate> small, int64_t map_id, int64_t kf_id,
                                                     int keyframes, const LtdaParams& p) {
  std::vector<ObjectCandidate> out;
  // Only this map's points are read (the caller holds its lock); views of
  // other maps just age.
  kept_.erase(std::remove_if(kept_.begin(), kept_.end(),
                             [&](Kept& k) {
                               return kf_id - k.last_kf > keyframes || (k.map_id == map_id && !refreshCandidate(k.cand));
                             }),
              kept_.end());
  for (ObjectCandidate& c : small) {
    if (!refreshCandidate(c)) continue;
    Kept* best = nullptr;
    double best_d = p.threshold_m;
    for (Kept& k : kept_) {
      if (k.map_id != map_id || k.cand.class_id != c.class_id || k.last_kf == kf_id) continue;
      const double d = (k.cand.centroid - c.centroid).norm();
      if (d < best_d) best_d = d, best = &k;
    }
    if (!best) {
      kept_.push_back({std::move(c), map_id, kf_id});
      continue;
    }
    for (auto& mp : c.points)
      if (std::find(best->cand.points.begin(), best->cand.points.end(), mp) == best->cand.points.end())
        best->cand.points.push_back(mp);
    best->cand.box = c.box;  // the latest view
    best->cand.source_id = c.source_id;
    best->last_kf = kf_id;
    refreshCandidate(best->cand);
    if (static_cast<int>(best->cand.points.size()) >= p.min_points) {
      out.push_back(std::move(best->cand));
      kept_.erase(kept_.begin() + (best - kept_.data()));
    }
  }
  return out;
}

void SmallCandidatePool::clear(int64_t map_id) {
  kept_.erase(std::remove_if(kept_.begin(), kept_.end(), [&](const Kept& k) { return k.map_id == map_id; }),
              kept_.end());
}

std::vector<LtdaMatch> associateObjects(std::map<int64_t, MapObjectPtr>& objects,
                                        const std::vector<ObjectCandidate>& candidates, int64_t kf_id, double t,
                                        const LtdaParams& p, int64_t& next_id) {
  std::vector<LtdaMatch> out(candidates.size());
  // Every (distance, candidate, object) pair within the threshold, nearest
  // first; objects bucketed by class and a grid of threshold-sized cells, so
  // the cost grows linearly with the number of objects.
  const double cell = std::max(p.threshold_m, 1e-6);
  auto cellOf = [cell](double v) { return static_cast<int64_t>(std::floor(v / cell)); };
  std::map<std::tuple<int, int64_t, int64_t, int64_t>, std::vector<const MapObject*>> grid;
  for (const auto& [id, o] : objects)
    if (p.dormant_by_distance || !o->dormant)  // else a dormant object is found by shared points only
      grid[{o->class_id, cellOf(o->centroid.x()), cellOf(o->centroid.y()), cellOf(o->centroid.z())}].push_back(o.get());
  // (rank, distance, candidate, object): rank 0 = the candidate shares map
  // points with the object (its points were tracked and already belong to
  // it: the same object whatever part of it this view shows), ranked by
  // the share; rank 1 = centroid distance only (Algorithm 1).
  std::vector<std::tuple<int, double, size_t, int64_t>> pairs;
  for (size_t c = 0; c < candidates.size(); c++) {
    std::map<int64_t, int> shared;
    for (const auto& mp : candidates[c].points)
      if (mp && mp->map_object >= 0) shared[mp->map_object]++;
    for (const auto& [id, n] : shared) {
      auto it = objects.find(id);
      if (it == objects.end() || it->second->class_id != candidates[c].class_id) continue;
      if (static_cast<size_t>(n) < std::max<size_t>(p.min_shared_points, 1)) continue;
      pairs.emplace_back(-n, (it->second->centroid - candidates[c].centroid).norm(), c, id);
    }
  }
  for (size_t c = 0; c < candidates.size(); c++) {
    const Eigen::Vector3d& x = candidates[c].centroid;
    const int64_t cx = cellOf(x.x()), cy = cellOf(x.y()), cz = cellOf(x.z());
    for (int64_t i = cx - 1; i <= cx + 1; i++)
      for (int64_t j = cy - 1; j <= cy + 1; j++)
        for (int64_t k = cz - 1; k <= cz + 1; k++) {
          auto it = grid.find({candidates[c].class_id, i, j, k});
          if (it == grid.end()) continue;
          for (const MapObject* o : it->second) {
            const double d = (o->centroid - x).norm();
            if (d < p.threshold_m) pairs.emplace_back(1, d, c, o->id);
          }
        }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<char> used_c(candidates.size(), 0);
  std::map<int64_t, char> used_o;
  for (const auto& [rank, d, c, id] : pairs) {
    if (used_c[c] || used_o[id]) continue;
    used_c[c] = 1;
    used_o[id] = 1;
    const MapObject& o = *objects.at(id);
    out[c] = {c, id, false, d, o.last_seen_kf, o.last_seen_t};
  }
  std::set<MapObject*> left;  // objects whose points went to another
  for (size_t c = 0; c < candidates.size(); c++) {
    const ObjectCandidate& cand = candidates[c];
    MapObjectPtr o;
    if (used_c[c]) {
      o = objects.at(out[c].object);
    } else {
      o = std::make_shared<MapObject>();
      o->id = next_id++;
      o->class_id = cand.class_id;
      o->first_seen_kf = kf_id;
      o->first_seen_t = t;
      o->first_box = cand.box;
      o->centroid_radius = p.centroid_radius;
      objects[o->id] = o;
      out[c] = {c, o->id, true, 0.0, -1, 0.0};
    }
    for (const auto& mp : cand.points) {
      if (mp->map_object >= 0 && mp->map_object != o->id)  // it leaves the object it was in
        if (auto it = objects.find(mp->map_object); it != objects.end() && it->second->points.erase(mp->id))
          left.insert(it->second.get());
      o->addPoint(mp);
    }
    o->last_seen_kf = kf_id;
    o->last_seen_t = t;
    o->current_box = cand.box;
    o->sightings++;
    o->refresh();
  }
  for (MapObject* o : left) o->refresh();
  return out;
}

size_t dropMissedObjectPoints(std::vector<ObjectCandidate>& candidates,
                              const std::map<int64_t, MapObjectPtr>& objects, int64_t kf_id,
                              const std::function<bool(int, const cv::Rect2f&)>& detected,
                              const MissedObjectParams& p, int min_points) {
  if (p.recent_keyframes <= 0 || candidates.empty()) return 0;
  std::vector<const MapObject*> recent;  // established objects seen lately
  for (const auto& [id, op] : objects) {
    const MapObject& o = *op;
    if (o.active && !o.dormant && o.sightings >= p.min_sightings && o.last_seen_kf >= 0 && o.last_seen_kf < kf_id &&
        kf_id - o.last_seen_kf <= p.recent_keyframes && !o.points.empty())
      recent.push_back(&o);
  }
  if (recent.empty()) return 0;
  const double r2 = p.radius_m * p.radius_m;
  size_t dropped = 0;
  for (ObjectCandidate& c : candidates) {
    std::vector<char> drop(c.points.size(), 0);
    for (const MapObject* b : recent) {
      if (b->class_id == c.class_id) continue;
      std::vector<size_t> of_b;  // candidate points that are B's, or next to B's
      size_t held = 0;
      for (size_t k = 0; k < c.points.size(); k++) {
        const MapPointPtr& mp = c.points[k];
        if (mp->map_object == b->id && b->points.count(mp->id)) {
          held++;
          of_b.push_back(k);
          continue;
        }
        if (r2 <= 0) continue;
        for (const auto& [id, q] : b->points)
          if (q && !q->bad && (q->pos - mp->pos).squaredNorm() <= r2) {
            of_b.push_back(k);
            break;
          }
      }
      if (of_b.empty() || static_cast<double>(held) >= p.max_fraction * static_cast<double>(b->numPoints())) continue;
      if (detected(b->class_id, c.box)) continue;  // B detected there: not missed
      for (size_t k : of_b) drop[k] = 1;
    }
    size_t kept = 0;
    for (size_t k = 0; k < c.points.size(); k++)
      if (!drop[k]) c.points[kept++] = c.points[k];
    if (kept == c.points.size()) continue;
    dropped += c.points.size() - kept;
    c.points.resize(kept);
    refreshCandidate(c);  // its centroid (none left: erased below)
  }
  candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                  [&](const ObjectCandidate& c) { return static_cast<int>(c.points.size()) < min_points; }),
                   candidates.end());
  return dropped;
}

std::vector<std::pair<int64_t, int64_t>> mergeOverlappingObjects(std::map<int64_t, MapObjectPtr>& objects,
                                                                 const std::function<bool(const MapObject&)>& eligible,
                                                                 size_t min_points) {
  std::vector<std::pair<int64_t, int64_t>> merges;
  for (auto a = objects.begin(); a != objects.end(); ++a) {
    MapObject& A = *a->second;
    if (A.numPoints() < min_points || !eligible(A)) continue;
    for (auto b = std::next(a); b != objects.end();) {
      MapObject& B = *b->second;
      if (B.class_id != A.class_id || B.numPoints() < min_points || !eligible(B) ||
          !(A.contains(B.centroid) || B.contains(A.centroid))) {
        ++b;
        continue;
      }
      for (const auto& [id, mp] : B.points) A.addPoint(mp);
      A.sightings += B.sightings;
      A.belief = std::max(A.belief, B.belief);
      if (B.first_seen_kf >= 0 && (A.first_seen_kf < 0 || B.first_seen_t < A.first_seen_t)) {
        A.first_seen_kf = B.first_seen_kf;
        A.first_seen_t = B.first_seen_t;
        A.first_box = B.first_box;
      }
      if (B.last_seen_t > A.last_seen_t) {
        A.last_seen_kf = B.last_seen_kf;
        A.last_seen_t = B.last_seen_t;
        A.current_box = B.current_box;
      }
      A.refresh();
      merges.emplace_back(A.id, B.id);
      b = objects.erase(b);
    }
  }
  return merges;
}

ReidAppearance reidAppearance(const MapObject& old) {
  ReidAppearance app;
  for (const auto& [id, q] : old.points)
    if (q && !q->bad) app.points.push_back(q.get());
  for (size_t j = 0; j < app.points.size(); j++)
    for (const uint8_t* d : app.points[j]->descriptorViews(6)) {
      app.rows.push_back(d);
      app.row_point.push_back(j);
    }
  return app;
}

ObjectMotion reidentify(const MapObject& seen, const MapObject& old, const ReidParams& p) {
  if (seen.class_id != old.class_id) return ObjectMotion{};
  return reidentify(seen, old, reidAppearance(old), p);
}

ObjectMotion reidentify(const MapObject& seen, const MapObject& old, const ReidAppearance& old_appearance,
                        const ReidParams& p, const std::vector<ObjectMotion>& priors) {
  ObjectMotion m;
  if (seen.class_id != old.class_id || p.min_inliers < 3) return m;
  // Fewest matches worth comparing: the object's own motion needs min_inliers;
  // a prior motion prior_min_inliers (at least 3).
  const int need = priors.empty() || p.prior_min_inliers <= 0 ? p.min_inliers
                                                               : std::min(p.min_inliers, std::max(3, p.prior_min_inliers));
  std::vector<const MapPoint*> a;
  for (const auto& [id, q] : seen.points) {
    if (old.points.count(id)) return m;  // shares points: partial views of one object, not a move
    if (q && !q->bad) a.push_back(q.get());
  }
  const std::vector<const MapPoint*>& b = old_appearance.points;
  const std::vector<const uint8_t*>& rows = old_appearance.rows;
  const std::vector<size_t>& row_point = old_appearance.row_point;
  if (static_cast<int>(a.size()) < need || static_cast<int>(b.size()) < need) return m;
  // Best match of each seen point (distinctive descriptor) among the old
  // points (ratio test against the second best *point*); one seen point per
  // old point (the closest).
  std::vector<std::pair<int, size_t>> best_for_old(b.size(), {std::numeric_limits<int>::max(), 0});
  std::vector<int> d_point(b.size());
  for (size_t i = 0; i < a.size(); i++) {
    std::fill(d_point.begin(), d_point.end(), std::numeric_limits<int>::max());
    for (size_t r = 0; r < rows.size(); r++)
      d_point[row_point[r]] = std::min(d_point[row_point[r]], descriptorDistance(a[i]->desc.data(), rows[r]));
    int best = std::numeric_limits<int>::max(), second = best;
    size_t bj = 0;
    for (size_t j = 0; j < b.size(); j++) {
      const int d = d_point[j];
      if (d < best) {
        second = best, best = d, bj = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best > p.max_descriptor_distance || best >= p.ratio * second) continue;
    if (best < best_for_old[bj].first) best_for_old[bj] = {best, i};
  }
  std::vector<Eigen::Vector3d> src, dst;  // old -> seen
  for (size_t j = 0; j < b.size(); j++)
    if (best_for_old[j].first != std::numeric_limits<int>::max()) {
      src.push_back(b[j]->pos);
      dst.push_back(a[best_for_old[j].second]->pos);
    }
  m.matches = static_cast<int>(src.size());
  if (m.matches < need) return m;
  const size_t n = src.size();
  auto fit = [&](const std::vector<size_t>& idx, Eigen::Matrix3d& R, Eigen::Vector3d& t) {
    Eigen::Matrix3Xd S(3, idx.size()), D(3, idx.size());
    for (size_t k = 0; k < idx.size(); k++) S.col(k) = src[idx[k]], D.col(k) = dst[idx[k]];
    const Eigen::Matrix4d T = Eigen::umeyama(S, D, false);
    R = T.topLeftCorner<3, 3>();
    t = T.topRightCorner<3, 1>();
  };
  auto inliersOf = [&](const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
    std::vector<size_t> in;
    for (size_t k = 0; k < n; k++)
      if ((R * src[k] + t - dst[k]).norm() <= p.inlier_m) in.push_back(k);
    return in;
  };
  auto shiftOf = [&](const Eigen::Matrix3d& R, const Eigen::Vector3d& t) { return (R * old.centroid + t - old.centroid).norm(); };
  // Too few matches for a motion of its own: a prior motion they confirm.
  auto byPrior = [&]() {
    if (p.prior_min_inliers <= 0) return;
    const ObjectMotion* best = nullptr;
    size_t best_n = 0;
    for (const ObjectMotion& q : priors) {
      const size_t c = inliersOf(q.R, q.t).size();
      if (c > best_n) best_n = c, best = &q;
    }
    if (!best || static_cast<int>(best_n) < need || 2 * static_cast<int>(best_n) < m.matches) return;
    m.R = best->R, m.t = best->t;
    m.inliers = static_cast<int>(best_n);
    m.shift = shiftOf(m.R, m.t);
    m.from_prior = true;
    m.moved = m.shift >= p.min_shift_m;
  };
  if (m.matches < p.min_inliers) {
    byPrior();
    return m;
  }
  std::mt19937 rng(20161);  // fixed seed: the same map gives the same answer
  std::vector<size_t> best_in;
  for (int it = 0; it < p.iterations; it++) {
    const size_t i = rng() % n, j = rng() % n, k = rng() % n;
    if (i == j || j == k || i == k) continue;
    // A triangle that fixes a rotation (sides longer than the inlier
    // distance, not nearly collinear: sine of its angle at i at least 0.25),
    // and the same shape on both sides (rigid). Its size is not bounded
    // further: the points of a small object (a suitcase's face, 20 cm) span
    // no more; the consensus decides.
    const Eigen::Vector3d u = src[j] - src[i], v = src[k] - src[i];
    const double nu = u.norm(), nv = v.norm();
    if (nu < p.inlier_m || nv < p.inlier_m || u.cross(v).norm() < 0.25 * nu * nv) continue;
    if (std::abs(nu - (dst[j] - dst[i]).norm()) > p.inlier_m || std::abs(nv - (dst[k] - dst[i]).norm()) > p.inlier_m)
      continue;
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    fit({i, j, k}, R, t);
    auto in = inliersOf(R, t);
    if (in.size() > best_in.size()) best_in = std::move(in);
  }
  if (static_cast<int>(best_in.size()) < p.min_inliers) {
    m.inliers = static_cast<int>(best_in.size());
    byPrior();  // no motion of its own: one of the priors, if the matches confirm it
    return m;
  }
  fit(best_in, m.R, m.t);
  m.inliers = static_cast<int>(inliersOf(m.R, m.t).size());
  m.shift = shiftOf(m.R, m.t);
  m.moved = m.inliers >= p.min_inliers && m.shift >= p.min_shift_m;
  return m;
}

}  // namespace dslam
