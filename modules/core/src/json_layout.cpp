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

/** line:column of byte `pos` of `text`. */
std::string lineColumn(const std::string& text, size_t pos) {
  size_t line = 1, col = 1;
  for (size_t i = 0; i < pos && i < text.size(); i++) {
    if (text[i] == '\n') {
      line++;
      col = 1;
    } else {
      col++;
    }
  }
  return std::to_string(line) + ":" + std::to_string(col);
}

/** No dslam JSON file nests deeper than a few levels; a hostile file nested
 *  100,000 levels deep would exhaust the stack of the code that walks it. */
void checkJsonDepth(const std::string& text, const std::string& file) {
  constexpr int kMaxDepth = 256;
  int depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); i++) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') i++;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxDepth)
        throw DataError(file + ":" + lineColumn(text, i) + ": invalid JSON: nested more than " +
                        std::to_string(kMaxDepth) + " levels deep");
    } else if (c == ']' || c == '}') {
      depth--;
    }
  }
}

}  // namespace

std::string layoutJson(const nlohmann::ordered_json& j, int depth) { return layoutText(j, depth); }
std::string layoutJson(const nlohmann::json& j, int depth) { return layoutText(j, depth); }


std::string jsonErrorText(const std::exception& e) {
  std::string what = e.what();
  if (const size_t p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
  return what;
}

nlohmann::json parseJsonFile(const std::string& file) {
  using json = nlohmann::json;
  std::ifstream f(file, std::ios::binary);
  if (!f) throw DataError("cannot open " + file + (fileExists(file) ? " (permission?)" : " (missing)"));
  std::ostringstream ss;
  ss << f.rdbuf();
  const std::string text = ss.str();
  checkJsonDepth(text, file);
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    // byte offset -> line:column
    const size_t pos = std::min<size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    std::string what = e.what();
    if (const size_t p = what.find("syntax error"); p != std::string::npos) what = what.substr(p);
    throw DataError(file + ":" + lineColumn(text, pos) + ": invalid JSON: " + what);
  } catch (const json::exception& e) {  // e.g. out_of_range: "number overflow parsing '1e58140'"
    throw DataError(file + ": invalid JSON: " + jsonErrorText(e));
  }
}

}  // namespace dslam
