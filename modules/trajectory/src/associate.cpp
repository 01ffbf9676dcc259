#include "dslam/trajectory/associate.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "dslam/core/error.h"

namespace dslam::traj {

namespace {
std::vector<size_t> sortedOrder(const std::vector<double>& v, const char* name) {
  for (size_t i = 0; i < v.size(); i++)
    if (!std::isfinite(v[i]))
      throw DataError(std::string("associate: timestamp ") + std::to_string(i) + " of list " + name + " is not finite");
  std::vector<size_t> idx(v.size());
  std::iota(idx.begin(), idx.end(), size_t{0});
  std::stable_sort(idx.begin(), idx.end(), [&](size_t x, size_t y) { return v[x] < v[y]; });
  return idx;
}
}  // namespace

std::vector<std::pair<size_t, size_t>> associate(const std::vector<double>& a, const std::vector<double>& b,
                                                 double max_dt) {
  if (!(max_dt > 0) || !std::isfinite(max_dt))
    throw ConfigError("associate: max_dt must be a positive number of seconds, got " + std::to_string(max_dt));
  const std::vector<size_t> oa = sortedOrder(a, "a"), ob = sortedOrder(b, "b");

  // Candidate pairs within max_dt: a sliding window over the sorted b list
  // (twice as wide as needed so that rounding never drops a pair that the
  // exact test |dt| < max_dt accepts).
  struct Cand {
    double d;
    size_t i, j;
  };
  std::vector<Cand> cands;
  size_t lo = 0;
  for (size_t ia : oa) {
    const double ta = a[ia];
    // Differences, not ta +- 2 max_dt: near 1e15 s a double cannot hold ta + 0.04.
    while (lo < ob.size() && ta - b[ob[lo]] > 2 * max_dt) lo++;
    for (size_t k = lo; k < ob.size() && b[ob[k]] - ta < 2 * max_dt; k++) {
      const double d = std::abs(ta - b[ob[k]]);
      if (d < max_dt) cands.push_back({d, ia, ob[k]});
    }
  }
  // associate.py sorts (|dt|, t_a, t_b) tuples and takes them greedily.
  std::sort(cands.begin(), cands.end(), [&](const Cand& x, const Cand& y) {
    if (x.d != y.d) return x.d < y.d;
    if (a[x.i] != a[y.i]) return a[x.i] < a[y.i];
    if (b[x.j] != b[y.j]) return b[x.j] < b[y.j];
    if (x.i != y.i) return x.i < y.i;
    return x.j < y.j;
  });
  std::vector<char> used_a(a.size(), 0), used_b(b.size(), 0);
  std::vector<std::pair<size_t, size_t>> out;
  for (const auto& c : cands) {
    if (used_a[c.i] || used_b[c.j]) continue;
    used_a[c.i] = used_b[c.j] = 1;
    out.emplace_back(c.i, c.j);
  }
  std::sort(out.begin(), out.end(), [&](const auto& x, const auto& y) {
    if (a[x.first] != a[y.first]) return a[x.first] < a[y.first];
    return x.first < y.first;
  });
  return out;
}

}  // namespace dslam::traj
