// Fuzz target: trajectory readers (traj::read with format detection, TUM,
// KITTI with and without a times file, EuRoC CSV). The first input byte
// selects the reader; the rest is the file.
#include "dslam/trajectory/io.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace traj = dslam::traj;
  const auto in = dslam::fuzz::select(data, size, 7);
  dslam::fuzz::guarded([&] {
    switch (in.mode) {
      case 0: traj::read(dslam::fuzz::writeFile("traj.txt", in.data, in.size)); break;
      case 1: traj::readTum(dslam::fuzz::writeFile("traj.txt", in.data, in.size)); break;
      case 2: traj::readTum(dslam::fuzz::writeFile("traj.txt", in.data, in.size), false); break;
      case 3: traj::readKitti(dslam::fuzz::writeFile("poses.txt", in.data, in.size)); break;
      case 4: {  // poses and times from one input: the times file is the part after the first NUL
        const std::string s = in.text();
        const size_t z = s.find('\0');
        const std::string poses = dslam::fuzz::writeFile("poses.txt", s.substr(0, z));
        const std::string times = dslam::fuzz::writeFile("times.txt", z == std::string::npos ? "" : s.substr(z + 1));
        traj::readKitti(poses, times);
        break;
      }
      case 5: traj::readEuroc(dslam::fuzz::writeFile("data.csv", in.data, in.size)); break;
      default: traj::read(dslam::fuzz::writeFile("traj.csv", in.data, in.size)); break;
    }
  });
  return 0;
}
