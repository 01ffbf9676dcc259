#pragma once
/** \file yaml_loader.h
 *  YAML file loading with `$include{file}` and `${VAR|default}` (MOLA
 *  style). Nothing here runs shell commands.
 *
 *  - `${VAR}` / `${VAR|default}` are replaced in the text before parsing by
 *    the environment variable VAR, else the default; without a default an
 *    unset variable is an error. Built-ins: `${DSLAM_SHARED_DIR}` defaults to
 *    dslam::sharedDir(), `${CONFIG_DIR}` is the folder of the current file.
 *  - A scalar value `$include{path}` is replaced by the parsed content of
 *    that file (relative to the including file), recursively; include cycles
 *    are errors. */
#include <map>
#include <memory>
#include <string>

#include "mrpt/containers/yaml_frwd.h"

namespace dslam::config {

/** A loaded document and, for error messages, which file each included
 *  subtree came from (key path prefix -> file). */
struct LoadedYaml {
  std::shared_ptr<mrpt::containers::yaml> root;
  std::string file;                               ///< top-level file
  std::map<std::string, std::string> origins;     ///< "camera" -> "cams/tum.yaml"
  /** File that defines the node at `key_path` (longest matching prefix). */
  std::string fileFor(const std::string& key_path) const;
};

/** Substitutes ${VAR|default} in `text` (file/line used in errors). */
std::string expandVariables(const std::string& text, const std::string& file);

/** Loads and fully resolves a YAML file. Throws ConfigError / DataError
 *  naming the file (and line) on failure. */
LoadedYaml loadYamlFile(const std::string& path);
/** Same for in-memory text (includes resolve against `base_dir`). */
LoadedYaml loadYamlText(const std::string& text, const std::string& pseudo_file, const std::string& base_dir);

}  // namespace dslam::config
