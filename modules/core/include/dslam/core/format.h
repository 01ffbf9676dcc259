#pragma once
/** \file format.h
 *  Numbers in messages and tables. */
#include <cstdio>
#include <string>

namespace dslam {

/** `v` printed with one printf conversion, e.g. formatNumber("%g", 0.5),
 *  formatNumber("%.6f", stamp). */
inline std::string formatNumber(const char* printf_format, double v) {
  char b[64];
  std::snprintf(b, sizeof b, printf_format, v);
  return b;
}

}  // namespace dslam
