#include "dslam/features/rotation_histogram.h"

#include <algorithm>
#include <cmath>

namespace dslam {

void threeMaxima(const std::vector<std::vector<int>>& hist, int& i1, int& i2, int& i3) {
  size_t m1 = 0, m2 = 0, m3 = 0;
  i1 = i2 = i3 = -1;
  for (int i = 0; i < static_cast<int>(hist.size()); i++) {
    const size_t s = hist[i].size();
    if (s > m1) {
      m3 = m2, m2 = m1, m1 = s;
      i3 = i2, i2 = i1, i1 = i;
    } else if (s > m2) {
      m3 = m2, m2 = s;
      i3 = i2, i2 = i;
    } else if (s > m3) {
      m3 = s;
      i3 = i;
    }
  }
  if (static_cast<float>(m2) < 0.1f * static_cast<float>(m1)) {
    i2 = i3 = -1;
  } else if (static_cast<float>(m3) < 0.1f * static_cast<float>(m1)) {
    i3 = -1;
  }
}

int rotationBin(float diff_deg, int bins) {
  float r = std::fmod(diff_deg, 360.f);
  if (r < 0) r += 360.f;
  const float factor = static_cast<float>(bins) / 360.f;
  int bin = static_cast<int>(std::round(r * factor));
  if (bin == bins) bin = 0;
  return std::clamp(bin, 0, bins - 1);
}

std::vector<bool> rotationConsistent(const std::vector<float>& angle_diff_deg, int bins) {
  std::vector<bool> keep(angle_diff_deg.size(), true);
  if (angle_diff_deg.empty() || bins <= 0) return keep;
  std::vector<std::vector<int>> hist(bins);
  for (size_t k = 0; k < angle_diff_deg.size(); k++)
    hist[rotationBin(angle_diff_deg[k], bins)].push_back(static_cast<int>(k));
  int i1, i2, i3;
  threeMaxima(hist, i1, i2, i3);
  for (int b = 0; b < bins; b++) {
    if (b == i1 || b == i2 || b == i3) continue;
    for (int k : hist[b]) keep[k] = false;
  }
  return keep;
}

}  // namespace dslam
