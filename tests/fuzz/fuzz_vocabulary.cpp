// Fuzz target: vocabulary loaders (dslam binary "DSLAMVOC", DBoW2 / ORB-SLAM
// text, DBoW2 / DBoW3 OpenCV YAML; each plain or gzip-compressed). The first
// input byte selects the format and whether the harness gzip-compresses the
// rest before writing it (so that the fuzzer mutates the text, not the
// deflate stream, and the gzip code paths are exercised too). A loaded
// vocabulary transforms a few descriptors (a hostile tree must not make the
// descent loop or index out of range).
#include <zlib.h>

#include <opencv2/core.hpp>

#include "dslam/place_recognition/vocabulary.h"
#include "fuzz_common.h"

namespace {
std::string gzip(const uint8_t* data, size_t n) {
  std::string out(compressBound(static_cast<uLong>(n)) + 32, '\0');
  z_stream z{};
  deflateInit2(&z, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);  // 15 + 16: gzip wrapper
  z.next_in = const_cast<Bytef*>(data);
  z.avail_in = static_cast<uInt>(n);
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using dslam::VocabularyFormat;
  const auto in = dslam::fuzz::select(data, size, 8);
  static const VocabularyFormat formats[4] = {VocabularyFormat::Auto, VocabularyFormat::Binary,
                                              VocabularyFormat::Text, VocabularyFormat::Yaml};
  static const char* names[4] = {"voc.bin", "voc.dvoc", "voc.txt", "voc.yml"};
  const unsigned f = in.mode % 4;
  const bool gz = in.mode >= 4;
  const std::string path = gz ? dslam::fuzz::writeFile(std::string(names[f]) + ".gz", gzip(in.data, in.size))
                              : dslam::fuzz::writeFile(names[f], in.data, in.size);
  dslam::fuzz::guarded([&] {
    const auto voc = dslam::Vocabulary::load(path, formats[f]);
    (void)voc.summary();
    cv::Mat d(4, 32, CV_8U);
    for (int i = 0; i < d.rows * d.cols; i++) d.data[i] = static_cast<uint8_t>(i * 37 + 11);
    d.row(0).setTo(0);
    d.row(1).setTo(255);
    dslam::BowVector bow;
    dslam::FeatureVector fv;
    voc.transform(d, bow, fv, std::min(4, voc.levels()));
  });
  return 0;
}
