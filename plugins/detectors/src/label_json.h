#pragma once
// Private helpers of the label readers and writers (label_io.cpp,
// panoptic_io.cpp): JSON through nlohmann with errors that name the file and
// the place in it, and the common file writers.
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "dslam/core/detection.h"
#include "dslam/core/json_layout.h"

namespace dslam::labels::detail {

using json = nlohmann::json;

/** JSON files are read by dslam::parseJsonFile (core/json_layout.h): a
 *  syntax error names the file, line and column. */
using dslam::parseJsonFile;

/** Where a value sits in a file, for messages: "f.json: boxes[3].bbox". */
struct At {
  std::string file, path;
  At key(const std::string& k) const { return {file, path.empty() ? k : path + "." + k}; }
  At index(size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
  std::string str() const { return path.empty() ? file : file + ": " + path; }
};

/** Short one-line excerpt of a value for error messages. */
std::string describe(const json& v);
double number(const At& at, const json& v);
int integer(const At& at, const json& v);
std::vector<double> numberList(const At& at, const json& v, size_t len);
/** obj[key]; DataError "<what> lacks 'key'" when missing. */
const json& need(const At& at, const json& obj, const char* key, const char* what);
/** obj[key] when present and not null, else nullptr. */
const json* optional(const json& obj, const char* key);
bool truthy(const At& at, const json& v);

void writeText(const std::string& file, const std::string& text);
void writePng(const std::string& file, const cv::Mat& m);
cv::Mat readImage(const std::string& file, int flags, const std::string& what);

nlohmann::ordered_json boxObject(const BoundingBox& b);
nlohmann::ordered_json segmentObject(const PanopticSegment& s, bool with_kind);

}  // namespace dslam::labels::detail
