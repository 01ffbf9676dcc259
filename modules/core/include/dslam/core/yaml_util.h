#pragma once
/** \file yaml_util.h
 *  Strict helpers over mrpt::containers::yaml nodes (MRPT stores every
 *  scalar as text). Include only in .cpp files: it pulls in MRPT's yaml. */
#include <mrpt/containers/yaml.h>

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
/** Levenshtein distance, for "did you mean" hints. */
size_t editDistance(const std::string& a, const std::string& b);
/** ", did you mean 'x'?" if a candidate is close, else "". */
std::string didYouMean(const std::string& key, const std::vector<std::string>& valid);
std::string join(const std::vector<std::string>& v, const std::string& sep = ", ");
/** Emits a node as YAML text (flow style for short scalar sequences). */
std::string toYamlText(const mrpt::containers::yaml& y);

}  // namespace dslam::yamlu
