#pragma once
/** \file yaml_util.h
 *  Strict helpers over mrpt::containers::yaml nodes (MRPT stores every
 *  scalar as text). Include only in .cpp files: it pulls in MRPT's yaml. */
#include <mrpt/containers/yaml.h>

#include <functional>
#include <ostream>
#include <optional>
#include <string>
#include <vector>

namespace dslam::yamlu {

using node_t = mrpt::containers::yaml::node_t;

/** Text of a scalar node (nullopt for null / map / sequence nodes). */
std::optional<std::string> scalarText(const node_t& n);
std::optional<bool> parseBool(const std::string& s);
std::optional<long long> parseInt(const std::string& s);
std::optional<double> parseDouble(const std::string& s);
/** "map", "sequence", "null" or "scalar 'text'". */
std::string describe(const node_t& n);
/** Key node of `key` in map node `m` (for its line mark), or nullptr. */
const node_t* findKey(const node_t& m, const std::string& key);
const node_t* findValue(const node_t& m, const std::string& key);
/** Keys of a map node in file order (by line, then column). */
std::vector<std::string> keysInOrder(const node_t& m);
/** Byte offset of the first byte of `s` that is not part of a valid UTF-8
 *  sequence (overlong forms, surrogates and code points above U+10FFFF are
 *  invalid), or std::string::npos. YAML text must be UTF-8, and libfyaml
 *  (under MRPT's yaml) loops forever on some invalid bytes, e.g. "%\x80":
 *  every text is checked before it is parsed. */
size_t invalidUtf8(const std::string& s);
/** 1-based line number of byte offset `pos` in `s`. */
size_t lineOf(const std::string& s, size_t pos);
/** mrpt::containers::yaml::FromText after the UTF-8 check; `what` names
 *  the source ("file.yaml", "parameter 'x'") in the ConfigError. */
mrpt::containers::yaml parseYamlText(const std::string& text, const std::string& what);

/** Levenshtein distance, for "did you mean" hints. */
size_t editDistance(const std::string& a, const std::string& b);
/** ", did you mean 'x'?" if a candidate is close, else "". */
std::string didYouMean(const std::string& key, const std::vector<std::string>& valid);
std::string join(const std::vector<std::string>& v, const std::string& sep = ", ");
/** A scalar as YAML text, quoted when needed ('' for the empty string, a
 *  double-quoted escape string for control characters, ~ for null). */
std::string scalarOut(const node_t& n);
/** Writes the value part of `key: value` (leading space or newline, then
 *  nested maps and lists indented by `indent`); flow style for lists of
 *  scalars and for empty maps and lists. */
void emitValue(std::ostream& o, const node_t& n, int indent);
/** Emits a document as YAML text that the YAML loader reads back to the
 *  same tree (map keys in file order; MRPT's own printer does not quote
 *  values such as 'a: b' or '#x' and drops empty lists). */
std::string toYamlText(const mrpt::containers::yaml& y);

/** A node of a file with its key path ("objects[2].size"), for messages. */
struct At {
  const node_t* n;
  std::string path;
};

/** Typed, strict access to a YAML tree with "file:line: 'key.path': what"
 *  errors (ConfigError): the accessor of dslam's hand-structured YAML files
 *  (scenarios). Plug-in parameters go through dslam::Params, which shares the
 *  scalar parsers above. `file_for` maps a key path to the file it came from
 *  (config::LoadedYaml::fileFor, for $include{}d parts). */
class TypedReader {
 public:
  explicit TypedReader(std::function<std::string(const std::string&)> file_for) : file_for_(std::move(file_for)) {}
  virtual ~TypedReader() = default;

  [[noreturn]] void fail(const At& at, const std::string& msg) const;
  void requireMap(const At& m) const;
  /** Every key of map `m` must be in `allowed` (with a "did you mean"). */
  void checkKeys(const At& m, const std::vector<std::string>& allowed) const;
  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }
  /** m[key], nullopt when missing or null. */
  std::optional<At> child(const At& m, const std::string& key) const;
  At required(const At& m, const std::string& key) const;
  double num(const At& v) const;
  double num(const At& m, const std::string& key, double def) const;
  /** > 0 (>= 0 with allow_zero). */
  double positive(const At& m, const std::string& key, double def, bool allow_zero = false) const;
  long long integer(const At& v) const;
  long long integer(const At& m, const std::string& key, long long def) const;
  bool boolean(const At& m, const std::string& key, bool def) const;
  std::string str(const At& v) const;
  std::string str(const At& m, const std::string& key, const std::string& def) const;
  std::string oneOf(const At& m, const std::string& key, const std::string& def, const std::vector<std::string>& valid,
                    const std::string& what) const;
  std::vector<At> list(const At& v) const;
  /** A list of min_n..max_n numbers. */
  std::vector<double> numbers(const At& v, size_t min_n, size_t max_n) const;

 private:
  std::function<std::string(const std::string&)> file_for_;
};

}  // namespace dslam::yamlu
