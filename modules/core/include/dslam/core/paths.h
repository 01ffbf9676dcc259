#pragma once
/** \file paths.h
 *  Locations of shared data and path helpers. */
#include <string>

namespace dslam {

/** Root of the shared models/data folder: $DSLAM_SHARED_DIR if set, else the
 *  path configured at build time (<source>/../shared). */
std::string sharedDir();
/** sharedDir() + "/" + rel; throws DataError naming the file and pointing at
 *  scripts/download_data.sh if it does not exist. */
std::string sharedPath(const std::string& rel);
/** `<prefix>/share/dslam` of an installed dslam (`cmake --install`): found
 *  from the location of the dslam_core library (`<prefix>/lib/...`), so it
 *  works for the dslam command and for programs that link the libraries.
 *  Empty when running from a build tree. Holds config/, the default
 *  vocabulary and the plot scripts. */
std::string installDataDir();
/** Resolves `p` against `base_dir` unless absolute; expands a leading "~/". */
std::string resolvePath(const std::string& p, const std::string& base_dir);
bool fileExists(const std::string& p);
/** Whether `path` is the folder `dir` or lies inside it, after resolving
 *  symlinks, "." and ".." (neither needs to exist). */
bool isInside(const std::string& path, const std::string& dir);
bool dirExists(const std::string& p);
/** " (N MB free on its disk)" for the disk of the file `path` (its folder,
 *  or the current one), "" when that cannot be told: for messages about a
 *  failed write, whose usual cause is a full disk. */
std::string freeSpaceNote(const std::string& path);
/** Throws DataError("<what> not found: <path>" + hint) if missing. */
void requireFile(const std::string& p, const std::string& what, const std::string& hint = "");
void requireDir(const std::string& p, const std::string& what, const std::string& hint = "");
/** Creates output folder `p` (and its parents); a DataError naming `what`
 *  and the path when it cannot: a file is in the way, no permission. */
void makeOutputDir(const std::string& p, const std::string& what);

}  // namespace dslam
