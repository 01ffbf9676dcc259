// The fast PNG decoder (dslam/core/png.h) against cv::imread: same pixels
// for every layout it accepts, every row filter type covered, and a decline
// (empty Mat) for whatever it does not handle or finds damaged.
#include <gtest/gtest.h>
#include <libdeflate.h>

#include <opencv2/imgcodecs.hpp>

#include <cstring>
#include <filesystem>
#include <set>

#include "dslam/core/atomic_file.h"
#include "dslam/core/error.h"
#include "dslam/core/png.h"
#include "test_support.h"

using namespace dslam;

namespace {

/** Half noise, half smooth gradient: adaptive filtering then picks
 *  different row filters on different rows. */
cv::Mat testImage(int type, uint64_t seed) {
  cv::Mat m(61, 77, type);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65535 : 255);
  for (int y = 0; y < m.rows; y++)
    for (int x = 0; x < m.cols; x++)
      if ((y / 8) % 2 == 0)
        for (int c = 0; c < m.channels(); c++) {
          const int v = (x * 3 + y * (c + 1)) % 250;
          if (CV_MAT_DEPTH(type) == CV_16U)
            m.ptr<uint16_t>(y)[x * m.channels() + c] = static_cast<uint16_t>(v * 200);
          else
            m.ptr<uchar>(y)[x * m.channels() + c] = static_cast<uchar>(v);
        }
  return m;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return !a.empty() && a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

uint32_t be32(const unsigned char* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

/** Row filter types used in a PNG file (inflated here independently). */
std::set<int> filterTypes(const std::string& file, size_t row_bytes, int rows) {
  const std::string s = test::readFile(file);
  std::vector<unsigned char> idat;
  for (size_t pos = 8; pos + 12 <= s.size();) {
    const auto* p = reinterpret_cast<const unsigned char*>(s.data()) + pos;
    const uint32_t len = be32(p);
    if (std::memcmp(p + 4, "IDAT", 4) == 0) idat.insert(idat.end(), p + 8, p + 8 + len);
    pos += 12 + len;
  }
  std::vector<unsigned char> raw((row_bytes + 1) * rows);
  libdeflate_decompressor* d = libdeflate_alloc_decompressor();
  const auto r = libdeflate_zlib_decompress(d, idat.data(), idat.size(), raw.data(), raw.size(), nullptr);
  libdeflate_free_decompressor(d);
  std::set<int> types;
  if (r == LIBDEFLATE_SUCCESS)
    for (int y = 0; y < rows; y++) types.insert(raw[y * (row_bytes + 1)]);
  return types;
}

}  // namespace

TEST(Png, SamePixelsAsImreadForEveryLayoutAndFilter) {
  const std::string dir = test::tempDir("png");
  std::set<int> filters;
  int files = 0;
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1}) {
    const cv::Mat img = testImage(type, 7 + type);
    const std::vector<std::vector<int>> settings = {
        {},                                                                       // OpenCV default: Sub filter, RLE
        {cv::IMWRITE_PNG_COMPRESSION, 0},                                         // stored blocks
        {cv::IMWRITE_PNG_COMPRESSION, 3},                                         // adaptive filters
        {cv::IMWRITE_PNG_COMPRESSION, 9},                                         // adaptive, best
        {cv::IMWRITE_PNG_COMPRESSION, 6, cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_FILTERED},
        {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY}};
    for (size_t k = 0; k < settings.size(); k++) {
      const std::string f = dir + "/t" + std::to_string(type) + "_" + std::to_string(k) + ".png";
      ASSERT_TRUE(cv::imwrite(f, img, settings[k]));
      const cv::Mat ref = cv::imread(f, cv::IMREAD_UNCHANGED);
      ASSERT_TRUE(identical(ref, img));
      const cv::Mat fast = readPngFast(f, cv::IMREAD_UNCHANGED);
      EXPECT_TRUE(identical(fast, ref)) << f;
      if (img.channels() == 1) {
        EXPECT_TRUE(identical(readPngFast(f, cv::IMREAD_ANYDEPTH), cv::imread(f, cv::IMREAD_ANYDEPTH))) << f;
      }
      if (type == CV_8UC3) {
        EXPECT_TRUE(identical(readPngFast(f, cv::IMREAD_COLOR), cv::imread(f, cv::IMREAD_COLOR))) << f;
      }
      if (type == CV_8UC1) {
        EXPECT_TRUE(identical(readPngFast(f, cv::IMREAD_GRAYSCALE), cv::imread(f, cv::IMREAD_GRAYSCALE))) << f;
      }
      const auto t = filterTypes(f, img.cols * img.elemSize(), img.rows);
      filters.insert(t.begin(), t.end());
      files++;
    }
  }
  EXPECT_EQ(files, 24);
  EXPECT_EQ(filters, (std::set<int>{0, 1, 2, 3, 4})) << "every PNG row filter exercised";
}

