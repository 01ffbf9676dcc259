#include "dslam/core/json_layout.h"

#include <nlohmann/json.hpp>

#include <sstream>

namespace dslam {

namespace {

template <class J>
void layout(std::ostream& o, const J& j, int depth, int indent) {
  if (depth <= 0 || !j.is_structured() || j.empty()) {
    o << j.dump();
    return;
  }
  const std::string pad(static_cast<size_t>(indent + 2), ' ');
  const bool obj = j.is_object();
  o << (obj ? '{' : '[');
  bool first = true;
  for (auto it = j.begin(); it != j.end(); ++it) {
    o << (first ? "\n" : ",\n") << pad;
    if (obj) o << J(it.key()).dump() << ": ";
    layout(o, it.value(), depth - 1, indent + 2);
    first = false;
  }
  o << '\n' << std::string(static_cast<size_t>(indent), ' ') << (obj ? '}' : ']');
}

template <class J>
std::string layoutText(const J& j, int depth) {
  std::ostringstream o;
  layout(o, j, depth, 0);
  o << '\n';
  return o.str();
}

}  // namespace

std::string layoutJson(const nlohmann::ordered_json& j, int depth) { return layoutText(j, depth); }
std::string layoutJson(const nlohmann::json& j, int depth) { return layoutText(j, depth); }

}  // namespace dslam
