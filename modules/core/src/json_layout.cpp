#include "dslam/core/json_layout.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "dslam/core/error.h"
#include "dslam/core/paths.h"

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


nlohmann::json parseJsonFile(const std::string& file) {
  using json = nlohmann::json;
  std::ifstream f(file, std::ios::binary);
  if (!f) throw DataError("cannot open " + file + (fileExists(file) ? " (permission?)" : " (missing)"));
  std::ostringstream ss;
  ss << f.rdbuf();
  const std::string text = ss.str();
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    // byte offset -> line:column
    const size_t pos = std::min<size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    size_t line = 1, col = 1;
    for (size_t i = 0; i < pos; i++) {
      if (text[i] == '\n') {
        line++;
        col = 1;
      } else {
        col++;
      }
    }
    std::string what = e.what();
    if (const size_t p = what.find("syntax error"); p != std::string::npos) what = what.substr(p);
    throw DataError(file + ":" + std::to_string(line) + ":" + std::to_string(col) + ": invalid JSON: " + what);
  } catch (const json::exception& e) {  // e.g. out_of_range: "number overflow parsing '1e58140'"
    std::string what = e.what();
    if (const size_t p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw DataError(file + ": invalid JSON: " + what);
  }
}

}  // namespace dslam
