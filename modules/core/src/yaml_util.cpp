#include "dslam/core/yaml_util.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

namespace dslam::yamlu {

std::optional<std::string> scalarText(const node_t& n) {
  if (!n.isScalar() || n.isNullNode()) return std::nullopt;
  return std::string(n.internalAsStr());
}

std::optional<bool> parseBool(const std::string& s) {
  if (s == "true" || s == "True" || s == "TRUE" || s == "yes" || s == "on") return true;
  if (s == "false" || s == "False" || s == "FALSE" || s == "no" || s == "off") return false;
  return std::nullopt;
}

std::optional<long long> parseInt(const std::string& s) {
  long long v = 0;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (b != e && *b == '+') b++;
  auto r = std::from_chars(b, e, v);
  if (r.ec != std::errc() || r.ptr != e || b == e) return std::nullopt;
  return v;
}

std::optional<double> parseDouble(const std::string& s) {
  if (s == ".inf" || s == "inf") return HUGE_VAL;
  if (s == "-.inf" || s == "-inf") return -HUGE_VAL;
  double v = 0;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (b != e && *b == '+') b++;
  auto r = std::from_chars(b, e, v);
  if (r.ec != std::errc() || r.ptr != e || b == e) return std::nullopt;
  return v;
}

std::string describe(const node_t& n) {
  if (n.isNullNode()) return "null";
  if (n.isMap()) return "a map";
  if (n.isSequence()) return "a list";
  // Quote, do not dump: a short excerpt on one line (the value may be a
  // whole file that an $include{} pulled in).
  std::string v(n.internalAsStr());
  for (char& c : v)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  constexpr size_t kMax = 60;
  if (v.size() > kMax) v = v.substr(0, kMax) + "... (" + std::to_string(v.size()) + " characters)";
  return "'" + v + "'";
}

const node_t* findKey(const node_t& m, const std::string& key) {
  if (!m.isMap()) return nullptr;
  for (const auto& kv : m.asMap())
    if (auto k = scalarText(kv.first); k && *k == key) return &kv.first;
  return nullptr;
}

const node_t* findValue(const node_t& m, const std::string& key) {
  if (!m.isMap()) return nullptr;
  for (const auto& kv : m.asMap())
    if (auto k = scalarText(kv.first); k && *k == key) return &kv.second;
  return nullptr;
}

std::vector<std::string> keysInOrder(const node_t& m) {
  std::vector<std::pair<std::pair<int, int>, std::string>> v;
  if (!m.isMap()) return {};
  for (const auto& kv : m.asMap())
    v.push_back({{kv.first.marks.line, kv.first.marks.column}, scalarText(kv.first).value_or("")});
  std::stable_sort(v.begin(), v.end(), [](auto& a, auto& b) { return a.first < b.first; });
  std::vector<std::string> out;
  for (auto& e : v) out.push_back(e.second);
  return out;
}

size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); j++) prev[j] = j;
  for (size_t i = 1; i <= a.size(); i++) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); j++)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string didYouMean(const std::string& key, const std::vector<std::string>& valid) {
  size_t best = std::string::npos;
  std::string cand;
  for (const auto& v : valid) {
    const size_t d = editDistance(key, v);
    if (d < best) {
      best = d;
      cand = v;
    }
  }
  if (!cand.empty() && best <= std::max<size_t>(2, key.size() / 3)) return ", did you mean '" + cand + "'?";
  return "";
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (size_t i = 0; i < v.size(); i++) s += (i ? sep : "") + v[i];
  return s;
}

std::string toYamlText(const mrpt::containers::yaml& y) {
  std::ostringstream o;
  mrpt::containers::YamlEmitOptions eo;
  eo.emitHeader = false;
  y.printAsYAML(o, eo);
  return o.str();
}

}  // namespace dslam::yamlu
