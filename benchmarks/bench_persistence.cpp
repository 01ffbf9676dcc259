// Cost of the object layer (issue 12): ObjectPersistenceFilter::onKeyFrame
// (object candidates, long-term data association, beliefs, negative
// evidence) for a keyframe of an exact synthetic world with N objects of 20
// points each in front of a 2000-point wall, every object in view; and the
// PointPersistenceFilter on the same keyframes. The cost must grow at most
// linearly with the number of objects (Complexity: oN).
// wants_keyframe: ObjectPersistenceFilter::wantsKeyFrame, run by the
// tracking thread on every frame, with N objects not seen for long and
// none of their places in view (the camera turned away): every object is
// projected and none asks, the per-frame worst case of the place check.
//
//   bench_persistence --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "../tests/support/synth_map.h"
#include "dslam/core/params.h"
#include "dslam/map/atlas.h"
#include "dslam/plugins/map_managers/persistence_filters.h"

using namespace dslam;

namespace {

struct World {
  test::SynthWorld w{0};
  std::vector<int> object_of;  ///< per world point: object index, -1 = wall
  explicit World(int n_objects) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> ux(-1.8, 1.8), uy(-1.2, 1.2), uz(2.5, 4.0), u(-0.05, 0.05);
    std::uniform_int_distribution<int> byte(0, 255);
    auto add = [&](const Eigen::Vector3d& x, int obj) {
      w.X.push_back(x);
      Descriptor d;
      for (auto& b : d) b = static_cast<uint8_t>(byte(rng));
      w.desc.push_back(d);
      object_of.push_back(obj);
    };
    for (int o = 0; o < n_objects; o++) {
      const Eigen::Vector3d c(ux(rng), uy(rng), uz(rng));
      for (int k = 0; k < 20; k++) add(c + Eigen::Vector3d(u(rng), u(rng), u(rng)), o);
    }
    test::SynthWorld wall(2000, 5, 5.0, 5.5);
    for (const auto& x : wall.X) add(x, -1);
  }
};

/** A keyframe at time t seeing the whole world, object keypoints labelled
 *  (class 62 + object % 5, instance = object), associated with map points. */
KeyFramePtr keyframe(const World& W, Map& m, std::vector<MapPointPtr>& pts, double t) {
  std::vector<int> seen;
  Frame f = W.w.frame(SE3(), static_cast<int>(t * 30), &seen);
  f.input.timestamp = t;
  for (size_t k = 0; k < seen.size(); k++)
    if (const int o = W.object_of[seen[k]]; o >= 0) {
      f.meta[k].class_id = static_cast<int16_t>(62 + o % 5);
      f.meta[k].object_id = o;
    }
  auto kf = std::make_shared<KeyFrame>(Map::nextKeyFrameId(), f, SE3(), W.w.cam, W.w.scale, &m);
  for (size_t k = 0; k < seen.size(); k++) {
    MapPointPtr& mp = pts[seen[k]];
    if (!mp) {
      mp = std::make_shared<MapPoint>(Map::nextPointId(), W.w.X[seen[k]], kf.get(), &m);
      const int o = W.object_of[seen[k]];
      mp->class_id = static_cast<int16_t>(o >= 0 ? 62 + o % 5 : -1);
      m.addPoint(mp);
    }
    kf->addPoint(mp, static_cast<int>(k));
    mp->addObservation(kf.get(), static_cast<int>(k));
  }
  m.addKeyFrame(kf);
  kf->updateConnections();
  return kf;
}

/** A filter of type F over an atlas, on the world of N objects, after its
 *  first keyframe (at t = 0). */
template <class F>
struct Setup {
  const World W;
  std::shared_ptr<Atlas> atlas = std::make_shared<Atlas>();
  F filter;
  std::shared_ptr<Map> map;
  std::vector<MapPointPtr> pts;
  explicit Setup(int n) : W(n), pts(W.w.X.size()) {
    filter.configure(Params::resolve(filter.paramSpecs(), "{}"), PluginContext{});
    filter.setInner(atlas);
    map = filter.currentMap();
    filter.onKeyFrame(keyframe(W, *map, pts, 0.0));
  }
  void finish(benchmark::State& state, int n) const {
    state.counters["objects"] = static_cast<double>(map->objects().size());
    state.SetComplexityN(n);
  }
};

template <class F>
void run(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Setup<F> s(n);
  double t = 0;
  for (auto _ : state) {
    state.PauseTiming();
    t += 3.0;  // long-term: every object is sighted again
    auto kf = keyframe(s.W, *s.map, s.pts, t);
    state.ResumeTiming();
    s.filter.onKeyFrame(kf);
  }
  s.finish(state, n);
}

void wants_keyframe(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Setup<ObjectPersistenceFilter> s(n);
  Frame f = s.W.w.frame(SE3(), 300);  // unlabelled keypoints: no new object to ask for
  f.input.timestamp = 10.0;           // every object not seen for 10 s
  const SE3 away(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY())), Eigen::Vector3d::Zero());
  const std::vector<MapPointPtr> matched(f.size());
  int asked = 0;
  for (auto _ : state) asked += s.filter.wantsKeyFrame(s.map, f, away, s.W.w.cam, matched);
  if (asked) state.SkipWithError("a place out of view asked for a keyframe");
  s.finish(state, n);
}

}  // namespace

BENCHMARK(wants_keyframe)->RangeMultiplier(4)->Range(8, 512)->Complexity(benchmark::oN)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(run, ObjectPersistenceFilter)->RangeMultiplier(4)->Range(8, 512)->Iterations(20)->Complexity(benchmark::oN)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(run, PointPersistenceFilter)->RangeMultiplier(4)->Range(8, 512)->Iterations(20)->Complexity(benchmark::oN)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
