#include "dslam/core/png.h"

#include "dslam/core/error.h"
#include "dslam/core/paths.h"

#include <libdeflate.h>
#include <sys/stat.h>

#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <memory>
#include <vector>

namespace dslam {

namespace {

uint32_t be32(const unsigned char* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

/** The bytes of regular file `path`. Anything else is not opened (a folder
 *  opens and "ends" at LONG_MAX; opening a FIFO waits for a writer): false,
 *  and `not_file` says what it is. */
bool readFile(const std::string& path, std::vector<unsigned char>& buf, std::string& not_file) {
  struct stat st;
  if (stat(path.c_str(), &st) != 0) return false;
  if (!S_ISREG(st.st_mode)) {
    not_file = S_ISDIR(st.st_mode) ? "a folder, not an image file" : "not a regular file";
    return false;
  }
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f || std::fseek(f.get(), 0, SEEK_END) != 0) return false;
  const long n = std::ftell(f.get());
  if (n <= 0 || std::fseek(f.get(), 0, SEEK_SET) != 0) return false;
  buf.resize(static_cast<size_t>(n));
  return std::fread(buf.data(), 1, buf.size(), f.get()) == buf.size();
}

/** Sub filter: each byte plus the byte one pixel before it. The running
 *  pixel stays in registers (one independent chain per channel) instead of
 *  being read back from the bytes just written. */
template <int BPP>
void unSub(unsigned char* c, size_t row) {
  unsigned char left[BPP] = {};
  for (size_t i = 0; i + BPP <= row; i += BPP)
    for (int k = 0; k < BPP; k++) {
      left[k] = static_cast<unsigned char>(c[i + k] + left[k]);
      c[i + k] = left[k];
    }
}

/** Reverses the row filter of `c` (row bytes, `p` the previous unfiltered
 *  row or zeros). False for an unknown filter type. */
bool unfilter(int type, unsigned char* c, const unsigned char* p, size_t row, size_t bpp) {
  switch (type) {
    case 0:
      return true;
    case 1:
      switch (bpp) {
        case 1: unSub<1>(c, row); break;
        case 2: unSub<2>(c, row); break;
        case 3: unSub<3>(c, row); break;
        case 4: unSub<4>(c, row); break;
        default: return false;
      }
      return true;
    case 2:
      for (size_t i = 0; i < row; i++) c[i] = static_cast<unsigned char>(c[i] + p[i]);
      return true;
    case 3:
      for (size_t i = 0; i < bpp; i++) c[i] = static_cast<unsigned char>(c[i] + p[i] / 2);
      for (size_t i = bpp; i < row; i++) c[i] = static_cast<unsigned char>(c[i] + (unsigned(c[i - bpp]) + p[i]) / 2);
      return true;
    case 4:
      for (size_t i = 0; i < bpp; i++) c[i] = static_cast<unsigned char>(c[i] + p[i]);
      for (size_t i = bpp; i < row; i++) {
        const int a = c[i - bpp], b = p[i], d = p[i - bpp];
        const int pa = std::abs(b - d), pb = std::abs(a - d), pc = std::abs(a + b - 2 * d);
        c[i] = static_cast<unsigned char>(c[i] + ((pa <= pb && pa <= pc) ? a : pb <= pc ? b : d));
      }
      return true;
    default:
      return false;
  }
}

/** Larger images are refused before decoding (no camera comes near). */
constexpr uint64_t kMaxPixels = uint64_t(1) << 28;

/** Why the JPEG in `f` is damaged, or "" when it is whole or not a JPEG.
 *  Walks the markers from SOI to EOI: every segment's length, and the
 *  entropy-coded data after each SOS up to its next marker. libjpeg decodes
 *  a file cut short into a picture whose missing part is grey, printing
 *  only "Premature end of JPEG file" to stderr, so a truncated frame would
 *  otherwise be tracked as if the scene had turned grey. */
std::string jpegDamage(const std::vector<unsigned char>& f) {
  if (f.size() < 3 || f[0] != 0xff || f[1] != 0xd8 || f[2] != 0xff) return "";
  const size_t n = f.size();
  auto truncated = [&](const std::string& where) {
    return "corrupt JPEG: truncated: the file (" + std::to_string(n) + " bytes) ends " + where +
           ", before the end-of-image marker";
  };
  size_t pos = 2;
  while (true) {
    if (pos >= n) return truncated("after byte " + std::to_string(n));
    if (f[pos] != 0xff) return "corrupt JPEG: no marker at byte " + std::to_string(pos);
    while (pos < n && f[pos] == 0xff) pos++;  // fill bytes
    if (pos >= n) return truncated("inside a marker");
    const unsigned m = f[pos++];
    if (m == 0xd9) return "";  // EOI; anything after it is ignored, as libjpeg does
    if (m == 0x01 || (m >= 0xd0 && m <= 0xd7)) continue;  // no length
    if (pos + 2 > n) return truncated("inside a segment header");
    const size_t len = (size_t(f[pos]) << 8) | f[pos + 1];
    if (len < 2) return "corrupt JPEG: segment length " + std::to_string(len) + " at byte " + std::to_string(pos);
    if (pos + len > n)
      return truncated("inside a segment of " + std::to_string(len) + " bytes at byte " + std::to_string(pos - 2));
    pos += len;
    if (m != 0xda) continue;
    // Entropy-coded data: 0xff is followed by 0x00 (a stuffed byte) or a
    // restart marker inside it; anything else starts the next segment.
    while (true) {
      const void* ff = std::memchr(&f[pos], 0xff, n - pos);
      if (!ff) return truncated("inside the image data");
      pos = static_cast<size_t>(static_cast<const unsigned char*>(ff) - f.data());
      if (pos + 1 >= n) return truncated("inside the image data");
      const unsigned next = f[pos + 1];
      if (next == 0x00 || (next >= 0xd0 && next <= 0xd7) || next == 0xff) {
        pos += next == 0xff ? 1 : 2;
        continue;
      }
      break;
    }
  }
}

/** readPngFast on the bytes of the file. */
cv::Mat decodePng(const std::vector<unsigned char>& file, int flags, std::string* damage) {
  thread_local std::vector<unsigned char> idat, raw;
  if (damage) damage->clear();
  // A damaged PNG (libpng would fail on it too, after printing its own
  // "libpng error: ..." line): says why and returns nothing.
  auto damaged = [&](const std::string& why) {
    if (damage) *damage = "corrupt PNG: " + why;
    return cv::Mat();
  };
  auto chunkName = [](const unsigned char* t) {
    std::string n;
    for (int i = 0; i < 4; i++) n += std::isalpha(t[i]) ? static_cast<char>(t[i]) : '?';
    return n;
  };
  static const unsigned char kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (file.size() < 8 + 25 || std::memcmp(file.data(), kSig, 8) != 0) return {};
  // Chunks: IHDR first, IDATs, IEND; ancillary chunks that change what
  // cv::imread returns (tRNS adds alpha, eXIf rotates), unknown critical
  // ones (PLTE) and layouts decoded below only in part (interlaced,
  // palette, 16-bit colour, grey with alpha) make us decline, but only after
  // every chunk's length and CRC and the image data's zlib stream are
  // checked: cv::imread would print libpng's error line for those too.
  uint32_t w = 0, h = 0;
  int depth = 0, color = -1;
  bool ended = false, decline = false, interlaced = false;
  idat.clear();
  for (size_t pos = 8; pos + 12 <= file.size();) {
    const uint32_t len = be32(&file[pos]);
    const unsigned char* type = &file[pos + 4];
    if (len > file.size() - pos - 12)
      return damaged("truncated: chunk " + chunkName(type) + " of " + std::to_string(len) + " bytes at byte " +
                     std::to_string(pos) + " runs past the end of the file (" + std::to_string(file.size()) +
                     " bytes)");
    const unsigned char* data = type + 4;
    if (libdeflate_crc32(0, type, len + 4) != be32(data + len)) {
      if (!(type[0] & 0x20)) return damaged("CRC error in chunk " + chunkName(type) + " at byte " + std::to_string(pos));
      decline = true;  // an ancillary chunk: libpng drops it with a warning
    }
    const std::string t(reinterpret_cast<const char*>(type), 4);
    if (pos == 8) {
      if (t != "IHDR" || len != 13) return {};
      w = be32(data);
      h = be32(data + 4);
      depth = data[8];
      color = data[9];
      if (uint64_t(w) * h > kMaxPixels) {  // a decompression bomb: a few MB that decode to gigabytes
        if (damage)
          *damage = "PNG of " + std::to_string(w) + "x" + std::to_string(h) + " pixels: more than the " +
                    std::to_string(kMaxPixels) + " (2^28) pixels dslam reads";
        return {};
      }
      const bool valid_depth =
          (color == 0 && (depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16)) ||
          (color == 3 && (depth == 1 || depth == 2 || depth == 4 || depth == 8)) ||
          ((color == 2 || color == 4 || color == 6) && (depth == 8 || depth == 16));
      if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu || !valid_depth || data[10] != 0 || data[11] != 0 ||
          data[12] > 1)
        return damaged("invalid header (IHDR): " + std::to_string(w) + "x" + std::to_string(h) + " pixels, colour type " +
                       std::to_string(color) + ", bit depth " + std::to_string(depth) + ", compression " +
                       std::to_string(data[10]) + ", filter " + std::to_string(data[11]) + ", interlace " +
                       std::to_string(data[12]));
      interlaced = data[12] == 1;
      decline = decline || interlaced;
    } else if (t == "IDAT") {
      idat.insert(idat.end(), data, data + len);
    } else if (t == "IEND") {
      ended = true;
      break;
    } else if (!(type[0] & 0x20) || t == "tRNS" || t == "eXIf") {
      decline = true;
    }
    pos += 12 + size_t(len);
  }
  if (!ended && w != 0) return damaged("truncated: the file ends without an IEND chunk");
  if (!ended || w == 0) return {};
  const int channels = color == 0 ? 1 : color == 2 ? 3 : color == 6 ? 4 : 0;
  const bool ok_flags = flags == cv::IMREAD_UNCHANGED || (flags == cv::IMREAD_ANYDEPTH && channels == 1) ||
                        (flags == cv::IMREAD_COLOR && channels == 3 && depth == 8) ||
                        (flags == cv::IMREAD_GRAYSCALE && channels == 1 && depth == 8);
  decline = decline || channels == 0 || (depth != 8 && !(depth == 16 && channels == 1)) || !ok_flags;