TEST(Png, SamePixelsAsImreadOnRealTumFrames) {
  const std::string dir = test::shared("data/tum-frames/rgbd-pair");
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "shared data missing: " << dir;
  for (const char* name : {"1.png", "2.png"}) {
    const std::string f = dir + "/" + name;
    EXPECT_TRUE(identical(readPngFast(f, cv::IMREAD_UNCHANGED), cv::imread(f, cv::IMREAD_UNCHANGED))) << f;
  }
  const std::string depth = dir + "/1_depth.png";
  const cv::Mat d = readPngFast(depth, cv::IMREAD_ANYDEPTH);
  EXPECT_EQ(d.type(), CV_16UC1);
  EXPECT_TRUE(identical(d, cv::imread(depth, cv::IMREAD_ANYDEPTH)));
}

TEST(Png, DeclinesWhatItDoesNotHandleAndReadImageFileFallsBack) {
  const std::string dir = test::tempDir("png_decline");
  const cv::Mat grey = testImage(CV_8UC1, 3), rgb = testImage(CV_8UC3, 4), rgb16 = testImage(CV_16UC3, 5);
  ASSERT_TRUE(cv::imwrite(dir + "/g.png", grey));
  ASSERT_TRUE(cv::imwrite(dir + "/c16.png", rgb16));
  ASSERT_TRUE(cv::imwrite(dir + "/c.jpg", rgb));
  // Conversions cv::imread does (grey -> BGR, 16-bit colour) are left to it.
  EXPECT_TRUE(readPngFast(dir + "/g.png", cv::IMREAD_COLOR).empty());
  EXPECT_TRUE(readPngFast(dir + "/c16.png", cv::IMREAD_UNCHANGED).empty());
  EXPECT_TRUE(identical(readImageFile(dir + "/g.png", cv::IMREAD_COLOR), cv::imread(dir + "/g.png", cv::IMREAD_COLOR)));
  EXPECT_TRUE(identical(readImageFile(dir + "/c16.png", cv::IMREAD_UNCHANGED), rgb16));
  // Not a PNG: cv::imread decodes it.
  EXPECT_TRUE(readPngFast(dir + "/c.jpg", cv::IMREAD_UNCHANGED).empty());
  EXPECT_EQ(readImageFile(dir + "/c.jpg", cv::IMREAD_UNCHANGED).size(), rgb.size());
  // Missing, truncated, damaged.
  EXPECT_TRUE(readPngFast(dir + "/none.png", cv::IMREAD_UNCHANGED).empty());
  EXPECT_TRUE(readImageFile(dir + "/none.png", cv::IMREAD_UNCHANGED).empty());
  std::string bytes = test::readFile(dir + "/g.png");
  ASSERT_TRUE(identical(readPngFast(dir + "/g.png", cv::IMREAD_UNCHANGED), grey));
  test::writeFile(dir + "/trunc.png", bytes.substr(0, bytes.size() / 2));
  EXPECT_TRUE(readPngFast(dir + "/trunc.png", cv::IMREAD_UNCHANGED).empty());
  const size_t idat = bytes.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  bytes[idat + 30] = static_cast<char>(bytes[idat + 30] ^ 0x5a);  // CRC no longer matches
  test::writeFile(dir + "/flip.png", bytes);
  EXPECT_TRUE(readPngFast(dir + "/flip.png", cv::IMREAD_UNCHANGED).empty());
}

