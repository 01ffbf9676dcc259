#include "dslam/config/yaml_loader.h"

#include <mrpt/containers/yaml.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <filesystem>
#include <fstream>
#include <cctype>
#include <cstring>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"

namespace fs = std::filesystem;
using mrpt::containers::yaml;
using node_t = yaml::node_t;

namespace dslam::config {

std::string LoadedYaml::fileFor(const std::string& key_path) const {
  std::string best = file;
  size_t best_len = 0;
  for (const auto& [prefix, f] : origins) {
    const bool match = key_path == prefix || (key_path.rfind(prefix, 0) == 0 && key_path.size() > prefix.size() &&
                                              (key_path[prefix.size()] == '.' || key_path[prefix.size()] == '['));
    if (match && prefix.size() >= best_len) {
      best = f;
      best_len = prefix.size();
    }
  }
  return best;
}

namespace {

bool isVarStart(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; }
bool isVarChar(char c) { return isVarStart(c) || (c >= '0' && c <= '9'); }

/** A `${NAME}` / `${NAME|default}` at `code[i]` (which is '$'): its end
 *  (one past '}'), name and default. Hand-written, not std::regex: the
 *  recursive std::regex matcher overflows the stack on long lines. */
bool matchVariable(const std::string& code, size_t i, size_t& end, std::string& name, std::optional<std::string>& def) {
  if (i + 2 >= code.size() || code[i + 1] != '{' || !isVarStart(code[i + 2])) return false;
  size_t j = i + 3;
  while (j < code.size() && isVarChar(code[j])) j++;
  if (j >= code.size()) return false;
  name = code.substr(i + 2, j - i - 2);
  if (code[j] == '}') {
    def.reset();
    end = j + 1;
    return true;
  }
  if (code[j] != '|') return false;
  const size_t close = code.find('}', j + 1);
  if (close == std::string::npos) return false;
  def = code.substr(j + 1, close - j - 1);
  end = close + 1;
  return true;
}

}  // namespace

std::string expandVariables(const std::string& text, const std::string& file) {
  std::string out;
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  const std::string cfgdir = file.empty() ? "." : fs::path(file).parent_path().string();
  while (std::getline(in, line)) {
    lineno++;
    // Comments are not expanded (a commented-out ${X} must not fail).
    std::string code = line, comment;
    for (size_t i = 0; i < line.size(); i++) {
      if (line[i] == '#' && (i == 0 || line[i - 1] == ' ' || line[i - 1] == '\t')) {
        code = line.substr(0, i);
        comment = line.substr(i);
        break;
      }
    }
    std::string res;
    size_t i = 0;
    while (i < code.size()) {
      const size_t dollar = code.find('$', i);
      if (dollar == std::string::npos) break;
      size_t end = 0;
      std::string var;
      std::optional<std::string> def;
      if (!matchVariable(code, dollar, end, var, def)) {
        res.append(code, i, dollar + 1 - i);
        i = dollar + 1;
        continue;
      }
      res.append(code, i, dollar - i);
      const char* e = std::getenv(var.c_str());
      if (e && *e) {
        // The value is pasted into the text: it must not change its structure.
        const std::string v = e;
        const char* bad = v.find_first_of("\r\n") != std::string::npos ? "a line break"
                          : v.find(" #") != std::string::npos || v.find("\t#") != std::string::npos
                              ? "' #' (which would start a comment)"
                          : v.find("$include{") != std::string::npos ? "$include{} (not expanded from variables)"
                                                                     : nullptr;
        if (bad)
          throw ConfigError(file + ":" + std::to_string(lineno) + ": environment variable '" + var + "' holds " + bad +
                            "; set it to a plain value");
        res += v;
      }
      else if (def)
        res += *def;
      else if (var == "DSLAM_SHARED_DIR")
        res += sharedDir();
      else if (var == "CONFIG_DIR")
        res += cfgdir.empty() ? "." : cfgdir;
      else
        throw ConfigError(file + ":" + std::to_string(lineno) + ": environment variable '" + var +
                          "' is not set (or empty) and has no default (write ${" + var + "|default})");
      i = end;
    }
    if (i < code.size()) res.append(code, i, std::string::npos);
    out += res + comment + "\n";
  }
  return out;
}

namespace {

/** The path of a scalar that is exactly `$include{path}` (path without '}'). */
std::optional<std::string> includePath(const std::string& t) {
  static const std::string kOpen = "$include{";
  if (t.size() <= kOpen.size() + 1 || t.compare(0, kOpen.size(), kOpen) != 0 || t.back() != '}') return std::nullopt;
  std::string p = t.substr(kOpen.size(), t.size() - kOpen.size() - 1);
  if (p.find('}') != std::string::npos) return std::nullopt;
  return p;
}

/** Runs `fn` with stderr (fd 2) captured; returns what was written there.
 *  MRPT's YAML parser (libfyaml) prints some syntax errors, e.g. an unclosed
 *  flow sequence, to stderr and returns a partial document instead of
 *  throwing: capturing them is the only way to report them. */
template <class Fn>
std::string captureStderr(Fn&& fn) {
  static std::mutex m;
  std::lock_guard<std::mutex> lk(m);
  std::fflush(stderr);
  FILE* tmp = std::tmpfile();
  const int saved = tmp ? ::dup(2) : -1;
  if (!tmp || saved < 0 || ::dup2(::fileno(tmp), 2) < 0) {  // cannot capture: run as is
    if (tmp) std::fclose(tmp);
    if (saved >= 0) ::close(saved);
    fn();
    return {};
  }
  struct Restore {
    int saved;
    FILE* tmp;
    ~Restore() {
      std::fflush(stderr);
      ::dup2(saved, 2);
      ::close(saved);
    }
  };
  std::string out;
  {
    Restore r{saved, tmp};
    fn();
  }
  std::rewind(tmp);
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof(buf), tmp)) > 0 && out.size() < 65536) out.append(buf, n);
  std::fclose(tmp);
  return out;
}

