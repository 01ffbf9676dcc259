// Fuzz target: the dataset readers' list and calibration files: TUM rgb.txt
// (readTumList), associations.txt (readTumAssociations), KITTI calib.txt,
// EuRoC cam data.csv and sensor.yaml. The first input byte selects the
// reader; the rest is the file.
#include "dslam/plugins/datasets/euroc.h"
#include "dslam/plugins/datasets/kitti.h"
#include "dslam/plugins/datasets/tum.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto in = dslam::fuzz::select(data, size, 5);
  dslam::fuzz::guarded([&] {
    switch (in.mode) {
      case 0: dslam::readTumList(dslam::fuzz::writeFile("rgb.txt", in.data, in.size)); break;
      case 1: dslam::readTumAssociations(dslam::fuzz::writeFile("associations.txt", in.data, in.size)); break;
      case 2: dslam::readKittiCalib(dslam::fuzz::writeFile("calib.txt", in.data, in.size)); break;
      case 3: {
        const std::string f = dslam::fuzz::writeFile("cam0/data.csv", in.data, in.size);
        dslam::readEurocImageList((dslam::fuzz::scratchDir() / "cam0").string());
        break;
      }
      default: dslam::readEurocSensorYaml(dslam::fuzz::writeFile("sensor.yaml", in.data, in.size)); break;
    }
  });
  return 0;
}
