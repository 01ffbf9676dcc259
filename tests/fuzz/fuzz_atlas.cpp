// Fuzz target: atlas files (Atlas::load, the "DSLAMATL" binary map format:
// maps, keyframes with keypoints and descriptors, map points,
// observations, spanning tree and loop edges).
#include "dslam/map/atlas.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = dslam::fuzz::writeFile("atlas.bin", data, size);
  dslam::fuzz::guarded([&] {
    dslam::Atlas a;
    a.load(path);
    for (const auto& m : a.maps()) (void)m;
  });
  return 0;
}
