#include "dslam/core/yaml_util.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <sstream>

#include "dslam/core/error.h"

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

namespace {
/** The whole text as a T (from_chars; a leading '+' allowed), or nullopt. */
template <class T>
std::optional<T> parseWhole(const std::string& s) {
  T v = 0;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (b != e && *b == '+') b++;
  auto r = std::from_chars(b, e, v);
  if (r.ec != std::errc() || r.ptr != e || b == e) return std::nullopt;
  return v;
}
}  // namespace

std::optional<long long> parseInt(const std::string& s) { return parseWhole<long long>(s); }

std::optional<double> parseDouble(const std::string& s) {
  if (s == ".inf" || s == "inf") return HUGE_VAL;
  if (s == "-.inf" || s == "-inf") return -HUGE_VAL;
  return parseWhole<double>(s);
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

size_t invalidUtf8(const std::string& s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const size_t n = s.size();
  size_t i = 0;
  while (i < n) {
    const unsigned char c = p[i];
    if (c < 0x80) {
      i++;
      continue;
    }
    size_t len;
    uint32_t cp;
    if (c >= 0xC2 && c <= 0xDF) {
      len = 2, cp = c & 0x1F;
    } else if (c >= 0xE0 && c <= 0xEF) {
      len = 3, cp = c & 0x0F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      len = 4, cp = c & 0x07;
    } else {
      return i;  // continuation byte without a lead, 0xC0/0xC1 (overlong) or > 0xF4
    }
    if (i + len > n) return i;
    for (size_t k = 1; k < len; k++) {
      if ((p[i + k] & 0xC0) != 0x80) return i;
      cp = (cp << 6) | (p[i + k] & 0x3F);
    }
    if ((len == 3 && cp < 0x800) || (len == 4 && cp < 0x10000) || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF))
      return i;
    i += len;
  }
  return std::string::npos;
}

size_t lineOf(const std::string& s, size_t pos) {
  return 1 + static_cast<size_t>(std::count(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(std::min(pos, s.size())), '\n'));
}

