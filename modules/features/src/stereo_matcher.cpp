#include "dslam/features/stereo_matcher.h"

#include <algorithm>
#include <optional>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <string>
#include <utility>

#include "dslam/core/error.h"
#include "dslam/core/descriptor.h"
#include "dslam/features/orb_extractor.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace dslam {

namespace {

/** Sum of absolute differences between the (2w+1)^2 windows centred at
 *  (xl, y) of `L` and (xr, y) of `R` after removing the brightness offset
 *  `off` (right - left). */
int sadWindow(const cv::Mat& L, int xl, const cv::Mat& R, int xr, int y, int w, int off) {
  int sum = 0;
#if defined(__SSE2__)
  // 16 pixels per row load; valid because the pyramid levels are views with
  // OrbExtractor::kEdgeThreshold (19) pixels of padding on each side, so a
  // row read of 16 bytes from x - w (x + w inside the level) stays inside.
  static_assert(OrbExtractor::kEdgeThreshold >= 16, "SAD row loads need the pyramid padding");
  if (2 * w + 1 <= 16) {
    const __m128i zero = _mm_setzero_si128();
    const __m128i voff = _mm_set1_epi16(static_cast<int16_t>(off));
    alignas(16) int16_t mask_lo[8], mask_hi[8];
    for (int k = 0; k < 8; k++) {
      mask_lo[k] = k < 2 * w + 1 ? -1 : 0;
      mask_hi[k] = k + 8 < 2 * w + 1 ? -1 : 0;
    }
    const __m128i mlo = _mm_load_si128(reinterpret_cast<const __m128i*>(mask_lo));
    const __m128i mhi = _mm_load_si128(reinterpret_cast<const __m128i*>(mask_hi));
    const __m128i ones = _mm_set1_epi16(1);
    __m128i acc = _mm_setzero_si128();
    for (int dy = -w; dy <= w; dy++) {
      const __m128i l = _mm_loadu_si128(reinterpret_cast<const __m128i*>(L.ptr<uint8_t>(y + dy) + xl - w));
      const __m128i r = _mm_loadu_si128(reinterpret_cast<const __m128i*>(R.ptr<uint8_t>(y + dy) + xr - w));
      __m128i dlo = _mm_add_epi16(_mm_sub_epi16(_mm_unpacklo_epi8(l, zero), _mm_unpacklo_epi8(r, zero)), voff);
      __m128i dhi = _mm_add_epi16(_mm_sub_epi16(_mm_unpackhi_epi8(l, zero), _mm_unpackhi_epi8(r, zero)), voff);
      dlo = _mm_and_si128(_mm_max_epi16(dlo, _mm_sub_epi16(zero, dlo)), mlo);
      dhi = _mm_and_si128(_mm_max_epi16(dhi, _mm_sub_epi16(zero, dhi)), mhi);
      acc = _mm_add_epi32(acc, _mm_madd_epi16(_mm_add_epi16(dlo, dhi), ones));
    }
    alignas(16) int32_t part[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(part), acc);
    return part[0] + part[1] + part[2] + part[3];
  }
#endif
  for (int dy = -w; dy <= w; dy++) {
    const uint8_t* pl = L.ptr<uint8_t>(y + dy) + xl - w;
    const uint8_t* pr = R.ptr<uint8_t>(y + dy) + xr - w;
    for (int k = 0; k <= 2 * w; k++) sum += std::abs(static_cast<int>(pl[k]) - static_cast<int>(pr[k]) + off);
  }
  return sum;
}

/** Sums of the 2w+1 pixels of rows [y - w, y + w] in columns [x0, x0 + n). */
void columnSums(const cv::Mat& I, int x0, int n, int y, int w, std::vector<int>& out) {
  out.assign(n, 0);
  for (int dy = -w; dy <= w; dy++) {
    const uint8_t* p = I.ptr<uint8_t>(y + dy) + x0;
    for (int k = 0; k < n; k++) out[k] += p[k];
  }
}

}  // namespace

