#pragma once
/** \file png.h
 *  Fast decoding of the PNG layouts datasets use (TUM/Bonn colour and 16-bit
 *  depth, `dslam synth` output, label images). Every run decodes every frame
 *  and decoding was the largest single CPU cost of an RGB-D run (zlib inflate
 *  and libpng unfiltering, about a quarter of a `crowd_slam` run's CPU); this
 *  decoder inflates with libdeflate and unfilters whole pixels at a time. It
 *  returns exactly the pixels cv::imread returns (tested byte for byte) and
 *  declines every file it does not handle, so callers fall back to cv::imread
 *  and keep its behaviour and error messages. */
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace dslam {

/** Decodes the PNG file `path` as cv::imread(path, flags) would, for
 *  non-interlaced 8-bit grey / RGB / RGBA and 16-bit grey images with flags
 *  cv::IMREAD_UNCHANGED, 8-bit grey and 16-bit grey with cv::IMREAD_ANYDEPTH,
 *  8-bit RGB with cv::IMREAD_COLOR and 8-bit grey with cv::IMREAD_GRAYSCALE.
 *  Returns an empty Mat for anything else (other layouts or flags, palette,
 *  transparency or EXIF chunks, a missing, truncated or damaged file: chunk
 *  CRCs and the zlib checksum are verified): use cv::imread then. `damage`
 *  (optional) is set to why when the file must not go to cv::imread either
 *  (see readImageFile), else cleared. */
cv::Mat readPngFast(const std::string& path, int flags, std::string* damage = nullptr);

/** readPngFast(path, flags), or cv::imread(path, flags) when it declines.
 *  A PNG that is damaged (a CRC error in a critical chunk, truncated, image
 *  data that does not inflate, a header libpng refuses) gives an empty Mat
 *  and, in `damage`, why (also in the layouts left to cv::imread: every
 *  PNG's chunks are walked and its image data inflated first):
 *  it is not passed on to cv::imread, whose libpng would print its own
 *  "libpng error: ..." line to stderr before failing as well. So does a
 *  PNG of more than 2^28 pixels (a decompression bomb: a few MB of file
 *  that cv::imread would decode into gigabytes), a JPEG whose markers end
 *  before its end-of-image marker (cut short: libjpeg would decode it into
 *  a frame with a grey bottom part and only print "Premature end of JPEG
 *  file"), and a path that is not a regular file (a folder, a FIFO
 *  cv::imread would wait on). */
cv::Mat readImageFile(const std::string& path, int flags, std::string* damage = nullptr);

/** Writes `m` to `path` in the format its extension names (cv::imencode
 *  with `params`), then the bytes with a checked write. cv::imwrite lets the
 *  codec write the file itself, and on a full disk libpng prints "libpng
 *  error: Write Error" to stderr before failing. Throws DataError naming the
 *  file and, when the write fails, the space left on its disk. */
void writeImageFile(const std::string& path, const cv::Mat& m, const std::vector<int>& params = {});

/** Why readImageFile gave nothing, for messages: its `damage` ("corrupt
 *  PNG: ...", "corrupt JPEG: ...", "PNG of WxH pixels: more than ...") or "corrupt or
 *  unsupported image". */
std::string unreadableImageReason(const std::string& damage);

}  // namespace dslam
