#include "dslam/features/orb_extractor.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <numeric>
#include <string>

#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/core/error.h"
#include "orb_pattern.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace dslam {

namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/** CPU time of the calling thread, ms (robust to other processes' load). */
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/** Fills the `b`-pixel frame around the inner region of `padded` by
 *  BORDER_REFLECT_101 of the inner region (in place, no copy of the inner). */
void fillBorderReflect101(cv::Mat& padded, int b) {
  const int W = padded.cols, H = padded.rows, w = W - 2 * b, h = H - 2 * b;
  std::vector<int> xl(b), xr(b);
  for (int k = 0; k < b; k++) {
    xl[k] = b + cv::borderInterpolate(k - b, w, cv::BORDER_REFLECT_101);
    xr[k] = b + cv::borderInterpolate(w + k, w, cv::BORDER_REFLECT_101);
  }
  for (int y = b; y < b + h; y++) {
    uint8_t* row = padded.ptr<uint8_t>(y);
    for (int k = 0; k < b; k++) {
      row[k] = row[xl[k]];
      row[b + w + k] = row[xr[k]];
    }
  }
  for (int k = 0; k < b; k++) {
    const int yt = b + cv::borderInterpolate(k - b, h, cv::BORDER_REFLECT_101);
    const int yb = b + cv::borderInterpolate(h + k, h, cv::BORDER_REFLECT_101);
    std::memcpy(padded.ptr<uint8_t>(k), padded.ptr<uint8_t>(yt), W);
    std::memcpy(padded.ptr<uint8_t>(b + h + k), padded.ptr<uint8_t>(yb), W);
  }
}

/** Intensity-centroid orientation (degrees) of the circular patch of radius
 *  `half` around integer pixel (x, y). */
float icAngle(const cv::Mat& img, int x, int y, int half, const std::vector<int>& umax) {
  int m01 = 0, m10 = 0;
  const uint8_t* center = img.ptr<uint8_t>(y) + x;
  for (int u = -half; u <= half; ++u) m10 += u * center[u];
  const int step = static_cast<int>(img.step1());
  for (int v = 1; v <= half; ++v) {
    int v_sum = 0;
    const int d = umax[v];
    for (int u = -d; u <= d; ++u) {
      const int val_plus = center[u + v * step], val_minus = center[u - v * step];
      v_sum += val_plus - val_minus;
      m10 += u * (val_plus + val_minus);
    }
    m01 += v * v_sum;
  }
  return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
}

/** The pattern as floats, x and y split (for the rotation loop). */
struct FloatPattern {
  alignas(16) float x[512];
  alignas(16) float y[512];
  FloatPattern() {
    for (int i = 0; i < 512; i++) {
      x[i] = static_cast<float>(detail::kOrbBitPattern31[2 * i]);
      y[i] = static_cast<float>(detail::kOrbBitPattern31[2 * i + 1]);
    }
  }
};
const FloatPattern& floatPattern() {
  static const FloatPattern p;
  return p;
}

/** Oriented BRIEF of the keypoint at integer pixel (x, y) of the blurred
 *  level image, rotating the learned pattern by `angle_deg`. The rotated
 *  sample positions are rounded to nearest-even as OpenCV's cvRound, so the
 *  bits equal cv::ORB's for the same image, position and angle. */
void briefDescriptor(const cv::Mat& img, int x, int y, float angle_deg, uint8_t* desc) {
  const float angle = angle_deg * static_cast<float>(CV_PI / 180.0);
  const float a = static_cast<float>(std::cos(angle)), b = static_cast<float>(std::sin(angle));
  const uint8_t* center = img.ptr<uint8_t>(y) + x;
  const int step = static_cast<int>(img.step);
  const FloatPattern& P = floatPattern();
  alignas(16) int off[512];
#if defined(__SSE2__)
  const __m128 va = _mm_set1_ps(a), vb = _mm_set1_ps(b), vstep = _mm_set1_ps(static_cast<float>(step));
  for (int i = 0; i < 512; i += 4) {
    const __m128 px = _mm_load_ps(P.x + i), py = _mm_load_ps(P.y + i);
    const __m128 rx = _mm_sub_ps(_mm_mul_ps(px, va), _mm_mul_ps(py, vb));
    const __m128 ry = _mm_add_ps(_mm_mul_ps(px, vb), _mm_mul_ps(py, va));
    // Round to nearest even (the default MXCSR mode, as cvRound), then
    // iy * step + ix, exact in float for these small integers.
    const __m128 fx = _mm_cvtepi32_ps(_mm_cvtps_epi32(rx)), fy = _mm_cvtepi32_ps(_mm_cvtps_epi32(ry));
    _mm_store_si128(reinterpret_cast<__m128i*>(off + i), _mm_cvtps_epi32(_mm_add_ps(_mm_mul_ps(fy, vstep), fx)));
  }
#else
  for (int i = 0; i < 512; i++)
    off[i] = cvRound(P.x[i] * b + P.y[i] * a) * step + cvRound(P.x[i] * a - P.y[i] * b);
#endif
  for (int i = 0; i < 32; ++i) {
    const int* o = off + 16 * i;
    int val = 0;
    for (int k = 0; k < 8; k++) val |= (center[o[2 * k]] < center[o[2 * k + 1]]) << k;
    desc[i] = static_cast<uint8_t>(val);
  }
}

