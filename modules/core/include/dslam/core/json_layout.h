#pragma once
/** \file json_layout.h
 *  Readable JSON files: the first `depth` levels of objects and arrays one
 *  member per line, everything deeper on one line (so long per-frame arrays
 *  do not take one line per number). Every value is printed by nlohmann::json
 *  (escaping, numbers); only the line breaks are chosen here. Also the one
 *  JSON file reader with file:line:column errors. */
#include <nlohmann/json_fwd.hpp>

#include <exception>
#include <string>

namespace dslam {

std::string layoutJson(const nlohmann::ordered_json& j, int depth);
std::string layoutJson(const nlohmann::json& j, int depth);

/** Reads and parses a JSON file. DataError naming the file (missing /
 *  unreadable), and for a syntax error its line:column. */
nlohmann::json parseJsonFile(const std::string& file);

/** The message of a nlohmann::json exception without its
 *  "[json.exception.type_error.302] " prefix. */
std::string jsonErrorText(const std::exception& e);

}  // namespace dslam