namespace {

/** Right keypoints by image row, each registered in its +-row_radius band. */
std::vector<std::vector<int>> rowIndex(const OrbExtractor& right, const std::vector<cv::KeyPoint>& kps_r, int rows,
                                       float row_radius) {
  std::vector<std::vector<int>> row_idx(rows);
  for (int ir = 0; ir < static_cast<int>(kps_r.size()); ir++) {
    const cv::KeyPoint& k = kps_r[ir];
    const int oct = std::clamp(k.octave, 0, static_cast<int>(right.scaleFactors().size()) - 1);
    const float r = row_radius * right.scaleFactors()[oct];
    const int maxr = std::min(rows - 1, static_cast<int>(std::ceil(k.pt.y + r)));
    const int minr = std::max(0, static_cast<int>(std::floor(k.pt.y - r)));
    for (int y = minr; y <= maxr; y++) row_idx[y].push_back(ir);
  }
  return row_idx;
}

/** Best right keypoint by descriptor among `cands` (octave +-1, disparity in
 *  [min_u, max_u]); -1 if none is below th_high. */
int bestRowMatch(const uint8_t* dl, int level, const std::vector<int>& cands, const std::vector<cv::KeyPoint>& kps_r,
                 const cv::Mat& desc_r, float min_u, float max_u, int th_high, int& best_dist) {
  best_dist = th_high;
  int best_r = -1;
  for (int ir : cands) {
    const cv::KeyPoint& kr = kps_r[ir];
    if (kr.octave < level - 1 || kr.octave > level + 1) continue;
    const float ur = kr.pt.x;
    if (ur >= min_u && ur <= max_u) {
      const int d = descriptorDistance(dl, desc_r.ptr<uint8_t>(ir));
      if (d < best_dist) {
        best_dist = d;
        best_r = ir;
      }
    }
  }
  return best_r;
}

/** Result of the SAD search around a descriptor match, on one pyramid level. */
struct SadMatch {
  int best_sad = INT_MAX, best_inc = 0;
  float delta = 0;  ///< sub-pixel offset in [-1, 1]
};

/** SAD correlation of the left window at (sul, svl) along the right row
 *  around sur0 (+-sad_search), then the sub-pixel minimum. nullopt when the
 *  windows leave the image, the minimum is at the border of the search or the
 *  curve is flat. */
std::optional<SadMatch> sadRefine(const cv::Mat& IL, const cv::Mat& IR, int sul, int svl, int sur0,
                                  const StereoMatchParams& p, std::vector<int>& sad, std::vector<int>& col_l,
                                  std::vector<int>& col_r) {
  const int w = p.sad_half_window, L = p.sad_search;
  if (svl - w < 0 || svl + w >= IL.rows || sul - w < 0 || sul + w >= IL.cols) return std::nullopt;
  if (sur0 - L - w < 0 || sur0 + L + w >= IR.cols) return std::nullopt;
  SadMatch m;
  const int win = 2 * w + 1, area = win * win;
  int sum_l = 0, sum_r = 0;
  if (p.offset == StereoOffset::Mean) {
    // Window sums by sliding over the column sums of both images.
    columnSums(IL, sul - w, win, svl, w, col_l);
    for (int v : col_l) sum_l += v;
    columnSums(IR, sur0 - L - w, 2 * L + win, svl, w, col_r);
    for (int k = 0; k < win; k++) sum_r += col_r[k];
  }
  for (int inc = -L; inc <= L; inc++) {
    int off;
    if (p.offset == StereoOffset::Center) {
      off = IR.at<uint8_t>(svl, sur0 + inc) - IL.at<uint8_t>(svl, sul);
    } else {
      if (inc > -L) sum_r += col_r[inc + L + win - 1] - col_r[inc + L - 1];
      off = static_cast<int>(std::lround(static_cast<double>(sum_r - sum_l) / area));
    }
    const int d = sadWindow(IL, sul, IR, sur0 + inc, svl, w, off);
    if (d < m.best_sad) {
      m.best_sad = d;
      m.best_inc = inc;
    }
    sad[L + inc] = d;
  }
  if (m.best_inc == -L || m.best_inc == L) return std::nullopt;

  // Sub-pixel offset from the three SAD values around the minimum.
  const float d1 = static_cast<float>(sad[L + m.best_inc - 1]);
  const float d2 = static_cast<float>(sad[L + m.best_inc]);
  const float d3 = static_cast<float>(sad[L + m.best_inc + 1]);
  if (p.subpixel == StereoSubpixel::Parabola) {
    const float denom = 2.0f * (d1 + d3 - 2.0f * d2);
    if (!(denom > 0)) return std::nullopt;  // flat: no sub-pixel minimum
    m.delta = (d1 - d3) / denom;
  } else {
    const float slope = std::max(d1, d3) - d2;
    if (!(slope > 0)) return std::nullopt;
    m.delta = 0.5f * (d1 - d3) / slope;
  }
  if (m.delta < -1 || m.delta > 1) return std::nullopt;
  return m;
}

/** ORB-SLAM's final pass: matches whose SAD exceeds outlier_factor x the
 *  median are dropped. Returns how many. */
int rejectSadOutliers(std::vector<std::pair<int, int>>& dist_idx, float outlier_factor, std::vector<float>& u_right,
                      std::vector<float>& depth) {
  if (dist_idx.empty()) return 0;
  int outliers = 0;
  std::sort(dist_idx.begin(), dist_idx.end());
  const float median = static_cast<float>(dist_idx[dist_idx.size() / 2].first);
  const float th = outlier_factor * median;
  for (int i = static_cast<int>(dist_idx.size()) - 1; i >= 0; i--) {
    if (dist_idx[i].first < th) break;
    u_right[dist_idx[i].second] = -1.0f;
    depth[dist_idx[i].second] = -1.0f;
    outliers++;
  }
  return outliers;
}

}  // namespace

