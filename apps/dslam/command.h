#pragma once
/** \file command.h
 *  Sub-command registration for the dslam CLI. A cmd_<name>.cpp file does
 *
 *      static void setup(CLI::App& sub) { ...options...; sub.callback([]{...}); }
 *      DSLAM_COMMAND(eval, "Evaluate trajectories (ATE, RPE)", setup);
 *
 *  Callbacks report errors by throwing (dslam::Error -> exit 1 with
 *  "error: ..."), CLI::ValidationError -> usage error, exit 2). */
#include <CLI/CLI.hpp>

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
