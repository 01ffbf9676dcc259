// `dslam config check FILE` and `dslam config show FILE`.
#include <iostream>

#include "command.h"
#include "dslam/config/pipeline.h"

namespace {

void setup(CLI::App& sub) {
  sub.require_subcommand(1);
  static std::string file;
  auto* check = sub.add_subcommand("check", "Validate a pipeline file without running it");
  check->add_option("file", file, "pipeline YAML")->required();
  check->callback([] {
    const auto pc = dslam::config::loadPipeline(file);
    std::cout << file << ": OK (pipeline '" << pc.name << "', " << pc.modules.size() << " modules"
              << (pc.dataset ? ", dataset " + pc.dataset->type : std::string()) << ")\n";
  });
  auto* show = sub.add_subcommand("show", "Print the fully resolved pipeline with every default");
  show->add_option("file", file, "pipeline YAML")->required();
  show->callback([] { std::cout << dslam::config::loadPipeline(file).toYaml(); });
}

}  // namespace

DSLAM_COMMAND(config, "Check or show a pipeline configuration", setup);
