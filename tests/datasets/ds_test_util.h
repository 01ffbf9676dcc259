#pragma once
// Helpers for the dataset reader tests.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "dslam/core/dataset.h"
#include "dslam/core/error.h"
#include "dslam/core/registry.h"
#include "plugin_util.h"
#include "test_support.h"

namespace dslam::test {

/** Writes `content` to `file`, then `open()` must throw a DataError whose
 *  message holds every text of `want` (bad-input tests of the readers). */
template <class Open>
void expectOpenError(const std::string& file, const std::string& content, Open&& open,
                     std::initializer_list<const char*> want) {
  writeFile(file, content);
  const std::string e = dataError(open);
  for (const char* w : want) EXPECT_NE(e.find(w), std::string::npos) << file << ": " << e;
}

inline std::string yq(const std::string& s) { return "\"" + s + "\""; }


template <class F>
std::string anyErrorOf(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

inline void mkdirs(const std::string& d) { std::filesystem::create_directories(d); }

inline void writeImage(const std::string& path, const cv::Mat& m) {
  ASSERT_TRUE(cv::imwrite(path, m)) << path;
}

/** A small TUM folder (8x6 images). Depth: raw 5000+i, (0,0) = 0,
 *  (1,1) = 65535, (2,2) = 5000, row 5 random 16-bit values.
 *  rgb at 1.000 1.033 1.066 1.100 1.133, depth at 1.005 1.040 1.090 1.150 1.300:
 *  associate.py pairs 4 of them (1.066 has no depth within 0.02 s). */
struct TinyTum {
  std::string dir;
  /** `size`: of the images (8x6; the full 640x480 where the TUM intrinsics
   *  must fit them, as in a camera.yaml written back). */
  explicit TinyTum(const std::string& name = "rgbd_dataset_freiburg2_tiny", cv::Size size = {8, 6}) {
    dir = tempDir("tum") + "/" + name;
    mkdirs(dir + "/rgb");
    mkdirs(dir + "/depth");
    const char* rgb[] = {"1.000000", "1.033000", "1.066000", "1.100000", "1.133000"};
    const char* dep[] = {"1.005000", "1.040000", "1.090000", "1.150000", "1.300000"};
    std::ofstream fr(dir + "/rgb.txt"), fd(dir + "/depth.txt");
    fr << "# color images\n# timestamp filename\n";
    fd << "# depth maps\n";
    for (int i = 0; i < 5; i++) {
      cv::Mat im(size, CV_8UC3, cv::Scalar(10 * i, 20, 30));
      writeImage(dir + "/rgb/" + rgb[i] + ".png", im);
      fr << rgb[i] << " rgb/" << rgb[i] << ".png\n";
      cv::Mat d(size, CV_16UC1, cv::Scalar(5000 + i));
      d.at<uint16_t>(0, 0) = 0;
      d.at<uint16_t>(1, 1) = 65535;
      d.at<uint16_t>(2, 2) = 5000;
      cv::RNG rng(static_cast<uint64_t>(i + 1));  // row 5: arbitrary 16-bit values
      for (int c = 0; c < 8; c++) d.at<uint16_t>(5, c) = static_cast<uint16_t>(rng.uniform(0, 65536));
      writeImage(dir + "/depth/" + dep[i] + ".png", d);
      fd << dep[i] << " depth/" << dep[i] << ".png\n";
    }
    std::ofstream g(dir + "/groundtruth.txt");
    g << "# timestamp tx ty tz qx qy qz qw\n"
      << "1.0000 0 0 0 0 0 0 1\n"
      << "1.0340 0.1 0 0 0 0 0 1\n"
      << "1.1000 0.2 0 0 0 0 0 1\n"
      << "1.2000 0.3 0 0 0 0 0 1\n";
  }
  std::shared_ptr<DatasetSource> open(const std::string& extra = "", const std::string& type = "dslam::TumDataset") const {
    return openDataset(type, "path: " + yq(dir) + "\n" + extra);
  }
};


}  // namespace dslam::test
