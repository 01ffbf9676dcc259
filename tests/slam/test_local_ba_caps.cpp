// Local BA size caps (mapping.ba_max_keyframes, ba_max_fixed_keyframes) on a
// real run: a small-motion view where every keyframe sees every other one.
#include <gtest/gtest.h>

#include <algorithm>

#include "dslam/core/dataset.h"
#include "dslam/core/registry.h"
#include "dslam/slam/system.h"
#include "plugin_util.h"
#include "synth_cache.h"
#include "test_support.h"

using namespace dslam;

namespace {

struct Seen {
  int max_optimised = 0, max_fixed = 0, runs = 0;
};

Seen runWithCaps(const std::string& dir, int max_kf, int max_fixed) {
  auto ds = test::openDataset("dslam::TumDataset", test::cat("path: ", dir, "\n"));
  auto backend = test::defaultBackend();
  SlamParams sp;
  sp.mapper.ba_max_keyframes = max_kf;
  sp.mapper.ba_max_fixed_keyframes = max_fixed;
  sp.tracker.max_frames = 3;     // a keyframe every few frames: many covisible keyframes
  sp.tracker.ref_ratio = 0.99f;  // (whenever fewer than 99% of the reference keyframe's points are tracked)
  sp.place.enabled = false;
  System sys(*ds->camera(), sp, backend);
  Seen s;
  int64_t last = -1;
  for (size_t i = 0; i < ds->size(); i++) {
    sys.track(ds->read(i));
    const LocalBAStats b = sys.mapper().lastLocalBA();
    if (b.keyframe < 0 || b.keyframe == last) continue;
    last = b.keyframe;
    s.runs++;
    s.max_optimised = std::max(s.max_optimised, b.optimised);
    s.max_fixed = std::max(s.max_fixed, b.fixed);
    EXPECT_GT(b.points, 0);
    EXPECT_FALSE(b.aborted);  // sequential mode never stops a BA early
  }
  return s;
}

}  // namespace

TEST(LocalMapping, LocalBundleAdjustmentRespectsItsCaps) {
  const std::string dir = test::syntheticSequence("static_office", 90, 320, 240);
  const Seen capped = runWithCaps(dir, 4, 2);
  const Seen wide = runWithCaps(dir, 1000, 1000);
  std::cout << "local BA: capped runs " << capped.runs << ", max " << capped.max_optimised << " optimised + "
            << capped.max_fixed << " fixed; uncapped max " << wide.max_optimised << " + " << wide.max_fixed << "\n";
  ASSERT_GE(capped.runs, 5);
  EXPECT_EQ(capped.max_optimised, 4);  // reached, never exceeded
  EXPECT_EQ(capped.max_fixed, 2);
  EXPECT_GT(wide.max_optimised, 8);  // without the caps the problem grows with the map
}
