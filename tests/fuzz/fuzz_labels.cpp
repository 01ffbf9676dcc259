// Fuzz target: the label files of docs/detectors.md as FileDetector reads
// them: box JSON (plain and YOLO index80 ids), COCO panoptic JSON (whole
// dataset or per frame; then combined with a small id image by
// fillPanoptic), semantic label PNG, panoptic PNG. The first input byte
// selects the reader; the rest is the file.
#include <opencv2/core.hpp>

#include "dslam/plugins/detectors/label_io.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace labels = dslam::labels;
  const auto in = dslam::fuzz::select(data, size, 5);
  dslam::fuzz::guarded([&] {
    switch (in.mode) {
      case 0:
      case 1: {
        cv::Size sz;
        (void)labels::readBoxJson(dslam::fuzz::writeFile("000001.json", in.data, in.size), in.mode == 1, &sz);
        break;
      }
      case 2: {
        const auto pj = labels::readPanopticJson(dslam::fuzz::writeFile("panoptic.json", in.data, in.size));
        // Ids 0..5 (and one large id) in a 8x6 image against the first annotation.
        cv::Mat ids(6, 8, CV_32S);
        for (int i = 0; i < ids.rows * ids.cols; i++) ids.at<int32_t>(i / 8, i % 8) = i % 6;
        ids.at<int32_t>(5, 7) = (1 << 24) - 1;
        dslam::Detections d;
        labels::fillPanoptic(ids, pj.annotations.empty() ? nullptr : &pj.annotations.front(), pj, d);
        (void)labels::semanticFromPanoptic(d);
        (void)labels::detectionsJsonText(d);
        (void)pj.find("000001");
        break;
      }
      case 3: (void)labels::readSemanticPng(dslam::fuzz::writeFile("000001.png", in.data, in.size)); break;
      default: (void)labels::readPanopticPng(dslam::fuzz::writeFile("000001.png", in.data, in.size)); break;
    }
  });
  return 0;
}