/** One quadtree node (ORB-SLAM ExtractorNode): box [x0, x1) x [y0, y1) and the
 *  indices of the keypoints inside. */
struct QNode {
  int x0, y0, x1, y1;
  std::vector<int> idx;
  bool no_more = false;
  bool alive = true;
};

/** ORB-SLAM2 DistributeOctTree on keypoints with coordinates relative to the
 *  detection area [0, width) x [0, height): splits the area into quadrants
 *  until there are at least `n` nodes (or no node can be split), then keeps
 *  the strongest keypoint of each node; finally at most `n` (strongest).
 *  Ties are broken by creation order, so the result is deterministic.
 *  Returns indices into `kps`. */
std::vector<int> distributeQuadtree(const std::vector<cv::KeyPoint>& kps, int width, int height, int n) {
  std::vector<int> out;
  if (kps.empty() || n <= 0) return out;
  std::vector<QNode> nodes;
  nodes.reserve(4 * static_cast<size_t>(n) + 64);
  int alive = 0;

  const int n_ini = std::max(1, static_cast<int>(std::round(static_cast<float>(width) / height)));
  const float hx = static_cast<float>(width) / n_ini;
  for (int i = 0; i < n_ini; i++) {
    QNode q;
    q.x0 = static_cast<int>(hx * i);
    q.x1 = static_cast<int>(hx * (i + 1));
    q.y0 = 0;
    q.y1 = height;
    nodes.push_back(std::move(q));
  }
  for (int i = 0; i < static_cast<int>(kps.size()); i++) {
    const int c = std::clamp(static_cast<int>(kps[i].pt.x / hx), 0, n_ini - 1);
    nodes[c].idx.push_back(i);
  }
  for (auto& q : nodes) {
    if (q.idx.empty()) q.alive = false;
    else {
      alive++;
      q.no_more = q.idx.size() == 1;
    }
  }

  // Splits node k into its non-empty children; children with more than one
  // keypoint are appended to `expandable`. Returns nothing; updates `alive`.
  auto divide = [&](int k, std::vector<int>& expandable) {
    const QNode parent = std::move(nodes[k]);
    nodes[k].alive = false;
    nodes[k].idx.clear();
    alive--;
    const int half_x = static_cast<int>(std::ceil((parent.x1 - parent.x0) / 2.0f));
    const int half_y = static_cast<int>(std::ceil((parent.y1 - parent.y0) / 2.0f));
    const int mx = parent.x0 + half_x, my = parent.y0 + half_y;
    QNode c[4];
    c[0].x0 = parent.x0, c[0].y0 = parent.y0, c[0].x1 = mx, c[0].y1 = my;
    c[1].x0 = mx, c[1].y0 = parent.y0, c[1].x1 = parent.x1, c[1].y1 = my;
    c[2].x0 = parent.x0, c[2].y0 = my, c[2].x1 = mx, c[2].y1 = parent.y1;
    c[3].x0 = mx, c[3].y0 = my, c[3].x1 = parent.x1, c[3].y1 = parent.y1;
    for (int i : parent.idx) {
      const cv::Point2f& p = kps[i].pt;
      const int ci = (p.x < mx ? 0 : 1) + (p.y < my ? 0 : 2);
      c[ci].idx.push_back(i);
    }
    for (auto& ch : c) {
      if (ch.idx.empty()) continue;
      // A box that cannot shrink any more keeps its points (cannot happen
      // with FAST output, whose corners have distinct pixel positions).
      ch.no_more = ch.idx.size() == 1 || (ch.x1 - ch.x0 <= 1 && ch.y1 - ch.y0 <= 1);
      const bool expand = !ch.no_more;
      nodes.push_back(std::move(ch));
      alive++;
      if (expand) expandable.push_back(static_cast<int>(nodes.size()) - 1);
    }
  };

  bool finish = false;
  std::vector<int> expandable, current;
  for (int iter = 0; !finish && iter < 10000; iter++) {
    const int prev = alive;
    expandable.clear();
    current.clear();
    for (int k = 0; k < static_cast<int>(nodes.size()); k++)
      if (nodes[k].alive && !nodes[k].no_more) current.push_back(k);
    for (int k : current) divide(k, expandable);

    if (alive >= n || alive == prev) {
      finish = true;
    } else if (alive + 3 * static_cast<int>(expandable.size()) > n) {
      // Close to the target: split the most populated nodes first.
      while (!finish) {
        const int prev2 = alive;
        std::vector<int> todo;
        todo.swap(expandable);
        std::stable_sort(todo.begin(), todo.end(),
                         [&](int a, int b) { return nodes[a].idx.size() < nodes[b].idx.size(); });
        for (int j = static_cast<int>(todo.size()) - 1; j >= 0; j--) {
          divide(todo[j], expandable);
          if (alive >= n) break;
        }
        if (alive >= n || alive == prev2) finish = true;
      }
    }
  }

  // Strongest keypoint of each node.
  for (const auto& q : nodes) {
    if (!q.alive) continue;
    int best = q.idx[0];
    for (size_t k = 1; k < q.idx.size(); k++)
      if (kps[q.idx[k]].response > kps[best].response) best = q.idx[k];
    out.push_back(best);
  }
  if (static_cast<int>(out.size()) > n) {
    std::vector<int> order(out.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return kps[out[a]].response > kps[out[b]].response; });
    order.resize(n);
    std::sort(order.begin(), order.end());
    std::vector<int> kept;
    kept.reserve(n);
    for (int o : order) kept.push_back(out[o]);
    out.swap(kept);
  }
  return out;
}

}  // namespace

