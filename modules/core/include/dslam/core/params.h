#pragma once
/** \file params.h
 *  Declared plugin parameters and their validated values.
 *
 *  Every plugin lists its parameters as ParamSpec (name, type, default, one
 *  line of documentation). The pipeline loader validates the YAML given for
 *  the plugin against that list (unknown key, wrong type, missing required
 *  key are ConfigErrors naming file, line and key path and the valid
 *  choices) and fills in the defaults, producing a Params object. The YAML
 *  tree stays behind a pointer so this header does not pull in MRPT. */
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "mrpt/containers/yaml_frwd.h"

namespace dslam {

enum class ParamType {
  Bool,
  Int,
  Double,
  String,
  Path,        ///< string; relative paths resolve against the config file's folder
  Enum,        ///< string restricted to ParamSpec::choices
  IntList,
  DoubleList,
  StringList,
  DoubleMap,   ///< map string -> number, e.g. per-class thresholds
  Map,         ///< free-form YAML map (checked by the plugin itself)
};
const char* toString(ParamType t);

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::Double;
  std::string default_value;  ///< YAML text ("0.2", "[1, 2]", "{person: 0.5}"); empty if required
  std::string doc;            ///< one line
  std::vector<std::string> choices;  ///< Enum only
  bool required = false;
  std::optional<double> min, max;    ///< numeric range check (inclusive)
};

/** Short builders for paramSpecs() lists. */
ParamSpec P_bool(std::string name, bool def, std::string doc);
ParamSpec P_int(std::string name, int64_t def, std::string doc,
                std::optional<double> min = std::nullopt, std::optional<double> max = std::nullopt);
ParamSpec P_double(std::string name, double def, std::string doc,
                   std::optional<double> min = std::nullopt, std::optional<double> max = std::nullopt);
ParamSpec P_string(std::string name, std::string def, std::string doc);
ParamSpec P_path(std::string name, std::string def, std::string doc);
ParamSpec P_required(std::string name, ParamType type, std::string doc);
ParamSpec P_enum(std::string name, std::string def, std::vector<std::string> choices, std::string doc);
ParamSpec P_list(std::string name, ParamType list_type, std::string def, std::string doc);
ParamSpec P_map(std::string name, std::string def, std::string doc);

/** Where a YAML node came from, for error messages. */
struct SourceLocation {
  std::string file;      ///< may be empty (programmatic config)
  std::string key_path;  ///< e.g. "modules[2].params"
  int line = -1;         ///< 1-based, -1 unknown
  bool node_lines = true;  ///< errors take the line of the YAML node (false: values built from the command line)
  std::string str() const;  ///< "file:line: key 'path'"
};

/** Validated parameter values of one plugin (defaults filled in). */
class Params {
 public:
  Params();
  ~Params();
  Params(const Params&);
  Params& operator=(const Params&);

  /** Parses `yaml_text` (a map) without validation: for tests and embedding. */
  static Params fromYaml(const std::string& yaml_text);

  /** Validates `given` (a map node or nullptr = nothing given) against
   *  `specs`, fills defaults, resolves Path values against `base_dir`.
   *  Throws ConfigError. */
  static Params resolve(const std::vector<ParamSpec>& specs, const mrpt::containers::yaml* given,
                        const SourceLocation& where, const std::string& base_dir = "");
  /** Same from YAML text (convenience for tests and embedding). */
  static Params resolve(const std::vector<ParamSpec>& specs, const std::string& yaml_text,
                        const std::string& base_dir = "");

  bool has(const std::string& key) const;
  /** True if the key was written in the YAML (not filled from its default). */
  bool isGiven(const std::string& key) const { return given_.count(key) > 0; }
  bool getBool(const std::string& key) const;
  int64_t getInt(const std::string& key) const;
  double getDouble(const std::string& key) const;
  std::string getString(const std::string& key) const;
  std::vector<int> getIntList(const std::string& key) const;
  std::vector<double> getDoubleList(const std::string& key) const;
  std::vector<std::string> getStringList(const std::string& key) const;
  std::map<std::string, double> getDoubleMap(const std::string& key) const;
  std::vector<std::string> keys() const;

  /** Overrides one value (YAML text for the value). */
  void set(const std::string& key, const std::string& yaml_value);
  /** Overrides one value with a string taken as it is (no YAML parsing:
   *  safe for paths and names with any characters). */
  void setString(const std::string& key, const std::string& value);

  const SourceLocation& location() const { return where_; }
  /** Throws ConfigError "file:line: key 'path': parameter 'key': what"
   *  (for checks a plug-in makes beyond the parameter specs). */
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;
  std::string toYamlText() const;
  const mrpt::containers::yaml& asYaml() const;

 private:
  std::unique_ptr<mrpt::containers::yaml> y_;
  SourceLocation where_;
  std::set<std::string> given_;
  std::vector<std::string> order_;  ///< declaration order (spec order) for printing
};

}  // namespace dslam