  // Inflate into the size the layout needs (declined layouts too: whether
  // their data is a valid zlib stream).
  const int samples = color == 0 || color == 3 ? 1 : color == 4 ? 2 : color == 2 ? 3 : 4;
  const uint64_t bits = uint64_t(samples) * uint64_t(depth);
  auto rows = [&](uint64_t pw, uint64_t ph) { return pw == 0 || ph == 0 ? 0 : ph * ((pw * bits + 7) / 8 + 1); };
  uint64_t need = 0;
  if (!interlaced) {
    need = rows(w, h);
  } else {  // Adam7: the seven passes' sub-images
    static const uint32_t kPass[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                                         {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};
    for (const auto& q : kPass)
      need += rows(w > q[0] ? (w - q[0] + q[2] - 1) / q[2] : 0, h > q[1] ? (h - q[1] + q[3] - 1) / q[3] : 0);
  }
  raw.resize(static_cast<size_t>(need));
  thread_local std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)> inflater(
      libdeflate_alloc_decompressor(), &libdeflate_free_decompressor);
  size_t got = 0;
  if (!inflater) return {};
  const libdeflate_result r =
      libdeflate_zlib_decompress(inflater.get(), idat.data(), idat.size(), raw.data(), raw.size(), &got);
  if (r == LIBDEFLATE_BAD_DATA) return damaged("the image data (IDAT) is not a valid zlib stream");
  if (decline || r != LIBDEFLATE_SUCCESS || got != raw.size()) return {};
  const size_t bpp = size_t(channels) * size_t(depth / 8), row = bpp * w;

