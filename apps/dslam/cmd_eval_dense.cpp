// `dslam eval dense MAP GT_SCENE`: a dense map written by `dslam run`
// (outputs.dense_map) against the static geometry of the synthetic scene it
// was run on: ghost rate, accuracy, completeness (docs/dense_map.md).
#include <filesystem>
#include <iostream>

#include "command.h"
#include "dslam/core/log.h"
#include "dslam/dense/dense_eval.h"

namespace {
/** Keyframe positions further than this from the scene's camera path after
 *  alignment (RMS, metres) are warned about. */
constexpr double kAlignmentWarn = 0.25;
}  // namespace

void setupEvalDense(CLI::App& eval) {
  struct Opt {
    std::string map, scene, scenario, metadata;
    bool json = false;
    int frame_step = 1;
  };
  static Opt o;
  auto* c = eval.add_subcommand(
      "dense", "Dense map (map.bt) against a synthetic scene's static geometry: ghost rate, accuracy, completeness");
  c->add_option("map", o.map, "OctoMap written by dslam run (map.bt, dense.json beside it) or its run folder")
      ->required();
  c->add_option("gt_scene", o.scene, "the dslam synth folder the run used (objects.json)")->required();
  c->add_option("--scenario", o.scenario, "scenario file (default: the one objects.json names)");
  c->add_option("--metadata", o.metadata, "dense.json of the map (default: beside it)");
  c->add_option("--frame-step", o.frame_step, "frames sampled for the movers' swept volume")
      ->capture_default_str()
      ->check(dslam::app::kPositive);
  c->add_flag("--json", o.json, "print one JSON object instead of text");
  c->callback([] {
    namespace fs = std::filesystem;
    const std::string bt = fs::is_directory(o.map) ? (fs::path(o.map) / "map.bt").string() : o.map;
    const dslam::dense::DenseMapFile m = dslam::dense::loadDenseMap(bt, o.metadata);
    const dslam::synth::Scenario s = dslam::dense::sceneScenario(o.scene, o.scenario);
    dslam::dense::DenseEvalOptions eo;
    eo.frame_step = o.frame_step;
    const auto r = dslam::dense::evaluateDense(m, s, eo);
    if (r.alignment_rmse > kAlignmentWarn)
      DSLAM_LOG(Warn, bt << ": after alignment the map's keyframes lie " << r.alignment_rmse
                         << " m (RMS) from the scene's camera path: a map of another scene, or of a run that lost "
                            "its way; the scores below are not meaningful");
    if (o.json) {
      std::cout << dslam::dense::toJson(r) << std::endl;
    } else {
      std::cout << "dense map: " << bt << "\nscene:     " << o.scene << " (scenario " << s.name << ")\n"
                << dslam::dense::toText(r) << std::flush;
    }
  });
}
