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

}  // namespace dslam