void OrbParams::validate() const {
  auto bad = [](const std::string& what) { throw ConfigError("ORB parameters: " + what); };
  if (n_features < 0) bad("n_features must be >= 0 (got " + std::to_string(n_features) + ")");
  if (!(scale_factor > 1.0f) || !(scale_factor < 4.0f))
    bad("scale_factor must be in (1, 4) (got " + std::to_string(scale_factor) + ")");
  if (n_levels < 1 || n_levels > 32) bad("n_levels must be in [1, 32] (got " + std::to_string(n_levels) + ")");
  if (ini_th_fast < 1 || ini_th_fast > 254) bad("ini_th_fast must be in [1, 254] (got " + std::to_string(ini_th_fast) + ")");
  if (min_th_fast < 1 || min_th_fast > ini_th_fast)
    bad("min_th_fast must be in [1, ini_th_fast] (got " + std::to_string(min_th_fast) + ")");
}

OrbExtractor::OrbExtractor(const Params& p) : p_(p) {
  p_.validate();
  const int nl = p_.n_levels;
  scale_.resize(nl);
  sigma2_.resize(nl);
  inv_scale_.resize(nl);
  inv_sigma2_.resize(nl);
  scale_[0] = 1.0f;
  sigma2_[0] = 1.0f;
  for (int i = 1; i < nl; i++) {
    scale_[i] = scale_[i - 1] * p_.scale_factor;
    sigma2_[i] = scale_[i] * scale_[i];
  }
  for (int i = 0; i < nl; i++) {
    inv_scale_[i] = 1.0f / scale_[i];
    inv_sigma2_[i] = 1.0f / sigma2_[i];
  }
  computeQuotas();

  // umax: end of each row of the circular orientation patch (ORB-SLAM2).
  umax_.resize(kHalfPatchSize + 1);
  const int vmax = cvFloor(kHalfPatchSize * std::sqrt(2.f) / 2 + 1);
  const int vmin = cvCeil(kHalfPatchSize * std::sqrt(2.f) / 2);
  const double hp2 = kHalfPatchSize * kHalfPatchSize;
  for (int v = 0; v <= vmax; ++v) umax_[v] = cvRound(std::sqrt(hp2 - v * v));
  for (int v = kHalfPatchSize, v0 = 0; v >= vmin; --v) {  // make it symmetric
    while (umax_[v0] == umax_[v0 + 1]) ++v0;
    umax_[v] = v0;
    ++v0;
  }
  padded_.resize(nl);
  levels_.resize(nl);
  blurred_padded_.resize(nl);
  blurred_.resize(nl);
  detect_ms_.assign(nl, 0.0);
  describe_ms_.assign(nl, 0.0);
}

void OrbExtractor::setFeatureCount(int n) {
  if (n < 0) throw ConfigError("ORB feature count must be >= 0 (got " + std::to_string(n) + ")");
  if (n == p_.n_features) return;
  p_.n_features = n;
  computeQuotas();
}