/** "file:line:col: YAML syntax error: what" from libfyaml's
 *  "<memory-@0x...>:line:col: error: what". */
std::string syntaxError(const std::string& diag, const std::string& file) {
  // ":<line>:<col>: error: <what>" (scanned by hand: std::regex recurses per character).
  for (size_t at = diag.find(": error: "); at != std::string::npos; at = diag.find(": error: ", at + 1)) {
    size_t b = at;
    auto digitsBack = [&](size_t& pos) {  // digits ending at pos - 1, preceded by ':'
      size_t q = pos;
      while (q > 0 && std::isdigit(static_cast<unsigned char>(diag[q - 1]))) q--;
      if (q == pos || q == 0 || diag[q - 1] != ':') return std::string();
      std::string d = diag.substr(q, pos - q);
      pos = q - 1;
      return d;
    };
    const std::string col = digitsBack(b);
    const std::string line = col.empty() ? std::string() : digitsBack(b);
    if (line.empty()) continue;
    const size_t from = at + 9, nl = diag.find('\n', from);
    return file + ":" + line + ":" + col + ": YAML syntax error: " +
           diag.substr(from, nl == std::string::npos ? std::string::npos : nl - from);
  }
  std::string first = diag.substr(0, diag.find('\n'));
  return file + ": YAML syntax error: " + first.substr(0, 200);
}

/** A YAML line without its trailing comment (a '#' after a space, not
 *  inside quotes) and trailing spaces. */
