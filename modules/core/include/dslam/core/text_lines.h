#pragma once
/** \file text_lines.h
 *  Reading the line-based text files of datasets and trajectories (TUM
 *  lists, EuRoC CSV, KITTI poses and times, trajectory files). */
#include <string>
#include <vector>

namespace dslam {

/** One data line of a text file, with its 1-based number. */
struct TextLine {
  int lineno;
  std::string text;
};

/** The data lines of `file`: without a UTF-8 byte-order mark (Windows
 *  editors write one) and '\r' line ends; blank lines and lines starting
 *  with '#' skipped; with `trailing_comments`, a '#' anywhere starts a
 *  comment. Throws DataError "cannot open FILE (hint)" if it cannot be
 *  opened. */
std::vector<TextLine> readDataLines(const std::string& file, const std::string& hint = "",
                                    bool trailing_comments = false);

/** Splits on spaces, tabs and (if `commas`) commas; drops empty fields. */
std::vector<std::string> splitFields(const std::string& s, bool commas = false);

}  // namespace dslam
