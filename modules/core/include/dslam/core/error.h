#pragma once
/** \file error.h
 *  Exception types used across dslam. Every user-facing error names the thing
 *  that is wrong (file, line, key path, frame index) in its message. */
#include <stdexcept>
#include <string>

namespace dslam {

/** Base of all dslam errors. */
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** Input data problem (missing file, corrupt image, bad timestamps...). */
class DataError : public Error {
 public:
  using Error::Error;
};

/** Configuration problem: unknown key, wrong type, missing required key. */
class ConfigError : public Error {
 public:
  using Error::Error;
};

/** The message of a third-party exception as one short line: the text after
 *  "Message:" of an MRPT exception (which carries a multi-line backtrace),
 *  else its first line; cut to `max_len` characters. */
inline std::string exceptionSummary(const std::exception& e, size_t max_len = 300) {
  std::string s = e.what();
  if (const size_t m = s.find("Message:"); m != std::string::npos) {
    s.erase(0, m + 8);
    s.erase(0, s.find_first_not_of(" \t"));
  }
  if (const size_t nl = s.find('\n'); nl != std::string::npos) s.erase(nl);
  if (s.size() > max_len) s = s.substr(0, max_len) + "...";
  for (char& c : s)  // a class name read from a corrupt file: raw bytes
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return s;
}

}  // namespace dslam