std::string lineContent(const std::string& l) {
  char quote = 0;
  size_t end = l.size();
  for (size_t i = 0; i < l.size(); i++) {
    const char c = l[i];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '#' && (i == 0 || l[i - 1] == ' ' || l[i - 1] == '\t')) {
      end = i;
      break;
    }
  }
  std::string r = l.substr(0, end);
  while (!r.empty() && (r.back() == ' ' || r.back() == '\t' || r.back() == '\r')) r.pop_back();
  return r;
}

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string l;
  while (std::getline(in, l)) lines.push_back(l);
  return lines;
}

/** Column of the key on a "- - key:" line (the first non-dash item). */
size_t itemColumn(const std::string& c, size_t ind) {
  size_t item = ind;
  while (item + 1 < c.size() && c[item] == '-' && c[item + 1] == ' ') item = c.find_first_not_of(' ', item + 1);
  return item;
}

/** "key" of a block-mapping line "key: value" / "key:" starting at `from`
 *  (plain or quoted key); empty if the line is no such entry. */
std::string mappingKey(const std::string& c, size_t from) {
  if (from >= c.size() || c[from] == '{' || c[from] == '[' || c[from] == '-' || c[from] == '?') return "";
  size_t i = from;
  if (c[i] == '"' || c[i] == '\'') {
    const size_t close = c.find(c[i], i + 1);
    if (close == std::string::npos) return "";
    i = close + 1;
  } else {
    while (i < c.size() && !(c[i] == ':' && (i + 1 == c.size() || c[i + 1] == ' '))) i++;
  }
  if (i >= c.size() || c[i] != ':' || (i + 1 < c.size() && c[i + 1] != ' ')) return "";
  return c.substr(from, i - from);
}

/** "key: |", "- >-", "key: |2": the line opens a block scalar. */
bool startsBlockScalar(const std::string& c) {
  size_t e = c.size();
  while (e > 0 && (c[e - 1] == '-' || c[e - 1] == '+' || std::isdigit(static_cast<unsigned char>(c[e - 1])))) e--;
  if (e == 0 || (c[e - 1] != '|' && c[e - 1] != '>')) return false;
  size_t b = e - 1;
  while (b > 0 && c[b - 1] == ' ') b--;
  return b < e - 1 && b > 0 && (c[b - 1] == ':' || c[b - 1] == '-');
}

/** YAML reads an empty value ("tracking:" with nothing below it, a bare
 *  "-") as null, which MRPT's parser rejects ("Unexpected empty scalar", no
 *  line). Writes an explicit null (~) there; returns how many. Block
 *  scalars (| and >) are left alone. */
size_t fillEmptyValues(std::string& text) {
  std::vector<std::string> lines = splitLines(text);
  auto indentOf = [](const std::string& l) { return l.find_first_not_of(' '); };
  size_t filled = 0;
  size_t block_indent = std::string::npos;  // inside a | or > block scalar deeper than this
  for (size_t i = 0; i < lines.size(); i++) {
    const std::string c = lineContent(lines[i]);
    const size_t ind = indentOf(c);
    if (ind == std::string::npos) continue;  // blank or comment
    if (block_indent != std::string::npos) {
      if (ind > block_indent) continue;
      block_indent = std::string::npos;
    }
    if (startsBlockScalar(c)) {
      block_indent = ind;
      continue;
    }
    const bool dash = c.compare(ind, std::string::npos, "-") == 0;
    const bool key = !dash && c.back() == ':';
    if (!dash && !key) continue;
    size_t next_ind = std::string::npos;
    std::string next;
    for (size_t j = i + 1; j < lines.size() && next_ind == std::string::npos; j++) {
      next = lineContent(lines[j]);
      next_ind = indentOf(next);
    }
    const size_t item = itemColumn(c, ind);
    const bool next_is_item = next_ind != std::string::npos && next[next_ind] == '-' &&
                              (next_ind + 1 == next.size() || next[next_ind + 1] == ' ');
    const bool has_block =
        next_ind != std::string::npos && (next_ind > item || (key && next_ind == item && next_is_item));
    if (has_block) continue;
    lines[i] = c + " ~" + lines[i].substr(c.size());
    filled++;
  }
  if (filled) {
    std::string out;
    for (const auto& l : lines) out += l + "\n";
    text = out;
  }
  return filled;
}

