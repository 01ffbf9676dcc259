#pragma once
/** \file command.h
 *  Sub-command registration for the dslam CLI. A cmd_<name>.cpp file does
 *
 *      static void setup(CLI::App& sub) { ...options...; sub.callback([]{...}); }
 *      DSLAM_COMMAND(eval, "Evaluate trajectories (ATE, RPE)", setup);
 *
 *  Callbacks report errors by throwing (dslam::Error -> exit 1 with
 *  "error: ..."); command-line errors exit with CLI11's codes (105 a value
 *  a check refused, 106 a required argument missing, 109 an unknown
 *  option; docs/errors.md). */
#include <CLI/CLI.hpp>

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace dslam::app {

struct Command {
  std::string name, description;
  std::function<void(CLI::App&)> setup;
};

std::vector<Command>& commands();

struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* desc, std::function<void(CLI::App&)> setup) {
    commands().push_back({name, desc, std::move(setup)});
  }
};

/** Option checks with a readable message (CLI11's PositiveNumber and
 *  NonNegativeNumber print the largest double as the upper bound). */
inline CLI::Validator numberAtLeast(double lo, bool strict) {
  const std::string what = strict ? "greater than " : "at least ";
  return CLI::Validator(
      [lo, strict, what](std::string& s) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(s, v)) return "'" + s + "' is not a number";
        if (strict ? v > lo : v >= lo) return "";
        char b[32];
        std::snprintf(b, sizeof(b), "%g", lo);
        return "must be " + what + b + ", got " + s;
      },
      strict ? "POSITIVE" : "NONNEGATIVE");
}
inline const CLI::Validator kPositive = numberAtLeast(0, true);
inline const CLI::Validator kNonNegative = numberAtLeast(0, false);

/** Exit code the callback asks for (0 unless set), e.g. a failed check. */
int& exitCode();

/** "dslam 0.1.0 (commit 1a2b3c4d5e6f)": release and the git commit of the
 *  build ("-modified" when the tree had uncommitted changes; "unknown"
 *  outside git). */
std::string versionString();
/** The git commit of the build, as in versionString(). */
std::string commit();

}  // namespace dslam::app

#define DSLAM_COMMAND(NAME, DESC, SETUP) \
  static ::dslam::app::CommandRegistrar dslam_cmd_##NAME##_registrar(#NAME, DESC, SETUP)
