#pragma once
// An MRPT pinhole camera for writing test rawlogs (tests/datasets, the fuzz
// seeds): focal length f, w x h pixels, principal point at the centre.
#include <mrpt/img/TCamera.h>

namespace dslam::test {

inline mrpt::img::TCamera tcam(double f, int w, int h) {
  mrpt::img::TCamera c;
  c.ncols = w;
  c.nrows = h;
  c.setIntrinsicParamsFromValues(f, f, (w - 1) / 2.0, (h - 1) / 2.0);
  return c;
}

}  // namespace dslam::test