/** The keys of flow mappings ({a: 1, b: [2, 3]}), which may span lines:
 *  fed line by line (comments removed), throws on a key written twice in
 *  one of them. */
class FlowKeys {
 public:
  explicit FlowKeys(const std::string& file) : file_(file) {}
  bool inside() const { return !stack_.empty(); }

  /** Scans `c` (line `line`) from `from`, which is inside a flow collection
   *  or at the '{' / '[' that opens one. */
  void scan(const std::string& c, size_t from, size_t line) {
    for (size_t i = from; i < c.size(); i++) {
      const char ch = c[i];
      if (stack_.empty()) return;  // the collection closed; the rest is no flow
      Ctx& t = stack_.back();
      const char before = last_;
      if (ch != ' ' && ch != '\t') last_ = ch;
      if ((ch == '"' || ch == '\'') && std::strchr("{[,:", before)) {  // a quoted scalar: its text, without the quotes
        const size_t close = c.find(ch, i + 1);
        const size_t end = close == std::string::npos ? c.size() : close;
        if (t.map && t.in_key) t.key += c.substr(i + 1, end - i - 1);
        i = end;
      } else if (ch == '{' || ch == '[') {
        stack_.push_back({ch == '{', true, {}, {}});
      } else if (ch == '}' || ch == ']') {
        endEntry(line);
        stack_.pop_back();
      } else if (ch == ',') {
        endEntry(line);
      } else if (ch == ':' && t.map && t.in_key && (i + 1 == c.size() || std::strchr(" ,}]", c[i + 1]))) {
        addKey(line);
        t.in_key = false;
      } else if (t.map && t.in_key) {
        t.key += ch;
      }
    }
    if (!stack_.empty() && stack_.back().map && stack_.back().in_key) stack_.back().key += ' ';  // the line break
  }

  /** Starts scanning at `from` when a flow collection opens there. */
  void start(const std::string& c, size_t from, size_t line) {
    if (from < c.size() && (c[from] == '{' || c[from] == '[')) {
      last_ = c[from];
      stack_.push_back({c[from] == '{', true, {}, {}});
      scan(c, from + 1, line);
    }
  }

 private:
  struct Ctx {
    bool map;
    bool in_key;                           ///< reading a key (before its ':')
    std::string key;                       ///< the key read so far
    std::map<std::string, size_t> keys;    ///< key -> line
  };
  void addKey(size_t line) {
    Ctx& t = stack_.back();
    const size_t b = t.key.find_first_not_of(' ');
    const std::string key = b == std::string::npos ? "" : t.key.substr(b, t.key.find_last_not_of(' ') - b + 1);
    t.key.clear();
    if (key.empty()) return;
    auto [it, fresh] = t.keys.emplace(key, line);
    if (!fresh)
      throw ConfigError(file_ + ":" + std::to_string(line) + ": key '" + key + "' appears twice in the same {...} map" +
                        (it->second == line ? "" : " (first on line " + std::to_string(it->second) + ")") +
                        "; YAML would keep only the last one");
  }
  /** ',' or the closing bracket: an entry without ':' ({a, b}) is a key too. */
  void endEntry(size_t line) {
    Ctx& t = stack_.back();
    if (t.map && t.in_key) addKey(line);
    t.in_key = true;
    t.key.clear();
  }
  std::string file_;
  std::vector<Ctx> stack_;
  char last_ = '{';  ///< the last character other than a space: a quote after one of {[,: opens a quoted scalar
};

/** YAML forbids a key twice in one mapping, and MRPT's parser silently keeps
 *  the last one: `pipeline:` written twice ran the second. Block mappings
 *  and flow mappings ({a: 1, a: 2}). */