TEST(Png, DamagedFilesSayWhyAndAreNotPassedToLibpng) {
  // cv::imread fails on them too, but its libpng prints "libpng error: ..."
  // to stderr first: readImageFile keeps them from it.
  const std::string dir = test::tempDir("png_damaged");
  const cv::Mat grey = testImage(CV_8UC1, 3);
  ASSERT_TRUE(cv::imwrite(dir + "/g.png", grey));
  const std::string good = test::readFile(dir + "/g.png");
  const size_t idat = good.find("IDAT") - 4;  // the chunk starts with its length
  auto damageOf = [&](const std::string& name, const std::string& bytes) {
    test::writeFile(dir + "/" + name, bytes);
    std::string fast, file;
    EXPECT_TRUE(readPngFast(dir + "/" + name, cv::IMREAD_UNCHANGED, &fast).empty());
    testing::internal::CaptureStderr();
    EXPECT_TRUE(readImageFile(dir + "/" + name, cv::IMREAD_UNCHANGED, &file).empty());
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "") << name;
    EXPECT_EQ(fast, file);
    return file;
  };
  std::string flip = good;
  flip[idat + 30] = static_cast<char>(flip[idat + 30] ^ 0x5a);
  EXPECT_EQ(damageOf("flip.png", flip), "corrupt PNG: CRC error in chunk IDAT at byte " + std::to_string(idat));
  EXPECT_EQ(damageOf("half.png", good.substr(0, idat + 20)).rfind("corrupt PNG: truncated: chunk IDAT of ", 0), 0u);
  EXPECT_EQ(damageOf("noend.png", good.substr(0, good.size() - 12)),
            "corrupt PNG: truncated: the file ends without an IEND chunk");
  // Image data that does not inflate, the chunk's CRC made to match.
  std::string bad = good;
  const uint32_t len = (uint32_t(uint8_t(bad[idat])) << 24) | (uint32_t(uint8_t(bad[idat + 1])) << 16) |
                       (uint32_t(uint8_t(bad[idat + 2])) << 8) | uint8_t(bad[idat + 3]);
  for (uint32_t i = 2; i < len; i++) bad[idat + 8 + i] = static_cast<char>(0xff);
  uint32_t crc = 0xffffffffu;  // CRC-32 of type and data (PNG, zlib polynomial)
  for (uint32_t i = 0; i < len + 4; i++) {
    crc ^= uint8_t(bad[idat + 4 + i]);
    for (int k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xffffffffu;
  for (int k = 0; k < 4; k++) bad[idat + 8 + len + k] = static_cast<char>(crc >> (24 - 8 * k));
  EXPECT_EQ(damageOf("inflate.png", bad), "corrupt PNG: the image data (IDAT) is not a valid zlib stream");
  // A header of 25000 x 25000 pixels: refused before anything is decoded.
  std::string bomb = good;
  for (int k = 0; k < 2; k++)
    for (int b = 0; b < 4; b++) bomb[16 + 4 * k + b] = static_cast<char>((25000u >> (24 - 8 * b)) & 0xff);
  uint32_t hcrc = 0xffffffffu;
  for (int i = 12; i < 12 + 17; i++) {
    hcrc ^= uint8_t(bomb[static_cast<size_t>(i)]);
    for (int k = 0; k < 8; k++) hcrc = (hcrc >> 1) ^ (0xedb88320u & (0u - (hcrc & 1u)));
  }
  hcrc ^= 0xffffffffu;
  for (int k = 0; k < 4; k++) bomb[29 + static_cast<size_t>(k)] = static_cast<char>(hcrc >> (24 - 8 * k));
  EXPECT_EQ(damageOf("bomb.png", bomb), "PNG of 25000x25000 pixels: more than the 268435456 (2^28) pixels dslam reads");
  // The good file still reads; a missing file or one that is not a PNG is not "damaged".
  EXPECT_TRUE(identical(readImageFile(dir + "/g.png", cv::IMREAD_UNCHANGED), grey));
  std::string why = "x";
  EXPECT_TRUE(readImageFile(dir + "/none.png", cv::IMREAD_UNCHANGED, &why).empty());
  EXPECT_EQ(why, "");
  EXPECT_EQ(unreadableImageReason(""), "corrupt or unsupported image");
  EXPECT_EQ(unreadableImageReason("corrupt PNG: CRC error"), "corrupt PNG: CRC error");
}

TEST(Png, TruncatedJpegsAreDamagedNotHalfGrey) {
  // libjpeg decodes a JPEG cut short into a frame whose missing part is
  // grey (printing only "Premature end of JPEG file"): readImageFile walks
  // the markers first and refuses it.
  const std::string dir = test::tempDir("jpeg_damaged");
  const cv::Mat rgb = testImage(CV_8UC3, 9);
  for (const bool progressive : {false, true}) {
    const std::string name = progressive ? "/p.jpg" : "/b.jpg";
    ASSERT_TRUE(cv::imwrite(dir + name, rgb, {cv::IMWRITE_JPEG_PROGRESSIVE, progressive ? 1 : 0,
                                              cv::IMWRITE_JPEG_RST_INTERVAL, progressive ? 0 : 2}));
    const std::string good = test::readFile(dir + name);
    std::string why = "x";
    EXPECT_TRUE(identical(readImageFile(dir + name, cv::IMREAD_COLOR, &why), cv::imread(dir + name, cv::IMREAD_COLOR)));
    EXPECT_EQ(why, "") << name;
    // Bytes after the end-of-image marker are ignored, as libjpeg does.
    test::writeFile(dir + "/tail.jpg", good + std::string("\0\0garbage\xff", 10));
    EXPECT_FALSE(readImageFile(dir + "/tail.jpg", cv::IMREAD_COLOR, &why).empty());
    EXPECT_EQ(why, "");
    for (const size_t cut : {good.size() - 2, good.size() * 3 / 4, good.size() / 2, size_t(20), size_t(3)}) {
      test::writeFile(dir + "/cut.jpg", good.substr(0, cut));
      testing::internal::CaptureStderr();
      EXPECT_TRUE(readImageFile(dir + "/cut.jpg", cv::IMREAD_COLOR, &why).empty()) << name << " cut at " << cut;
      EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
      EXPECT_EQ(why.rfind("corrupt JPEG: truncated: the file (" + std::to_string(cut) + " bytes) ends ", 0), 0u)
          << why;
    }
  }
  test::writeFile(dir + "/len.jpg", std::string("\xff\xd8\xff\xe0\x00\x01", 6));
  std::string why;
  EXPECT_TRUE(readImageFile(dir + "/len.jpg", cv::IMREAD_COLOR, &why).empty());
  EXPECT_EQ(why, "corrupt JPEG: segment length 1 at byte 4");
}

TEST(Png, DamageInLayoutsLeftToImreadIsFoundToo) {
  // Layouts the fast decoder does not decode (16-bit colour, 1-bit grey,
  // grey read as colour) still go through its chunk walk and an inflate of
  // their image data, so damage there is reported without libpng's line.
  const std::string dir = test::tempDir("png_declined_damage");
  const cv::Mat rgb16 = testImage(CV_16UC3, 5), grey = testImage(CV_8UC1, 6);
  ASSERT_TRUE(cv::imwrite(dir + "/c16.png", rgb16));
  ASSERT_TRUE(cv::imwrite(dir + "/bits.png", grey, {cv::IMWRITE_PNG_BILEVEL, 1}));
  ASSERT_TRUE(cv::imwrite(dir + "/g.png", grey));
  struct Case {
    std::string file;
    int flags;
  };
  for (const Case& c : {Case{"c16.png", cv::IMREAD_UNCHANGED}, Case{"bits.png", cv::IMREAD_UNCHANGED},
                        Case{"g.png", cv::IMREAD_COLOR}}) {
    const std::string good = test::readFile(dir + "/" + c.file);
    std::string why = "x";
    EXPECT_TRUE(identical(readImageFile(dir + "/" + c.file, c.flags, &why), cv::imread(dir + "/" + c.file, c.flags)))
        << c.file;
    EXPECT_EQ(why, "") << c.file;
    const size_t idat = good.find("IDAT") - 4;
    const uint32_t len = be32(reinterpret_cast<const unsigned char*>(good.data()) + idat);
    auto damageOf = [&](const std::string& bytes) {
      test::writeFile(dir + "/bad.png", bytes);
      std::string d;
      testing::internal::CaptureStderr();
      EXPECT_TRUE(readImageFile(dir + "/bad.png", c.flags, &d).empty()) << c.file;
      EXPECT_EQ(testing::internal::GetCapturedStderr(), "") << c.file;
      return d;
    };
    std::string flip = good;
    flip[idat + 8 + len / 2] = static_cast<char>(flip[idat + 8 + len / 2] ^ 0x5a);
    EXPECT_EQ(damageOf(flip), "corrupt PNG: CRC error in chunk IDAT at byte " + std::to_string(idat)) << c.file;
    EXPECT_EQ(damageOf(good.substr(0, idat + 8 + len / 2)).rfind("corrupt PNG: truncated: chunk IDAT of ", 0), 0u)
        << c.file;
    // Image data that does not inflate, its CRC made to match.
    std::string bad = good;
    for (uint32_t i = 2; i < len; i++) bad[idat + 8 + i] = static_cast<char>(0xff);
    const uint32_t crc = libdeflate_crc32(0, bad.data() + idat + 4, len + 4);
    for (int k = 0; k < 4; k++) bad[idat + 8 + len + k] = static_cast<char>(crc >> (24 - 8 * k));
    EXPECT_EQ(damageOf(bad), "corrupt PNG: the image data (IDAT) is not a valid zlib stream") << c.file;
  }
  // A header libpng refuses: bit depth 3.
  std::string hdr = test::readFile(dir + "/g.png");
  hdr[24] = 3;
  const uint32_t crc = libdeflate_crc32(0, hdr.data() + 12, 17);
  for (int k = 0; k < 4; k++) hdr[29 + k] = static_cast<char>(crc >> (24 - 8 * k));
  test::writeFile(dir + "/hdr.png", hdr);
  std::string why;
  testing::internal::CaptureStderr();
  EXPECT_TRUE(readImageFile(dir + "/hdr.png", cv::IMREAD_UNCHANGED, &why).empty());
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(why, "corrupt PNG: invalid header (IHDR): 77x61 pixels, colour type 0, bit depth 3, compression 0, "
                 "filter 0, interlace 0");
}

TEST(Png, WriteImageFileSaysWhenTheDiskIsFullWithoutLibpngsLine) {
  const std::string dir = test::tempDir("png_write");
  const cv::Mat rgb = testImage(CV_8UC3, 11), depth = testImage(CV_16UC1, 12);
  writeImageFile(dir + "/c.png", rgb, {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_RLE});
  writeImageFile(dir + "/d.png", depth);
  EXPECT_TRUE(identical(cv::imread(dir + "/c.png", cv::IMREAD_UNCHANGED), rgb));
  EXPECT_TRUE(identical(cv::imread(dir + "/d.png", cv::IMREAD_UNCHANGED), depth));
  // The same bytes as cv::imwrite.
  ASSERT_TRUE(cv::imwrite(dir + "/c_cv.png", rgb, {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_RLE}));
  EXPECT_EQ(test::readFile(dir + "/c.png"), test::readFile(dir + "/c_cv.png"));
  auto errorOf = [&](const std::string& path) {
    testing::internal::CaptureStderr();
    std::string msg;
    try {
      writeImageFile(path, rgb);
    } catch (const DataError& e) {
      msg = e.what();
    }
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "") << path;  // cv::imwrite: "libpng error: Write Error"
    return msg;
  };
  if (std::filesystem::exists("/dev/full")) {  // every write fails with ENOSPC, as on a full disk
    EXPECT_EQ(errorOf("/dev/full").rfind("cannot write image /dev/full (", 0), 0u) << errorOf("/dev/full");
  }
  EXPECT_EQ(errorOf(dir + "/x.unknown"),
            "cannot write image " + dir + "/x.unknown (no image format for the extension '.unknown')");
  EXPECT_EQ(errorOf(dir + "/none/c.png").rfind("cannot write image " + dir + "/none/c.png", 0), 0u);
}

TEST(TextFile, WriteTextFileWritesOrNamesTheFileThatFailed) {
  const std::string dir = test::tempDir("text_write");
  writeTextFile(dir + "/a.txt", "one\ntwo\n");
  EXPECT_EQ(test::readFile(dir + "/a.txt"), "one\ntwo\n");
  auto errorOf = [](const std::string& path) {
    try {
      writeTextFile(path, std::string(100000, 'x'));
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(errorOf(dir + "/none/b.txt").rfind("cannot write " + dir + "/none/b.txt", 0), 0u);
  if (std::filesystem::exists("/dev/full")) {  // every write fails with ENOSPC, as on a full disk
    EXPECT_EQ(errorOf("/dev/full").rfind("write failed: /dev/full", 0), 0u) << errorOf("/dev/full");
  }
}