StereoMatchStats computeStereoMatches(const OrbExtractor& left, const std::vector<cv::KeyPoint>& kps_l,
                                      const cv::Mat& desc_l, const OrbExtractor& right,
                                      const std::vector<cv::KeyPoint>& kps_r, const cv::Mat& desc_r, float bf,
                                      float baseline, std::vector<float>& u_right, std::vector<float>& depth,
                                      const StereoMatchParams& p) {
  StereoMatchStats st;
  const int n = static_cast<int>(kps_l.size()), nr = static_cast<int>(kps_r.size());
  st.left = n;
  st.right = nr;
  u_right.assign(n, -1.0f);
  depth.assign(n, -1.0f);
  if (!(bf > 0) || !(baseline > 0))
    throw ConfigError("stereo matching: bf and baseline must be > 0 (bf=" + std::to_string(bf) +
                      ", baseline=" + std::to_string(baseline) + ")");
  if (desc_l.rows != n || desc_r.rows != nr)
    throw DataError("stereo matching: descriptor rows do not match the keypoints");
  if (n == 0 || nr == 0) return st;
  const auto& pyr_l = left.pyramid();
  const auto& pyr_r = right.pyramid();
  if (pyr_l.empty() || pyr_r.empty() || pyr_l[0].size() != pyr_r[0].size())
    throw DataError("stereo matching: left and right images differ in size");
  const auto& scale = left.scaleFactors();
  const auto& inv_scale = left.invScaleFactors();
  const int n_levels = static_cast<int>(std::min(pyr_l.size(), pyr_r.size()));
  const int rows = pyr_l[0].rows;
  const std::vector<std::vector<int>> row_idx = rowIndex(right, kps_r, rows, p.row_radius);

  const float min_z = baseline, min_d = 0.0f, max_d = bf / min_z;
  const int th_orb = (p.th_high + p.th_low) / 2;
  std::vector<std::pair<int, int>> dist_idx;  // (SAD distance, left index)
  dist_idx.reserve(n);
  std::vector<int> sad(2 * p.sad_search + 1), col_l, col_r;

  for (int il = 0; il < n; il++) {
    const cv::KeyPoint& kl = kps_l[il];
    const int level = kl.octave;
    if (level < 0 || level >= n_levels) continue;
    const float vl = kl.pt.y, ul = kl.pt.x;
    const int row = static_cast<int>(vl);
    if (row < 0 || row >= rows) continue;
    const std::vector<int>& cands = row_idx[row];
    if (cands.empty()) continue;
    const float min_u = ul - max_d, max_u = ul - min_d;
    if (max_u < 0) continue;
    int best_dist = 0;
    const int best_r = bestRowMatch(desc_l.ptr<uint8_t>(il), level, cands, kps_r, desc_r, min_u, max_u, p.th_high,
                                    best_dist);
    if (best_r < 0 || best_dist >= th_orb) continue;
    st.candidates++;

    // Sub-pixel refinement by SAD correlation on the left keypoint's level.
    const float sf = inv_scale[level];
    const int sul = static_cast<int>(std::round(ul * sf));
    const int svl = static_cast<int>(std::round(vl * sf));
    const int sur0 = static_cast<int>(std::round(kps_r[best_r].pt.x * sf));
    const auto m = sadRefine(pyr_l[level], pyr_r[level], sul, svl, sur0, p, sad, col_l, col_r);
    if (!m) continue;

    float best_ur = scale[level] * (static_cast<float>(sur0) + static_cast<float>(m->best_inc) + m->delta);
    float disparity = ul - best_ur;
    if (disparity >= min_d && disparity < max_d) {
      if (disparity <= 0) {
        disparity = 0.01f;
        best_ur = ul - 0.01f;
      }
      depth[il] = bf / disparity;
      u_right[il] = best_ur;
      dist_idx.emplace_back(m->best_sad, il);
    }
  }
  st.outliers = rejectSadOutliers(dist_idx, p.outlier_factor, u_right, depth);
  st.matched = static_cast<int>(dist_idx.size()) - st.outliers;
  return st;
}

}  // namespace dslam