void OrbExtractor::computeQuotas() {
  const int nl = p_.n_levels;
  per_level_.assign(nl, 0);
  const float factor = 1.0f / p_.scale_factor;
  float desired = p_.n_features * (1 - factor) / (1 - static_cast<float>(std::pow(double(factor), double(nl))));
  int sum = 0;
  for (int l = 0; l < nl - 1; l++) {
    per_level_[l] = cvRound(desired);
    sum += per_level_[l];
    desired *= factor;
  }
  per_level_[nl - 1] = std::max(p_.n_features - sum, 0);
}

void OrbExtractor::buildPyramid(const cv::Mat& gray) {
  const int b = kEdgeThreshold;
  for (int l = 0; l < p_.n_levels; l++) {
    const cv::Size sz(cvRound(gray.cols * inv_scale_[l]), cvRound(gray.rows * inv_scale_[l]));
    const cv::Size whole(sz.width + 2 * b, sz.height + 2 * b);
    padded_[l].create(whole, CV_8UC1);
    blurred_padded_[l].create(whole, CV_8UC1);
    levels_[l] = padded_[l](cv::Rect(b, b, sz.width, sz.height));
    blurred_[l] = blurred_padded_[l](cv::Rect(b, b, sz.width, sz.height));
    if (sz.width < 1 || sz.height < 1) continue;
    if (l == 0) gray.copyTo(levels_[0]);
    else cv::resize(levels_[l - 1], levels_[l], sz, 0, 0, cv::INTER_LINEAR);
    fillBorderReflect101(padded_[l], b);
  }
}

void OrbExtractor::extract(const cv::Mat& gray, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                           const cv::Mat& mask) {
  if (gray.empty()) throw DataError("ORB extractor: empty image");
  if (gray.type() != CV_8UC1)
    throw DataError("ORB extractor: expected an 8-bit grey image (CV_8UC1), got type " + std::to_string(gray.type()));
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != gray.size()))
    throw DataError("ORB extractor: mask must be CV_8UC1 of the image size " + std::to_string(gray.cols) + "x" +
                    std::to_string(gray.rows) + " (got " + std::to_string(mask.cols) + "x" +
                    std::to_string(mask.rows) + ", type " + std::to_string(mask.type()) + ")");
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = threadCpuMs();
  timings_ = OrbTimings{};
  buildPyramid(gray);
  timings_.pyramid_ms = threadCpuMs() - c0;

  const int nl = p_.n_levels;
  std::vector<std::vector<cv::KeyPoint>> kps(nl);
  std::vector<cv::Mat> desc(nl);
  auto run = [&](int l) {
    processLevel(l, mask, kps[l], desc[l]);
  };
  if (p_.parallel_levels && nl > 1) {
    // Levels are independent and write only their own outputs.
    cv::parallel_for_(cv::Range(0, nl), [&](const cv::Range& r) {
      for (int l = r.start; l < r.end; l++) run(l);
    }, nl);
  } else {
    for (int l = 0; l < nl; l++) run(l);
  }

  size_t total = 0;
  for (const auto& k : kps) total += k.size();
  keypoints.clear();
  keypoints.reserve(total);
  descriptors.create(static_cast<int>(total), 32, CV_8U);
  int row = 0;
  for (int l = 0; l < nl; l++) {
    keypoints.insert(keypoints.end(), kps[l].begin(), kps[l].end());
    if (!kps[l].empty()) desc[l].copyTo(descriptors.rowRange(row, row + desc[l].rows));
    row += desc[l].rows;
  }
  // Stage CPU times are summed over the levels.
  for (int l = 0; l < nl; l++) {
    timings_.detect_ms += detect_ms_[l];
    timings_.describe_ms += describe_ms_[l];
  }
  timings_.total_ms = msSince(t0);
}

