#include "dslam/core/params.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"

namespace dslam {

using mrpt::containers::yaml;
using node_t = yaml::node_t;

const char* toString(ParamType t) {
  switch (t) {
    case ParamType::Bool: return "bool";
    case ParamType::Int: return "int";
    case ParamType::Double: return "double";
    case ParamType::String: return "string";
    case ParamType::Path: return "path";
    case ParamType::Enum: return "enum";
    case ParamType::IntList: return "list<int>";
    case ParamType::DoubleList: return "list<double>";
    case ParamType::StringList: return "list<string>";
    case ParamType::DoubleMap: return "map<string,double>";
    case ParamType::Map: return "map";
  }
  return "?";
}

/** Shortest text that reads back as v (or as the same float, for values that
 *  came from a float: 1.2f prints as 1.2, not 1.20000004768372). */
static std::string fmtDouble(double v) {
  const bool is_float = static_cast<double>(static_cast<float>(v)) == v;
  std::string s;
  char buf[64];
  for (int prec = 1; prec <= 17; prec++) {
    std::snprintf(buf, sizeof(buf), "%.*g", prec, v);
    const double back = std::strtod(buf, nullptr);
    if (back == v || (is_float && static_cast<float>(back) == static_cast<float>(v))) break;
  }
  s = buf;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

ParamSpec P_bool(std::string name, bool def, std::string doc) {
  return {std::move(name), ParamType::Bool, def ? "true" : "false", std::move(doc), {}, false, {}, {}};
}
ParamSpec P_int(std::string name, int64_t def, std::string doc, std::optional<double> mn, std::optional<double> mx) {
  return {std::move(name), ParamType::Int, std::to_string(def), std::move(doc), {}, false, mn, mx};
}
ParamSpec P_double(std::string name, double def, std::string doc, std::optional<double> mn,
                   std::optional<double> mx) {
  return {std::move(name), ParamType::Double, fmtDouble(def), std::move(doc), {}, false, mn, mx};
}
ParamSpec P_string(std::string name, std::string def, std::string doc) {
  return {std::move(name), ParamType::String, std::move(def), std::move(doc), {}, false, {}, {}};
}
ParamSpec P_path(std::string name, std::string def, std::string doc) {
  return {std::move(name), ParamType::Path, std::move(def), std::move(doc), {}, false, {}, {}};
}
ParamSpec P_required(std::string name, ParamType type, std::string doc) {
  return {std::move(name), type, "", std::move(doc), {}, true, {}, {}};
}
ParamSpec P_enum(std::string name, std::string def, std::vector<std::string> choices, std::string doc) {
  return {std::move(name), ParamType::Enum, std::move(def), std::move(doc), std::move(choices), false, {}, {}};
}
ParamSpec P_list(std::string name, ParamType list_type, std::string def, std::string doc) {
  return {std::move(name), list_type, std::move(def), std::move(doc), {}, false, {}, {}};
}
ParamSpec P_map(std::string name, std::string def, std::string doc) {
  return {std::move(name), ParamType::DoubleMap, std::move(def), std::move(doc), {}, false, {}, {}};
}

std::string SourceLocation::str() const {
  std::string s;
  if (!file.empty()) s += file;
  if (line >= 0) s.append(":").append(std::to_string(line));
  if (!s.empty()) s += ": ";
  if (!key_path.empty()) s += "key '" + key_path + "'";
  return s;
}

Params::Params() : y_(std::make_unique<yaml>(yaml::Map())) {}
Params::~Params() = default;
Params::Params(const Params& o)
    : y_(std::make_unique<yaml>(*o.y_)), where_(o.where_), given_(o.given_), order_(o.order_) {}
Params& Params::operator=(const Params& o) {
  if (this != &o) {
    y_ = std::make_unique<yaml>(*o.y_);
    where_ = o.where_;
    given_ = o.given_;
    order_ = o.order_;
  }
  return *this;
}

Params Params::fromYaml(const std::string& yaml_text) {
  Params p;
  yaml y = yamlu::parseYamlText(yaml_text, "parameters");
  if (!y.isNullNode() && !y.isMap()) throw ConfigError("parameters must be a YAML map, got: " + yaml_text);
  if (y.isMap()) {
    *p.y_ = y;
    for (const auto& k : p.keys()) p.given_.insert(k);
  }
  return p;
}

namespace {

std::string keyPathOf(const SourceLocation& where, const std::string& key) {
  return where.key_path.empty() ? key : where.key_path + "." + key;
}

[[noreturn]] void failAt(const SourceLocation& where, const node_t* n, const std::string& key,
                         const std::string& what) {
  SourceLocation w = where;
  w.key_path = keyPathOf(where, key);
  if (n && w.node_lines) w.line = n->marks.line + 1;
  throw ConfigError(w.str() + ": " + what);
}

std::optional<std::string> checkScalar(const ParamSpec& s, ParamType t, const node_t& v, std::string& err) {
  auto txt = yamlu::scalarText(v);
  if (!txt) {
    err = std::string("expected ") + toString(t) + ", got " + yamlu::describe(v);
    return std::nullopt;
  }
  switch (t) {
    case ParamType::Bool:
      if (!yamlu::parseBool(*txt)) err = "expected bool (true/false), got '" + *txt + "'";
      break;
    case ParamType::Int:
    case ParamType::Double: {
      const bool is_int = t == ParamType::Int;
      std::optional<double> x;  // the range check compares as double either way
      if (!is_int)
        x = yamlu::parseDouble(*txt);
      else if (const auto i = yamlu::parseInt(*txt))
        x = static_cast<double>(*i);
      if (!x)
        err = std::string(is_int ? "expected an integer" : "expected a number") + ", got '" + *txt + "'";
      else if (!std::isfinite(*x))
        err = "expected a finite number, got '" + *txt + "'";
      else if ((s.min && *x < *s.min) || (s.max && *x > *s.max))
        err = "value " + *txt + " out of range [" + (s.min ? fmtDouble(*s.min) : "-inf") + ", " +
              (s.max ? fmtDouble(*s.max) : "inf") + "]";
      break;
    }
    case ParamType::Enum: {
      bool ok = false;
      for (const auto& c : s.choices) ok |= (c == *txt);
      if (!ok) err = "invalid value '" + *txt + "' (valid: " + yamlu::join(s.choices) + ")";
      break;
    }
    default: break;
  }
  if (!err.empty()) return std::nullopt;
  return txt;
}

/** Validates v against s; returns the normalised node. */
node_t validate(const ParamSpec& s, const node_t& v, const SourceLocation& where, const node_t* keyNode,
                const std::string& base_dir) {
  std::string err;
  auto fail = [&](const std::string& what) { failAt(where, keyNode ? keyNode : &v, s.name, what); };
  switch (s.type) {
    case ParamType::Bool:
    case ParamType::Int:
    case ParamType::Double:
    case ParamType::Enum:
    case ParamType::String: {
      auto t = checkScalar(s, s.type, v, err);
      if (!t) fail(err);
      return node_t(*t);
    }
    case ParamType::Path: {
      auto t = checkScalar(s, ParamType::String, v, err);
      if (!t) fail(err);
      return node_t(resolvePath(*t, base_dir));
    }
    case ParamType::IntList:
    case ParamType::DoubleList:
    case ParamType::StringList: {
      if (!v.isSequence() && !v.isNullNode()) fail(std::string("expected ") + toString(s.type) + ", got " + yamlu::describe(v));
      const ParamType et = s.type == ParamType::IntList      ? ParamType::Int
                           : s.type == ParamType::DoubleList ? ParamType::Double
                                                             : ParamType::String;
      node_t out = yaml::Sequence();
      out.printInShortFormat = true;
      if (v.isSequence()) {
        ParamSpec es = s;
        es.type = et;
        size_t i = 0;
        for (const auto& e : v.asSequence()) {
          auto t = checkScalar(es, et, e, err);
          if (!t) fail("element " + std::to_string(i) + ": " + err);
          out.asSequence().push_back(node_t(*t));
          i++;
        }
      }
      return out;
    }
    case ParamType::DoubleMap: {
      if (!v.isMap() && !v.isNullNode()) fail("expected a map of numbers, got " + yamlu::describe(v));
      node_t out = yaml::Map();
      if (v.isMap()) {
        ParamSpec es = s;
        es.type = ParamType::Double;
        for (const auto& kv : v.asMap()) {
          auto k = yamlu::scalarText(kv.first).value_or("");
          auto t = checkScalar(es, ParamType::Double, kv.second, err);
          if (!t) fail("entry '" + k + "': " + err);
          out.asMap()[node_t(k)] = node_t(*t);
        }
      }
      return out;
    }
    case ParamType::Map:
      if (!v.isMap() && !v.isNullNode()) fail("expected a map, got " + yamlu::describe(v));
      return v.isNullNode() ? yaml::Map() : v;
  }
  return v;
}

}  // namespace

Params Params::resolve(const std::vector<ParamSpec>& specs, const yaml* given, const SourceLocation& where,
                       const std::string& base_dir) {
  Params p;
  p.where_ = where;
  const node_t* g = nullptr;
  if (given && !given->isNullNode()) {
    g = &given->node();
    if (!g->isMap()) {
      SourceLocation w = where;
      if (w.line < 0 && w.node_lines) w.line = g->marks.line + 1;
      throw ConfigError(w.str() + ": expected a map of parameters, got " + yamlu::describe(*g));
    }
  }
  std::vector<std::string> valid;
  for (const auto& s : specs) valid.push_back(s.name);
  if (g) {
    for (const auto& kv : g->asMap()) {
      const std::string k = yamlu::scalarText(kv.first).value_or("");
      bool known = false;
      for (const auto& s : specs) known |= (s.name == k);
      if (!known)
        failAt(where, &kv.first, k,
               "unknown parameter" + yamlu::didYouMean(k, valid) +
                   (valid.empty() ? " (this plugin takes no parameters)" : " (valid: " + yamlu::join(valid) + ")"));
    }
  }
  auto& m = p.y_->asMap();
  for (const auto& s : specs) {
    p.order_.push_back(s.name);
    const node_t* kn = g ? yamlu::findKey(*g, s.name) : nullptr;
    const node_t* vn = g ? yamlu::findValue(*g, s.name) : nullptr;
    if (vn) {
      m[node_t(s.name)] = validate(s, *vn, where, kn, base_dir);
      p.given_.insert(s.name);
    } else if (s.required) {
      failAt(where, nullptr, s.name,
             std::string("missing required parameter (") + toString(s.type) + ": " + s.doc + ")");
    } else {
      yaml d = s.default_value.empty() ? yaml() : yaml::FromText("v: " + s.default_value);
      node_t dv = s.default_value.empty() ? node_t(std::string()) : d.asMap().begin()->second;
      if (s.default_value.empty() && (s.type == ParamType::Map || s.type == ParamType::DoubleMap))
        dv = yaml::Map();
      if (s.default_value.empty() &&
          (s.type == ParamType::IntList || s.type == ParamType::DoubleList || s.type == ParamType::StringList))
        dv = yaml::Sequence();
      try {
        m[node_t(s.name)] = validate(s, dv, where, nullptr, base_dir);
      } catch (const ConfigError& e) {
        throw ConfigError(std::string("internal: bad default for parameter '") + s.name + "': " + e.what());
      }
    }
  }
  return p;
}

Params Params::resolve(const std::vector<ParamSpec>& specs, const std::string& yaml_text,
                       const std::string& base_dir) {
  yaml y = yaml_text.empty() ? yaml() : yamlu::parseYamlText(yaml_text, "parameters");
  return resolve(specs, &y, SourceLocation{}, base_dir);
}

void Params::fail(const std::string& key, const std::string& what) const {
  throw ConfigError(where_.str() + (where_.str().empty() ? "" : ": ") + "parameter '" + key + "': " + what);
}

bool Params::has(const std::string& key) const { return y_->isMap() && y_->has(key); }

static const node_t& valueOf(const yaml& y, const std::string& key) {
  const node_t* v = yamlu::findValue(y.node(), key);
  if (!v) throw ConfigError("parameter '" + key + "' is not declared by this plugin");
  return *v;
}

#define DSLAM_NODE(key) valueOf(*y_, key)

bool Params::getBool(const std::string& key) const {
  auto t = yamlu::scalarText(DSLAM_NODE(key));
  auto b = t ? yamlu::parseBool(*t) : std::nullopt;
  if (!b) fail(key, "not a bool");
  return *b;
}
int64_t Params::getInt(const std::string& key) const {
  auto t = yamlu::scalarText(DSLAM_NODE(key));
  auto b = t ? yamlu::parseInt(*t) : std::nullopt;
  if (!b) fail(key, "not an integer");
  return *b;
}
double Params::getDouble(const std::string& key) const {
  auto t = yamlu::scalarText(DSLAM_NODE(key));
  auto b = t ? yamlu::parseDouble(*t) : std::nullopt;
  if (!b) fail(key, "not a number");
  return *b;
}
std::string Params::getString(const std::string& key) const {
  const node_t& n = DSLAM_NODE(key);
  if (n.isNullNode()) return "";
  auto t = yamlu::scalarText(n);
  if (!t) fail(key, "not a string");
  return *t;
}
namespace {
/** Elements of a sequence node parsed by `parse` (nullopt = not valid:
 *  `bad()` throws); an empty list for a non-sequence. */
template <class T, class Parse, class Bad>
std::vector<T> listOf(const node_t& n, Parse parse, Bad bad) {
  std::vector<T> out;
  if (!n.isSequence()) return out;
  for (const auto& e : n.asSequence()) {
    auto t = yamlu::scalarText(e);
    auto x = t ? parse(*t) : std::nullopt;
    if (!x) bad();
    out.push_back(static_cast<T>(*x));
  }
  return out;
}
}  // namespace

std::vector<int> Params::getIntList(const std::string& key) const {
  return listOf<int>(DSLAM_NODE(key), yamlu::parseInt, [&] { fail(key, "list element is not an integer"); });
}
std::vector<double> Params::getDoubleList(const std::string& key) const {
  return listOf<double>(DSLAM_NODE(key), yamlu::parseDouble, [&] { fail(key, "list element is not a number"); });
}
std::vector<std::string> Params::getStringList(const std::string& key) const {
  std::vector<std::string> out;
  const node_t& n = DSLAM_NODE(key);
  if (!n.isSequence()) return out;
  for (const auto& e : n.asSequence()) out.push_back(yamlu::scalarText(e).value_or(""));
  return out;
}
std::map<std::string, double> Params::getDoubleMap(const std::string& key) const {
  std::map<std::string, double> out;
  const node_t& n = DSLAM_NODE(key);
  if (!n.isMap()) return out;
  for (const auto& kv : n.asMap()) {
    auto t = yamlu::scalarText(kv.second);
    auto x = t ? yamlu::parseDouble(*t) : std::nullopt;
    if (!x) fail(key, "map value is not a number");
    out[yamlu::scalarText(kv.first).value_or("")] = *x;
  }
  return out;
}
#undef DSLAM_NODE

std::vector<std::string> Params::keys() const {
  std::vector<std::string> k;
  if (y_->isMap())
    for (const auto& kv : y_->asMap()) k.push_back(yamlu::scalarText(kv.first).value_or(""));
  return k;
}

void Params::set(const std::string& key, const std::string& yaml_value) {
  yaml d = yamlu::parseYamlText("v: " + yaml_value, "value of parameter '" + key + "'");
  y_->asMap()[node_t(key)] = d.asMap().begin()->second;
  given_.insert(key);
}

void Params::setString(const std::string& key, const std::string& value) {
  y_->asMap()[node_t(key)] = node_t(value);
  given_.insert(key);
}


std::string Params::toYamlText() const {
  std::ostringstream o;
  std::vector<std::string> ks = order_;
  for (const auto& k : keys())
    if (std::find(ks.begin(), ks.end(), k) == ks.end()) ks.push_back(k);
  for (const auto& k : ks) {
    const node_t* v = yamlu::findValue(y_->node(), k);
    if (!v) continue;
    o << yamlu::scalarOut(node_t(k)) << ":";
    yamlu::emitValue(o, *v, 2);
  }
  return o.str();
}
const yaml& Params::asYaml() const { return *y_; }

}  // namespace dslam