  cv::Mat out(static_cast<int>(h), static_cast<int>(w), CV_MAKETYPE(depth == 8 ? CV_8U : CV_16U, channels));
  const std::vector<unsigned char> zeros(row, 0);
  for (uint32_t y = 0; y < h; y++) {
    unsigned char* c = &raw[y * (row + 1)];
    const unsigned char* p = y > 0 ? &raw[(y - 1) * (row + 1) + 1] : zeros.data();
    if (!unfilter(c[0], c + 1, p, row, bpp)) return {};
    c++;
    unsigned char* o = out.ptr<unsigned char>(static_cast<int>(y));
    if (depth == 16) {  // big-endian samples
      auto* o16 = reinterpret_cast<uint16_t*>(o);
      for (size_t i = 0; i < w; i++) {
        uint16_t v;
        std::memcpy(&v, c + 2 * i, 2);
        o16[i] = __builtin_bswap16(v);
      }
    } else if (channels == 1) {
      std::memcpy(o, c, row);
    } else {  // RGB(A) -> BGR(A)
      for (size_t i = 0; i < row; i += bpp) {
        o[i] = c[i + 2];
        o[i + 1] = c[i + 1];
        o[i + 2] = c[i];
        if (bpp == 4) o[i + 3] = c[i + 3];
      }
    }
  }
  return out;
}

}  // namespace

cv::Mat readPngFast(const std::string& path, int flags, std::string* damage) {
  thread_local std::vector<unsigned char> file;
  if (damage) damage->clear();
  if (std::string not_file; !readFile(path, file, not_file)) {
    if (damage) *damage = not_file;
    return {};
  }
  return decodePng(file, flags, damage);
}

cv::Mat readImageFile(const std::string& path, int flags, std::string* damage) {
  thread_local std::vector<unsigned char> file;
  std::string why;
  cv::Mat m;
  if (readFile(path, file, why)) {
    m = decodePng(file, flags, &why);
    if (m.empty() && why.empty()) why = jpegDamage(file);
    if (m.empty() && why.empty()) m = cv::imread(path, flags);
  }
  if (damage) *damage = why;
  return m;
}

void writeImageFile(const std::string& path, const cv::Mat& m, const std::vector<int>& params) {
  thread_local std::vector<unsigned char> bytes;
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext.empty() || !cv::haveImageWriter(path))
    throw DataError("cannot write image " + path + " (no image format for the extension '" + ext + "')");
  bool encoded = false;
  try {
    encoded = cv::imencode(ext, m, bytes, params);
  } catch (const cv::Exception& e) {
    throw DataError("cannot write image " + path + ": " + e.err);
  }
  if (!encoded) throw DataError("cannot write image " + path + ": the " + ext + " encoder refused it");
  auto failed = [&] { return DataError("cannot write image " + path + freeSpaceNote(path)); };
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw failed();
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  if (std::fclose(f) != 0 || !written) throw failed();  // fclose flushes: a full disk shows here
}

std::string unreadableImageReason(const std::string& damage) {
  return damage.empty() ? "corrupt or unsupported image" : damage;
}

}  // namespace dslam