mrpt::containers::yaml parseYamlText(const std::string& text, const std::string& what) {
  if (const size_t bad = invalidUtf8(text); bad != std::string::npos)
    throw ConfigError(what + ":" + std::to_string(lineOf(text, bad)) + ": not valid UTF-8 text (byte " +
                      std::to_string(bad) + "); YAML files must be UTF-8");
  return mrpt::containers::yaml::FromText(text);
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

namespace {
bool needsQuotes(const std::string& s) {
  if (s.empty()) return true;
  if (s.find_first_of(":#{}[],&*!|>'\"%@`") != std::string::npos) return true;
  if (s.front() == '-' && (s.size() == 1 || s[1] == ' ')) return true;
  return s.front() == ' ' || s.back() == ' ';
}
bool hasControl(const std::string& s) {
  for (unsigned char c : s)
    if (c < 0x20 || c == 0x7f) return true;
  return false;
}
}  // namespace

std::string scalarOut(const node_t& n) {
  if (n.isNullNode()) return "~";
  const std::string s = scalarText(n).value_or("");
  if (hasControl(s)) {  // double-quoted with escapes: newlines survive
    std::string q = "\"";
    char buf[8];
    for (unsigned char c : s) {
      if (c == '"' || c == '\\') {
        q += '\\';
        q += static_cast<char>(c);
      } else if (c == '\n') {
        q += "\\n";
      } else if (c == '\t') {
        q += "\\t";
      } else if (c < 0x20 || c == 0x7f) {
        std::snprintf(buf, sizeof(buf), "\\x%02x", c);
        q += buf;
      } else {
        q += static_cast<char>(c);
      }
    }
    return q + "\"";
  }
  if (!needsQuotes(s)) return s;
  std::string q = "'";
  for (char c : s) q += (c == '\'' ? std::string("''") : std::string(1, c));
  return q + "'";
}

void emitValue(std::ostream& o, const node_t& n, int indent) {
  const std::string pad(indent, ' ');
  if (n.isMap()) {
    if (n.asMap().empty()) {
      o << " {}\n";
      return;
    }
    o << "\n";
    for (const auto& k : keysInOrder(n)) {
      o << pad << scalarOut(node_t(k)) << ":";
      emitValue(o, *findValue(n, k), indent + 2);
    }
  } else if (n.isSequence()) {
    bool flat = true;
    for (const auto& e : n.asSequence()) flat &= e.isScalar() || e.isNullNode();
    if (flat) {
      o << " [";
      size_t i = 0;
      for (const auto& e : n.asSequence()) o << (i++ ? ", " : "") << scalarOut(e);
      o << "]\n";
    } else {
      o << "\n";
      for (const auto& e : n.asSequence()) {
        o << pad << "-";
        emitValue(o, e, indent + 2);
      }
    }
  } else {
    o << " " << scalarOut(n) << "\n";
  }
}

std::string toYamlText(const mrpt::containers::yaml& y) {
  const node_t& n = y.node();
  std::ostringstream o;
  if (n.isMap()) {
    for (const auto& k : keysInOrder(n)) {
      o << scalarOut(node_t(k)) << ":";
      emitValue(o, *findValue(n, k), 2);
    }
  } else {
    std::ostringstream v;
    emitValue(v, n, 2);
    const std::string s = v.str();
    o << (s.empty() ? s : s.substr(1));  // the value without its leading space / newline
  }
  return o.str();
}

// ------------------------------------------------------------ TypedReader

void TypedReader::fail(const At& at, const std::string& msg) const {
  std::string f = file_for_ ? file_for_(at.path) : std::string();
  std::string where = f;
  if (at.n) where += ":" + std::to_string(at.n->marks.line + 1);
  throw ConfigError(where + ": " + (at.path.empty() ? std::string() : "'" + at.path + "': ") + msg);
}

void TypedReader::requireMap(const At& m) const {
  if (!m.n->isMap()) fail(m, "expected a map, got " + describe(*m.n));
}

void TypedReader::checkKeys(const At& m, const std::vector<std::string>& allowed) const {
  requireMap(m);
  for (const auto& kv : m.n->asMap()) {
    const std::string k = scalarText(kv.first).value_or("");
    if (std::find(allowed.begin(), allowed.end(), k) == allowed.end())
      fail(At{&kv.first, join(m.path, k)},
           "unknown key '" + k + "'" + didYouMean(k, allowed) + " (valid keys: " + yamlu::join(allowed) + ")");
  }
}

std::optional<At> TypedReader::child(const At& m, const std::string& key) const {
  const node_t* v = findValue(*m.n, key);
  if (!v || v->isNullNode()) return std::nullopt;
  return At{v, join(m.path, key)};
}
At TypedReader::required(const At& m, const std::string& key) const {
  auto c = child(m, key);
  if (!c) fail(m, "missing required key '" + key + "'");
  return *c;
}

double TypedReader::num(const At& v) const {
  auto t = scalarText(*v.n);
  auto d = t ? parseDouble(*t) : std::nullopt;
  if (!d || !std::isfinite(*d)) fail(v, "expected a number, got " + describe(*v.n));
  return *d;
}
double TypedReader::num(const At& m, const std::string& key, double def) const {
  auto c = child(m, key);
  return c ? num(*c) : def;
}
double TypedReader::positive(const At& m, const std::string& key, double def, bool allow_zero) const {
  auto c = child(m, key);
  if (!c) return def;
  const double v = num(*c);
  if (v < 0 || (!allow_zero && v == 0)) fail(*c, allow_zero ? "must be >= 0" : "must be > 0");
  return v;
}
long long TypedReader::integer(const At& v) const {
  auto t = scalarText(*v.n);
  auto d = t ? parseInt(*t) : std::nullopt;
  if (!d) fail(v, "expected an integer, got " + describe(*v.n));
  return *d;
}
long long TypedReader::integer(const At& m, const std::string& key, long long def) const {
  auto c = child(m, key);
  return c ? integer(*c) : def;
}
bool TypedReader::boolean(const At& m, const std::string& key, bool def) const {
  auto c = child(m, key);
  if (!c) return def;
  auto t = scalarText(*c->n);
  auto b = t ? parseBool(*t) : std::nullopt;
  if (!b) fail(*c, "expected true/false, got " + describe(*c->n));
  return *b;
}
std::string TypedReader::str(const At& v) const {
  auto t = scalarText(*v.n);
  if (!t) fail(v, "expected a text value, got " + describe(*v.n));
  return *t;
}
std::string TypedReader::str(const At& m, const std::string& key, const std::string& def) const {
  auto c = child(m, key);
  return c ? str(*c) : def;
}
std::string TypedReader::oneOf(const At& m, const std::string& key, const std::string& def,
                  const std::vector<std::string>& valid, const std::string& what) const {
  auto c = child(m, key);
  if (!c) return def;
  const std::string s = str(*c);
  if (std::find(valid.begin(), valid.end(), s) == valid.end())
    fail(*c, "unknown " + what + " '" + s + "'" + didYouMean(s, valid) + " (valid: " + yamlu::join(valid) + ")");
  return s;
}
std::vector<At> TypedReader::list(const At& v) const {
  if (!v.n->isSequence()) fail(v, "expected a list, got " + describe(*v.n));
  std::vector<At> out;
  size_t i = 0;
  for (const auto& e : v.n->asSequence()) out.push_back(At{&e, v.path + "[" + std::to_string(i++) + "]"});
  return out;
}
std::vector<double> TypedReader::numbers(const At& v, size_t min_n, size_t max_n) const {
  auto l = list(v);
  if (l.size() < min_n || l.size() > max_n)
    fail(v, "expected " + (min_n == max_n ? std::to_string(min_n) : std::to_string(min_n) + " to " + std::to_string(max_n)) +
                " numbers, got " + std::to_string(l.size()));
  std::vector<double> out;
  for (auto& e : l) out.push_back(num(e));
  return out;
}

}  // namespace dslam::yamlu