void checkDuplicateKeys(const std::string& text, const std::string& file) {
  struct Level {
    size_t column;
    std::map<std::string, size_t> keys;  ///< key -> line
  };
  std::vector<Level> stack;
  const std::vector<std::string> lines = splitLines(text);
  size_t block_indent = std::string::npos;
  FlowKeys flow(file);
  for (size_t i = 0; i < lines.size(); i++) {
    const std::string c = lineContent(lines[i]);
    const size_t ind = c.find_first_not_of(' ');
    if (flow.inside()) {  // a line inside a flow collection opened above
      flow.scan(c, 0, i + 1);
      continue;
    }
    if (ind == std::string::npos || c.compare(ind, 3, "---") == 0 || c.compare(ind, 3, "...") == 0) continue;
    if (block_indent != std::string::npos) {
      if (ind > block_indent) continue;
      block_indent = std::string::npos;
    }
    const size_t col = itemColumn(c, ind);
    const bool item = col != ind;  // a "- " sequence item opens a new mapping at col
    while (!stack.empty() && (stack.back().column > col || (item && stack.back().column >= col))) stack.pop_back();
    if (startsBlockScalar(c)) block_indent = ind;
    const std::string key = mappingKey(c, col);
    flow.start(c, key.empty() ? col : c.find_first_not_of(' ', col + key.size() + 1), i + 1);
    if (key.empty()) continue;
    if (stack.empty() || stack.back().column != col) stack.push_back({col, {}});
    auto [it, fresh] = stack.back().keys.emplace(key, i + 1);
    if (!fresh)
      throw ConfigError(file + ":" + std::to_string(i + 1) + ": key '" + key +
                        "' appears twice in the same map (first on line " + std::to_string(it->second) +
                        "); YAML would keep only the last one");
  }
}

/** Deeper nesting (of block and flow collections together) is an error:
 *  libfyaml and MRPT's parser recurse per level and overflow the stack
 *  at about 10,000 levels (the JSON reader has the same bound). */
constexpr size_t kMaxYamlDepth = 256;

/** What MRPT's parser does not report with a line, or not at all, checked
 *  on the text before parsing: NUL bytes (the parser stops there silently),
 *  a second document (silently ignored), anchors and aliases (an assertion
 *  inside the parser), nesting deeper than kMaxYamlDepth (a stack overflow).
 *  Blanks the document markers of the one document ('---' before it, '...'
 *  after it). */
