#include "dslam/core/text_lines.h"

#include <fstream>

#include "dslam/core/error.h"

namespace dslam {

std::vector<TextLine> readDataLines(const std::string& file, const std::string& hint, bool trailing_comments) {
  std::ifstream f(file);
  if (!f) throw DataError("cannot open " + file + (hint.empty() ? "" : " (" + hint + ")"));
  std::vector<TextLine> out;
  std::string s;
  int n = 0;
  while (std::getline(f, s)) {
    n++;
    if (n == 1 && s.compare(0, 3, "\xEF\xBB\xBF") == 0) s.erase(0, 3);  // UTF-8 byte-order mark
    if (trailing_comments)
      if (const size_t hash = s.find('#'); hash != std::string::npos) s.erase(hash);
    if (!s.empty() && s.back() == '\r') s.pop_back();
    const size_t p = s.find_first_not_of(" \t\r");
    if (p == std::string::npos || s[p] == '#') continue;
    out.push_back({n, s});
  }
  return out;
}

std::vector<std::string> splitFields(const std::string& s, bool commas) {
  std::vector<std::string> out;
  std::string tok;
  for (char c : s) {
    if (c == ' ' || c == '\t' || c == '\r' || (commas && c == ',')) {
      if (!tok.empty()) out.push_back(tok);
      tok.clear();
    } else {
      tok += c;
    }
  }
  if (!tok.empty()) out.push_back(tok);
  return out;
}

}  // namespace dslam
