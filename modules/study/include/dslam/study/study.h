#pragma once
/** \file study.h
 *  Ablation studies (`dslam ablate`, docs/ablation.md): a study file names
 *  base pipelines, variants (overlays on a base), datasets (folders or
 *  scenarios rendered on demand), repeats and seeds. loadStudy() validates
 *  the whole file and resolves every variant's pipeline before anything runs;
 *  plan() lists the cells (variant x dataset x seed x repeat), each runnable
 *  on its own (cluster array jobs).
 *
 *      name: afc_ablation
 *      repeats: 1
 *      bases:
 *        crowd_slam: ../pipelines/synthetic/crowd_slam.yaml
 *      variants:
 *        no_afc: {base: crowd_slam, overlay: [{remove: feature_count}]}
 *      datasets:
 *        close_person: {scenario: ../scenarios/close_person.yaml, frames: 300}
 *        kitti: {path: ${DSLAM_SHARED_DIR}/data/kitti-stereo-51} */
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dslam/eval/eval.h"
#include "mrpt/containers/yaml_frwd.h"

namespace dslam::study {

/** One overlay operation (docs/ablation.md, "Overlays"). */
struct OverlayOp {
  enum class Kind { Set, Add, Remove, Replace };
  Kind kind = Kind::Set;
  /** The operation's YAML node as written in the study (the value of
   *  `set:`, `add:`, `remove:` or `replace:`), kept as a tree so that its
   *  values keep their type and their line. */
  std::shared_ptr<const mrpt::containers::yaml> node;
  std::string file;      ///< study file (for messages and relative paths)
  int line = -1;         ///< 1-based line of the operation
  std::string key_path;  ///< e.g. "variants.no_afc.overlay[0]"
  std::string where() const;  ///< "file:line: 'key_path'"
};
const char* toString(OverlayOp::Kind k);

/** Parses an overlay list (the value of a variant's `overlay:` key) from
 *  YAML text; errors name `pseudo_file` and the line. For tests and
 *  programs that build variants themselves. */
std::vector<OverlayOp> parseOverlay(const std::string& yaml_text, const std::string& pseudo_file = "<overlay>");

/** Applies `ops` in order to a pipeline given as YAML text (typically
 *  PipelineConfig::toYaml() of a base: every default filled in) and returns
 *  the resolved text of the result (PipelineConfig::toYaml()). Relative
 *  paths of the base resolve against `base_dir`, relative path parameters
 *  written in an operation against the study file's folder. Every problem
 *  (missing module or parameter, invalid result) is a ConfigError naming the
 *  operation's file, line and key. Plugins must be registered. */
std::string applyOverlay(const std::string& pipeline_yaml, const std::string& base_dir,
                         const std::vector<OverlayOp>& ops);

/** A pipeline that runs in the study: a base (no overlay) or a variant. */
struct Variant {
  std::string name;
  std::string base;         ///< base name; == name for a base
  bool is_base = true;
  std::string pipeline;     ///< the base's pipeline file (absolute)
  std::vector<OverlayOp> overlay;
  /** Variant whose median ATE is the denominator of this one's ratio: its
   *  base for a variant, `compare_to` for a base ("" = none). */
  std::string reference;
  std::vector<std::string> datasets;  ///< datasets it runs on (all if the file lists none)
  std::string config_yaml;  ///< resolved pipeline after the overlay (before seed/mode)
  std::string where;        ///< file:line of its entry
  std::string base_of_seed;  ///< made by the `seeds:` of this variant (its name + "_seed<k>"), else ""
};

/** A dataset: an existing folder/rawlog (`path:`) or a scenario rendered on
 *  demand into the scene cache (`scenario:` + overrides). */
struct Dataset {
  std::string name;
  std::string path;      ///< folder or .rawlog (path datasets)
  std::string scenario;  ///< scenario file (scenario datasets)
  int frames = 0;        ///< scenario overrides (0 = the scenario's)
  int width = 0, height = 0;
  std::optional<uint64_t> seed;
  std::optional<bool> noise;
  bool right = true;   ///< render the stereo right image
  bool labels = true;  ///< render boxes/, semantic/, panoptic/
  int max_frames = -1;  ///< `dslam run --max-frames`
  std::string where;
  /** Scenario datasets: the resolved scenario text ($include and ${VAR}
   *  expanded) plus the overrides, which the cache key hashes. */
  std::string scenario_key_text;
  bool isScenario() const { return !scenario.empty(); }
  /** Cache folder name: "<scenario name>-<16 hex digits>" (scenario
   *  datasets); "" for path datasets. */
  std::string cacheName() const;
};

/** How cells are evaluated against the dataset's ground truth. */
struct Evaluation {
  eval::Align align = eval::Align::SE3;
  double max_dt = 0.02;
  double rpe_delta = 1;
  eval::DeltaUnit rpe_unit = eval::DeltaUnit::Seconds;
};

/** One run: a variant on a dataset with a seed, repeat k. */
struct Cell {
  std::string id;      ///< "<variant>.<dataset>[.s<seed>].r<k>" (names are [A-Za-z0-9_-])
  size_t index = 0;    ///< position in plan() (`--cell-index`, `sbatch --array`)
  std::string variant, base, dataset;
  std::optional<uint64_t> seed;  ///< set when the study lists seeds
  int repeat = 0;
  std::string config_yaml;  ///< the cell's pipeline (seed and mode applied)
  /** Hash of everything that determines the cell's result (its pipeline
   *  text, the dataset identity, max_frames): a finished cell whose hash
   *  differs is stale and runs again under --resume. */
  std::string inputs_hash;
};

struct Study {
  std::string file;  ///< study file ("" when parsed from text)
  std::string dir;   ///< its folder
  std::string name, description;
  int repeats = 1;
  std::vector<uint64_t> seeds;  ///< empty: each pipeline's own seed
  std::string mode;             ///< "" (as the pipelines say) | sequential | parallel
  Evaluation evaluation;
  std::vector<Variant> variants;  ///< bases first (file order), then variants
  std::vector<Dataset> datasets;

  const Variant& variant(const std::string& name) const;
  const Dataset& dataset(const std::string& name) const;
  /** Every cell, in a stable order: variants, then datasets, seeds, repeats. */
  std::vector<Cell> plan() const;
};

/** Loads and validates a study file: unknown keys, wrong types, missing
 *  pipelines, overlays naming a missing module or parameter, datasets that
 *  do not exist are ConfigErrors naming the study file, line and key. Every
 *  variant's pipeline is resolved here (plugins must be registered). */
Study loadStudy(const std::string& file);
/** Same from text; relative paths resolve against `base_dir`. */
Study parseStudy(const std::string& yaml_text, const std::string& pseudo_file, const std::string& base_dir);

/** 64-bit FNV-1a as 16 hex digits (cache keys, input hashes). */
std::string hashHex(const std::string& text);

}  // namespace dslam::study