void checkStructure(std::string& text, const std::string& file) {
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw ConfigError(file + ":" + std::to_string(yamlu::lineOf(text, nul)) + ": a NUL byte (byte " +
                      std::to_string(nul) + "); YAML files are text");
  std::vector<std::string> lines = splitLines(text);
  auto fail = [&](size_t i, const std::string& what) {
    throw ConfigError(file + ":" + std::to_string(i + 1) + ": " + what);
  };
  bool content = false, ended = false, changed = false;
  size_t block_indent = std::string::npos;
  std::vector<size_t> indents;  // block levels
  long flow = 0;                // open [ and { (outside quotes)
  for (size_t i = 0; i < lines.size(); i++) {
    const std::string c = lineContent(lines[i]);
    const size_t ind = c.find_first_not_of(' ');
    if (ind == std::string::npos) continue;
    if (block_indent != std::string::npos) {
      if (ind > block_indent) continue;
      block_indent = std::string::npos;
    }
    const bool marker = ind == 0 && (c.compare(0, 3, "---") == 0 || c.compare(0, 3, "...") == 0) &&
                        (c.size() == 3 || c[3] == ' ');
    if (marker) {
      if (c[0] == '-' && content)
        fail(i, "a second YAML document starts here ('---'); a dslam YAML file holds one document");
      if (c.size() == 3) {
        if (c[0] == '.') ended = true;
        lines[i].clear();
        changed = true;
        continue;
      }
    }
    if (ended) fail(i, "text after the end of the YAML document ('...')");
    content = true;
    if (startsBlockScalar(c)) block_indent = ind;
    // Anchors and aliases: a token starting with & or * where a value
    // starts (after "key:", "- ", '[', '{' or ','; not inside a plain
    // scalar such as "a *note*").
    char quote = 0, prev = 0;  // prev: the last character other than a space
    for (size_t k = 0; k < c.size(); k++) {
      const char ch = c[k];
      const char before = prev;
      if (ch != ' ' && ch != '\t') prev = ch;
      if (quote) {
        if (ch == quote) quote = 0;
        continue;
      }
      const bool value_start = before == 0 || std::strchr(":-[{,", before);
      if ((ch == '"' || ch == '\'') && (k == 0 || std::strchr(" [{,:", c[k - 1]))) {
        quote = ch;
      } else if ((ch == '&' || ch == '*') && value_start && (k == 0 || c[k - 1] == ' ' || std::strchr("[{,", c[k - 1])) &&
                 k + 1 < c.size() && (std::isalnum(static_cast<unsigned char>(c[k + 1])) || c[k + 1] == '_')) {
        fail(i, std::string("YAML ") + (ch == '&' ? "anchors (&name)" : "aliases (*name)") +
                    " are not supported; write the value out");
      } else if (ch == '[' || ch == '{') {
        if (++flow + static_cast<long>(indents.size()) > static_cast<long>(kMaxYamlDepth))
          fail(i, "nested more than " + std::to_string(kMaxYamlDepth) + " levels deep");
      } else if (ch == ']' || ch == '}') {
        flow--;
      }
    }
    // Block levels: indentation, and each "- " of compact nested lists.
    while (!indents.empty() && indents.back() > ind) indents.pop_back();
    if (indents.empty() || indents.back() < ind) indents.push_back(ind);
    const size_t items = (itemColumn(c, ind) - ind + 1) / 2;
    if (indents.size() + items + static_cast<size_t>(std::max(0L, flow)) > kMaxYamlDepth)
      fail(i, "nested more than " + std::to_string(kMaxYamlDepth) + " levels deep");
  }
  if (changed) {
    std::string out;
    for (const auto& l : lines) out += l + "\n";
    text = out;
  }
}

yaml parseText(const std::string& text_in, const std::string& file) {
  if (const size_t bad = yamlu::invalidUtf8(text_in); bad != std::string::npos)  // libfyaml can hang on it
    throw ConfigError(file + ":" + std::to_string(yamlu::lineOf(text_in, bad)) + ": not valid UTF-8 text (byte " +
                      std::to_string(bad) + "); YAML files must be UTF-8");
  std::string text = text_in;
  checkStructure(text, file);
  fillEmptyValues(text);
  yaml y;
  std::string exception_msg;
  const std::string diag = captureStderr([&] {
    try {
      y = yaml::FromText(text);
    } catch (const std::exception& e) {
      exception_msg = e.what();
    }
  });
  if (diag.find("error") != std::string::npos) throw ConfigError(syntaxError(diag, file));
  if (!exception_msg.empty()) {
    // MRPT's message carries "<memory>:line:col: error" plus a backtrace.
    if (exception_msg.find(": error: ") != std::string::npos) throw ConfigError(syntaxError(exception_msg, file));
    // An assertion inside the parser: "==== MRPT exception ====\nMessage: ..."
    std::string what;
    if (const size_t m = exception_msg.find("Message:"); m != std::string::npos) {
      what = exception_msg.substr(m + 8, exception_msg.find('\n', m) - m - 8);
      what.erase(0, what.find_first_not_of(' '));
    }
    if (what.find("isScalar") != std::string::npos) what = "a map key that is not a plain value ({...}: or [...]:)";
    throw ConfigError(file + ": YAML syntax error: " + (what.empty() ? "the parser gives no reason" : what));
  }
  if (!diag.empty()) std::cerr << diag;  // warnings: pass them on
  checkDuplicateKeys(text, file);
  return y;
}

