// dslam: command-line entry point. Sub-commands live in cmd_*.cpp.
#include <algorithm>
#include <filesystem>
#include <iostream>

#include "command.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/registry.h"

namespace dslam::app {
std::vector<Command>& commands() {
  static std::vector<Command> c;
  return c;
}
int& exitCode() {
  static int c = 0;
  return c;
}
}  // namespace dslam::app

int main(int argc, char** argv) {
  using namespace dslam;
  CLI::App app{"dslam: visual SLAM in dynamic and changing environments"};
  app.require_subcommand(1);
  int verbosity = 0;
  bool quiet = false;
  app.add_flag("-v,--verbose", verbosity, "more log output (-v debug, -vv trace)");
  app.add_flag("-q,--quiet", quiet, "errors and warnings only");
  app.set_version_flag("--version", app::versionString());
  auto& cmds = app::commands();
  std::sort(cmds.begin(), cmds.end(), [](auto& a, auto& b) { return a.name < b.name; });
  for (auto& c : cmds) c.setup(*app.add_subcommand(c.name, c.description));
  app.parse_complete_callback([&] {
    if (quiet) log::setLevel(log::Level::Warn);
    if (verbosity == 1) log::setLevel(log::Level::Debug);
    if (verbosity >= 2) log::setLevel(log::Level::Trace);
  });
  try {
    register_builtin_plugins();
    loadExternalPlugins({});
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << std::endl;
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // "filesystem error: status: Too many levels of symbolic links [x]" -> "x: Too many levels of symbolic links"
    std::string paths = e.path1().string();
    if (!e.path2().empty()) paths += " -> " + e.path2().string();
    std::cerr << "error: " << (paths.empty() ? std::string() : paths + ": ") << e.code().message() << std::endl;
    return 1;
  } catch (const std::exception& e) {  // a library's exception (MRPT, OpenCV): its message line, not its backtrace
    std::cerr << "error: " << exceptionSummary(e, 1000) << std::endl;
    return 1;
  }
  return app::exitCode();
}