void OrbExtractor::processLevel(int level, const cv::Mat& mask, std::vector<cv::KeyPoint>& out, cv::Mat& desc) {
  const double t0 = threadCpuMs();
  out.clear();
  const cv::Mat& img = levels_[level];
  const int quota = per_level_[level];
  // Detection area as ORB-SLAM2: FAST needs 3 pixels around each corner,
  // the patches 19; corners are found in [minB + 3, maxB - 3).
  const int min_b = kEdgeThreshold - 3;
  const int max_bx = img.cols - kEdgeThreshold + 3, max_by = img.rows - kEdgeThreshold + 3;
  const int width = max_bx - min_b, height = max_by - min_b;
  const int n_cols = width / kCellSize, n_rows = height / kCellSize;
  if (quota <= 0 || n_cols < 1 || n_rows < 1) {
    desc.release();
    detect_ms_[level] = threadCpuMs() - t0;
    describe_ms_[level] = 0;
    return;
  }
  const int w_cell = static_cast<int>(std::ceil(static_cast<float>(width) / n_cols));
  const int h_cell = static_cast<int>(std::ceil(static_cast<float>(height) / n_rows));
  const float scale = scale_[level];
  auto allowed = [&](float lx, float ly) {  // level pixel -> mask at level 0
    if (mask.empty()) return true;
    const int x = std::clamp(cvRound(lx * scale), 0, mask.cols - 1);
    const int y = std::clamp(cvRound(ly * scale), 0, mask.rows - 1);
    return mask.at<uint8_t>(y, x) != 0;
  };

  // FAST at the initial threshold over the whole area (equivalent to one call
  // per cell, as each cell's corners lie in [ini + 3, ini + cell + 3)), then
  // the fallback threshold in the cells left empty.
  std::vector<cv::KeyPoint> all, cell_kps;
  const cv::Rect area(min_b, min_b, width, height);
  cv::FAST(img(area), all, p_.ini_th_fast, true);
  std::vector<int> cell_count(static_cast<size_t>(n_cols) * n_rows, 0);
  std::vector<cv::KeyPoint> cand;  // coordinates relative to the area
  cand.reserve(all.size() + 256);
  for (const auto& k : all) {
    if (!allowed(k.pt.x + min_b, k.pt.y + min_b)) continue;
    const int cx = std::min((static_cast<int>(k.pt.x) - 3) / w_cell, n_cols - 1);
    const int cy = std::min((static_cast<int>(k.pt.y) - 3) / h_cell, n_rows - 1);
    cell_count[cy * n_cols + cx]++;
    cand.push_back(k);
  }
  // Fallback: one FAST call per horizontal run of empty cells (fewer, wider
  // calls keep OpenCV's SIMD path busy).
  for (int i = 0; i < n_rows; i++) {
    const int ini_y = min_b + i * h_cell;
    if (ini_y >= max_by - 3) continue;
    const int max_y = std::min(ini_y + h_cell + 6, max_by);
    for (int j = 0; j < n_cols;) {
      auto usable = [&](int jj) { return min_b + jj * w_cell < max_bx - 6 && cell_count[i * n_cols + jj] == 0; };
      if (!usable(j)) {
        j++;
        continue;
      }
      int j2 = j;
      while (j2 + 1 < n_cols && usable(j2 + 1)) j2++;
      const int ini_x = min_b + j * w_cell;
      const int max_x = std::min(min_b + j2 * w_cell + w_cell + 6, max_bx);
      cv::FAST(img(cv::Rect(ini_x, ini_y, max_x - ini_x, max_y - ini_y)), cell_kps, p_.min_th_fast, true);
      for (auto k : cell_kps) {
        k.pt.x += static_cast<float>(ini_x - min_b);
        k.pt.y += static_cast<float>(ini_y - min_b);
        if (allowed(k.pt.x + min_b, k.pt.y + min_b)) cand.push_back(k);
      }
      j = j2 + 1;
    }
  }

  const std::vector<int> sel = distributeQuadtree(cand, width, height, quota);
  out.reserve(sel.size());
  const float size = kPatchSize * scale;
  for (int i : sel) {
    cv::KeyPoint k = cand[i];
    k.pt.x += static_cast<float>(min_b);
    k.pt.y += static_cast<float>(min_b);
    k.octave = level;
    k.size = size;
    k.class_id = -1;
    k.angle = icAngle(img, static_cast<int>(k.pt.x), static_cast<int>(k.pt.y), kHalfPatchSize, umax_);
    out.push_back(k);
  }
  const double t1 = threadCpuMs();

  // Descriptors on the blurred level (the border rows are filled by the
  // reflected padding of the level, as BORDER_REFLECT_101 of the level).
  desc.create(static_cast<int>(out.size()), 32, CV_8U);
  if (!out.empty()) {
    cv::GaussianBlur(img, blurred_[level], cv::Size(7, 7), 2, 2, cv::BORDER_REFLECT_101);
    for (size_t i = 0; i < out.size(); i++)
      briefDescriptor(blurred_[level], static_cast<int>(out[i].pt.x), static_cast<int>(out[i].pt.y), out[i].angle,
                      desc.ptr<uint8_t>(static_cast<int>(i)));
    if (level != 0)
      for (auto& k : out) k.pt *= scale;
  }
  const double t2 = threadCpuMs();
  detect_ms_[level] = t1 - t0;
  describe_ms_[level] = t2 - t1;
}

}  // namespace dslam
