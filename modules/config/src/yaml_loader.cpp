#include "dslam/config/yaml_loader.h"

#include <mrpt/containers/yaml.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <filesystem>
#include <fstream>
#include <regex>
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

std::string expandVariables(const std::string& text, const std::string& file) {
  static const std::regex re(R"(\$\{([A-Za-z_][A-Za-z0-9_]*)(\|([^}]*))?\})");
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
    auto begin = std::sregex_iterator(code.begin(), code.end(), re);
    size_t last = 0;
    for (auto it = begin; it != std::sregex_iterator(); ++it) {
      const auto& m = *it;
      res += code.substr(last, m.position() - last);
      const std::string var = m[1].str();
      const bool has_def = m[2].matched;
      const char* e = std::getenv(var.c_str());
      if (e && *e)
        res += e;
      else if (has_def)
        res += m[3].str();
      else if (var == "DSLAM_SHARED_DIR")
        res += sharedDir();
      else if (var == "CONFIG_DIR")
        res += cfgdir.empty() ? "." : cfgdir;
      else
        throw ConfigError(file + ":" + std::to_string(lineno) + ": environment variable '" + var +
                          "' is not set and has no default (write ${" + var + "|default})");
      last = m.position() + m.length();
    }
    res += code.substr(last);
    out += res + comment + "\n";
  }
  return out;
}

namespace {

const std::regex kInclude(R"(^\$include\{([^}]+)\}$)");

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
  static const std::regex re(R"(:(\d+):(\d+): error: ([^\n]*))");
  std::smatch m;
  if (std::regex_search(diag, m, re))
    return file + ":" + m[1].str() + ":" + m[2].str() + ": YAML syntax error: " + m[3].str();
  std::string first = diag.substr(0, diag.find('\n'));
  return file + ": YAML syntax error: " + first.substr(0, 200);
}

yaml parseText(const std::string& text, const std::string& file) {
  if (const size_t bad = yamlu::invalidUtf8(text); bad != std::string::npos)  // libfyaml can hang on it
    throw ConfigError(file + ":" + std::to_string(yamlu::lineOf(text, bad)) + ": not valid UTF-8 text (byte " +
                      std::to_string(bad) + "); YAML files must be UTF-8");
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
    throw ConfigError(file + ": YAML syntax error: " + exception_msg.substr(0, exception_msg.find('\n')));
  }
  if (!diag.empty()) std::cerr << diag;  // warnings: pass them on
  return y;
}

struct Resolver {
  LoadedYaml* out;
  std::vector<std::string> stack;

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
      std::smatch m;
      if (std::regex_match(*t, m, kInclude)) {
        const std::string inc = resolvePath(m[1].str(), fs::path(cur_file).parent_path().string());
        if (!fileExists(inc))
          throw ConfigError(cur_file + ":" + std::to_string(n.marks.line + 1) + ": key '" + key_path +
                            "': included file not found: " + inc);
        yaml sub = loadFile(inc);
        n = sub.node();
        out->origins[key_path] = inc;
        resolveNode(n, key_path, inc);
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
    stack.push_back(canon);
    yaml y = parseText(expandVariables(ss.str(), path), path);
    stack.pop_back();
    return y;
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