bool pathExists(const std::string& p) {
  std::error_code ec;  // "File name too long" and the like: not there
  return fs::exists(p, ec);
}

/** Bounds on $include{}: how deep a chain of includes may go, and how many
 *  a file may expand to in all (includes that include twice what includes
 *  twice grow exponentially: 20 such files ran out of memory). */
constexpr size_t kMaxIncludeDepth = 64;
constexpr size_t kMaxIncludes = 1000;

struct Resolver {
  LoadedYaml* out;
  std::vector<std::string> stack;
  size_t includes = 0;

  void resolveNode(node_t& n, const std::string& key_path, const std::string& cur_file) {
    if (n.isMap()) {
      for (auto& kv : n.asMap()) {
        const std::string k = yamlu::scalarText(kv.first).value_or("");
        resolveNode(kv.second, key_path.empty() ? k : key_path + "." + k, cur_file);
      }
    } else if (n.isSequence()) {
      size_t i = 0;
      for (auto& e : n.asSequence()) resolveNode(e, key_path + "[" + std::to_string(i++) + "]", cur_file);
    } else if (auto t = yamlu::scalarText(n)) {
      if (const auto path = includePath(*t)) {
        const std::string inc = resolvePath(*path, fs::path(cur_file).parent_path().string());
        if (!fileExists(inc))
          throw ConfigError(cur_file + ":" + std::to_string(n.marks.line + 1) + ": key '" + key_path + "': included " +
                            (pathExists(inc) ? "path is not a regular file: " : "file not found: ") + inc);
        if (stack.size() > kMaxIncludeDepth)
          throw ConfigError(cur_file + ":" + std::to_string(n.marks.line + 1) + ": key '" + key_path +
                            "': $include{} nested more than " + std::to_string(kMaxIncludeDepth) + " files deep");
        if (++includes > kMaxIncludes)
          throw ConfigError(cur_file + ":" + std::to_string(n.marks.line + 1) + ": key '" + key_path + "': more than " +
                            std::to_string(kMaxIncludes) +
                            " $include{} expansions in all (files that include others several times each)");
        yaml sub = loadFile(inc);
        n = sub.node();
        out->origins[key_path] = inc;
        stack.push_back(fs::weakly_canonical(inc).string());  // the chain of includes being resolved
        resolveNode(n, key_path, inc);
        stack.pop_back();
      }
    }
  }

  yaml loadFile(const std::string& path) {
    const std::string canon = fs::weakly_canonical(path).string();
    for (const auto& s : stack)
      if (s == canon) throw ConfigError("include cycle: " + path + " includes itself (via " + stack.back() + ")");
    std::ifstream f(path);
    if (!f) throw DataError("cannot read YAML file: " + path);
    std::stringstream ss;
    ss << f.rdbuf();
    return parseText(expandVariables(ss.str(), path), path);
  }
};

}  // namespace

LoadedYaml loadYamlFile(const std::string& path) {
  if (!fileExists(path)) throw DataError("config file not found: " + path);
  LoadedYaml ly;
  ly.file = path;
  Resolver r{&ly, {}};
  ly.root = std::make_shared<yaml>(r.loadFile(path));
  r.stack.push_back(fs::weakly_canonical(path).string());
  r.resolveNode(ly.root->node(), "", path);
  return ly;
}

LoadedYaml loadYamlText(const std::string& text, const std::string& pseudo_file, const std::string& base_dir) {
  LoadedYaml ly;
  ly.file = pseudo_file;
  Resolver r{&ly, {}};
  ly.root = std::make_shared<yaml>(parseText(expandVariables(text, pseudo_file), pseudo_file));
  r.resolveNode(ly.root->node(), "", (fs::path(base_dir) / pseudo_file).string());
  return ly;
}

}  // namespace dslam::config
