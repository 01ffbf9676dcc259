// Study files: parsing, validation and the plan of cells (docs/ablation.md).
#include "dslam/study/study.h"

#include <mrpt/containers/yaml.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <sstream>

#include "dslam/config/pipeline.h"
#include "dslam/config/yaml_loader.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"
#include "dslam/synth/scenario.h"

namespace fs = std::filesystem;
using mrpt::containers::yaml;
using node_t = yaml::node_t;
using dslam::yamlu::At;

namespace dslam::study {

std::string hashHex(const std::string& text) {
  uint64_t h = 1469598103934665603ull;  // FNV-1a, 64 bit
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char b[17];
  std::snprintf(b, sizeof(b), "%016llx", static_cast<unsigned long long>(h));
  return b;
}

std::string Dataset::cacheName() const {
  if (!isScenario()) return "";
  return fs::path(scenario).stem().string() + "-" + hashHex(scenario_key_text);
}

const Variant& Study::variant(const std::string& n) const {
  for (const auto& v : variants)
    if (v.name == n) return v;
  throw ConfigError("study " + name + ": no variant '" + n + "'");
}

const Dataset& Study::dataset(const std::string& n) const {
  for (const auto& d : datasets)
    if (d.name == n) return d;
  throw ConfigError("study " + name + ": no dataset '" + n + "'");
}

namespace {

const std::regex kName("^[A-Za-z0-9_-]+$");

/** The study's typed reader: "file:line: 'key.path': message" errors. */
class Reader : public yamlu::TypedReader {
 public:
  explicit Reader(const config::LoadedYaml& ly)
      : TypedReader([&ly](const std::string& p) { return ly.fileFor(p); }), ly_(ly) {}
  /** Folder that relative paths written at `key_path` resolve against. */
  std::string dirFor(const At& at, const std::string& base_dir) const {
    const std::string f = ly_.fileFor(at.path);
    return f == ly_.file ? base_dir : fs::path(f).parent_path().string();
  }
  std::string location(const At& at) const {
    return ly_.fileFor(at.path) + (at.n ? ":" + std::to_string(at.n->marks.line + 1) : "");
  }
  void checkName(const At& at, const std::string& name, const char* what) const {
    if (!std::regex_match(name, kName))
      fail(at, std::string(what) + " name '" + name + "': use letters, digits, '_' and '-' only (it names cells and folders)");
  }
  /** Map entries in file order, as (name, value). */
  std::vector<std::pair<std::string, At>> entries(const At& m, const char* what) const {
    requireMap(m);
    std::vector<std::pair<std::string, At>> v;
    for (const auto& k : yamlu::keysInOrder(*m.n)) {
      At a{yamlu::findValue(*m.n, k), join(m.path, k)};
      checkName(At{yamlu::findKey(*m.n, k), a.path}, k, what);
      v.push_back({k, a});
    }
    return v;
  }
  std::vector<std::string> names(const At& v) const {
    std::vector<std::string> out;
    for (const auto& e : list(v)) out.push_back(str(e));
    return out;
  }

 private:
  const config::LoadedYaml& ly_;
};

struct Parser {
  Parser(const config::LoadedYaml& l, std::string dir) : ly(l), base_dir(std::move(dir)) {}
  const config::LoadedYaml& ly;
  std::string base_dir;
  Reader R{ly};
  Study st;
  std::map<std::string, std::string> base_dirs;  ///< base name -> folder of its pipeline file

  void header(const At& root) {
    R.checkKeys(root, {"name", "description", "repeats", "seeds", "mode", "evaluation", "bases", "variants", "datasets"});
    st.name = R.str(root, "name", ly.file.empty() ? "study" : fs::path(ly.file).stem().string());
    R.checkName(R.child(root, "name").value_or(root), st.name, "study");
    st.description = R.str(root, "description", "");
    st.repeats = static_cast<int>(R.integer(root, "repeats", 1));
    if (st.repeats < 1 || st.repeats > 1000) R.fail(*R.child(root, "repeats"), "must be between 1 and 1000");
    if (auto s = R.child(root, "seeds")) st.seeds = seedList(*s);
    st.mode = R.oneOf(root, "mode", "", {"", "sequential", "parallel"}, "pipeline mode of every cell");
    if (auto e = R.child(root, "evaluation")) {
      R.checkKeys(*e, {"align", "max_dt", "rpe_delta", "rpe_unit"});
      st.evaluation.align = eval::alignFromString(R.oneOf(*e, "align", "se3", {"se3", "sim3", "none"}, "ATE alignment"));
      st.evaluation.max_dt = R.positive(*e, "max_dt", 0.02);
      st.evaluation.rpe_delta = R.positive(*e, "rpe_delta", 1);
      st.evaluation.rpe_unit =
          eval::deltaUnitFromString(R.oneOf(*e, "rpe_unit", "s", {"frames", "s", "m"}, "RPE delta unit"));
    }
  }

  /** A `seeds:` list: integers >= 0, none twice. */
  std::vector<uint64_t> seedList(const At& at) {
    std::vector<uint64_t> out;
    for (const auto& e : R.list(at)) {
      const long long v = R.integer(e);
      if (v < 0) R.fail(e, "seeds are integers >= 0");
      if (std::find(out.begin(), out.end(), static_cast<uint64_t>(v)) != out.end())
        R.fail(e, "seed " + std::to_string(v) + " is listed twice");
      out.push_back(static_cast<uint64_t>(v));
    }
    return out;
  }

  std::string existingFile(const At& at, const std::string& rel, const char* what) {
    const std::string p = resolvePath(rel, R.dirFor(at, base_dir));
    if (!fileExists(p)) R.fail(at, std::string(what) + " not found: " + p);
    return fs::absolute(p).lexically_normal().string();
  }

  void bases(const At& root) {
    const At b = R.required(root, "bases");
    for (const auto& [name, at] : R.entries(b, "base")) {
      Variant v;
      v.name = v.base = name;
      v.is_base = true;
      v.where = R.location(at);
      At file_at = at;
      if (at.n->isMap()) {
        R.checkKeys(at, {"pipeline", "compare_to", "datasets", "description"});
        file_at = R.required(at, "pipeline");
        v.reference = R.str(at, "compare_to", "");
        if (auto d = R.child(at, "datasets")) v.datasets = R.names(*d);
      }
      v.pipeline = existingFile(file_at, R.str(file_at), "pipeline file");
      try {
        v.config_yaml = config::loadPipeline(v.pipeline).toYaml();
      } catch (const Error& e) {
        R.fail(file_at, std::string("base pipeline is invalid: ") + e.what());
      }
      base_dirs[name] = fs::path(v.pipeline).parent_path().string();
      st.variants.push_back(std::move(v));
    }
  }

  void variants(const At& root) {
    const auto vs = R.child(root, "variants");
    if (!vs) return;
    for (const auto& [name, at] : R.entries(*vs, "variant")) {
      for (const auto& b : st.variants)
        if (b.name == name)
          R.fail(at, b.is_base ? "variant '" + name + "' has the name of a base (names must be unique)"
                               : "variant '" + name + "' is also made by the seeds of variant '" + b.base_of_seed + "'");
      R.checkKeys(at, {"base", "overlay", "datasets", "compare_to", "description", "seeds"});
      Variant v;
      v.name = name;
      v.is_base = false;
      v.where = R.location(at);
      const At base_at = R.required(at, "base");
      v.base = R.str(base_at);
      const Variant* base = nullptr;
      std::vector<std::string> base_names;
      for (const auto& b : st.variants)
        if (b.is_base) {
          base_names.push_back(b.name);
          if (b.name == v.base) base = &b;
        }
      if (!base)
        R.fail(base_at, "unknown base '" + v.base + "'" + yamlu::didYouMean(v.base, base_names) +
                            " (bases: " + yamlu::join(base_names) + ")");
      v.pipeline = base->pipeline;
      v.reference = R.str(at, "compare_to", v.base);
      v.datasets = base->datasets;
      if (auto d = R.child(at, "datasets")) v.datasets = R.names(*d);
      if (auto ov = R.child(at, "overlay")) v.overlay = overlay(*ov);
      const std::string base_yaml = base->config_yaml;  // (st.variants grows below)
      v.config_yaml = applyOverlay(base_yaml, base_dirs[v.base], v.overlay);
      // seeds: [k, ...]: one more variant <name>_seed<k> per seed, the same
      // overlay and then pipeline.seed k.
      std::vector<uint64_t> seeds;
      const auto seeds_at = R.child(at, "seeds");
      if (seeds_at) seeds = seedList(*seeds_at);
      const Variant plain = v;
      st.variants.push_back(std::move(v));
      for (uint64_t seed : seeds) {
        Variant w = plain;
        w.name = plain.name + "_seed" + std::to_string(seed);
        w.base_of_seed = plain.name;
        for (const auto& b : st.variants)
          if (b.name == w.name) R.fail(*seeds_at, "variant '" + w.name + "' (seed " + std::to_string(seed) + ") already exists");
        OverlayOp op;
        op.kind = OverlayOp::Kind::Set;
        op.file = ly.fileFor(seeds_at->path);
        op.line = seeds_at->n->marks.line + 1;
        op.key_path = seeds_at->path;
        op.node = std::make_shared<yaml>(yaml::FromText("pipeline.seed: " + std::to_string(seed)));
        w.overlay.push_back(std::move(op));
        w.config_yaml = applyOverlay(base_yaml, base_dirs[w.base], w.overlay);
        st.variants.push_back(std::move(w));
      }
    }
  }

  std::vector<OverlayOp> overlay(const At& ov) {
    std::vector<OverlayOp> ops;
    const auto items = R.list(ov);
    for (size_t i = 0; i < items.size(); i++) {
      const At& e = items[i];
      OverlayOp op;
      op.file = ly.fileFor(e.path);
      op.line = e.n->marks.line + 1;
      op.key_path = e.path;
      if (!e.n->isMap() || e.n->asMap().size() != 1)
        R.fail(e, "each overlay operation is a map with one key: set, add, remove or replace");
      const std::string k = yamlu::scalarText(e.n->asMap().begin()->first).value_or("");
      if (k == "set") op.kind = OverlayOp::Kind::Set;
      else if (k == "add") op.kind = OverlayOp::Kind::Add;
      else if (k == "remove") op.kind = OverlayOp::Kind::Remove;
      else if (k == "replace") op.kind = OverlayOp::Kind::Replace;
      else
        R.fail(At{&e.n->asMap().begin()->first, e.path + "." + k},
               "unknown overlay operation '" + k + "'" + yamlu::didYouMean(k, {"set", "add", "remove", "replace"}) +
                   " (valid: set, add, remove, replace)");
      op.key_path += "." + k;
      auto y = std::make_shared<yaml>();
      y->node() = e.n->asMap().begin()->second;
      op.node = y;
      ops.push_back(std::move(op));
    }
    return ops;
  }

  void resolution(const At& at, Dataset& d) {
    if (at.n->isSequence()) {
      const auto v = R.numbers(at, 2, 2);
      d.width = static_cast<int>(v[0]);
      d.height = static_cast<int>(v[1]);
    } else {
      static const std::regex re(R"(^(\d+)[xX](\d+)$)");
      std::smatch m;
      const std::string s = R.str(at);
      if (!std::regex_match(s, m, re)) R.fail(at, "expected WxH (e.g. 320x240) or [W, H], got '" + s + "'");
      d.width = std::stoi(m[1].str());
      d.height = std::stoi(m[2].str());
    }
    if (d.width < 16 || d.height < 16 || d.width > 8192 || d.height > 8192) R.fail(at, "image size out of range");
  }

  void scenario(const At& at, Dataset& d) {
    synth::ScenarioOverrides ov;
    ov.frames = d.frames;
    ov.width = d.width;
    ov.height = d.height;
    ov.seed = d.seed;
    ov.noise = d.noise;
    try {
      (void)synth::loadScenario(d.scenario, ov);  // validates file and overrides
    } catch (const Error& e) {
      R.fail(at, std::string("scenario is invalid: ") + e.what());
    }
    const config::LoadedYaml sly = config::loadYamlFile(d.scenario);
    std::ostringstream k;
    k << yamlu::toYamlText(*sly.root) << "\n# overrides: frames=" << d.frames << " size=" << d.width << "x" << d.height
      << " seed=" << (d.seed ? std::to_string(*d.seed) : "-") << " noise=" << (d.noise ? (*d.noise ? "1" : "0") : "-")
      << " right=" << d.right << " labels=" << d.labels << "\n";
    d.scenario_key_text = k.str();
  }

  void datasets(const At& root) {
    const At ds = R.required(root, "datasets");
    for (const auto& [name, at] : R.entries(ds, "dataset")) {
      Dataset d;
      d.name = name;
      d.where = R.location(at);
      At src = at;
      bool is_scenario = false;
      if (auto text = yamlu::scalarText(*at.n)) {
        is_scenario = fs::path(*text).extension() == ".yaml" || fs::path(*text).extension() == ".yml";
      } else {
        R.checkKeys(at, {"path", "scenario", "frames", "resolution", "seed", "noise", "right", "labels", "max_frames",
                         "description"});
        const auto p = R.child(at, "path");
        const auto s = R.child(at, "scenario");
        if (p && s) R.fail(at, "give 'path' (a dataset folder) or 'scenario' (a scenario file), not both");
        if (!p && !s) R.fail(at, "missing 'path' (a dataset folder or rawlog) or 'scenario' (a scenario file)");
        is_scenario = s.has_value();
        src = p ? *p : *s;
        d.max_frames = static_cast<int>(R.integer(at, "max_frames", -1));
        if (const auto mf = R.child(at, "max_frames"); mf && d.max_frames < 1)
          R.fail(*mf, "must be at least 1 (leave it out for every frame)");
        if (is_scenario) {
          d.frames = static_cast<int>(R.integer(at, "frames", 0));
          if (d.frames < 0) R.fail(*R.child(at, "frames"), "must be > 0");
          if (auto r = R.child(at, "resolution")) resolution(*r, d);
          if (auto sd = R.child(at, "seed")) {
            const long long v = R.integer(*sd);
            if (v < 0) R.fail(*sd, "must be >= 0");
            d.seed = static_cast<uint64_t>(v);
          }
          if (R.child(at, "noise")) d.noise = R.boolean(at, "noise", true);
          d.right = R.boolean(at, "right", true);
          d.labels = R.boolean(at, "labels", true);
        } else {
          for (const char* k : {"frames", "resolution", "seed", "noise", "right", "labels"})
            if (auto c = R.child(at, k)) R.fail(*c, std::string("'") + k + "' applies to scenario datasets only");
        }
      }
      const std::string rel = R.str(src);
      const std::string p = resolvePath(rel, R.dirFor(src, base_dir));
      if (is_scenario) {
        if (!fileExists(p)) R.fail(src, "scenario file not found: " + p);
        d.scenario = fs::absolute(p).lexically_normal().string();
        scenario(src, d);
      } else {
        std::error_code ec;
        if (!fs::exists(p, ec)) R.fail(src, "dataset not found: " + p);
        if (config::detectDatasetType(p).empty())
          R.fail(src, "cannot tell the dataset type of " + p +
                          " (a TUM/Bonn folder with rgb.txt, KITTI with calib.txt, EuRoC with mav0/, or a .rawlog)");
        d.path = fs::absolute(p).lexically_normal().string();
      }
      st.datasets.push_back(std::move(d));
    }
    if (st.datasets.empty()) R.fail(ds, "no datasets");
  }

  /** Dataset filters and references name existing datasets / variants. */
  void crossChecks(const At& root) {
    std::vector<std::string> dnames, vnames;
    for (const auto& d : st.datasets) dnames.push_back(d.name);
    for (const auto& v : st.variants) vnames.push_back(v.name);
    for (const auto& v : st.variants) {
      const std::string section = v.is_base ? "bases" : "variants";
      const At at{yamlu::findValue(*R.child(root, section)->n, v.name), section + "." + v.name};
      for (const auto& d : v.datasets)
        if (std::find(dnames.begin(), dnames.end(), d) == dnames.end())
          R.fail(R.child(at, "datasets").value_or(at), "unknown dataset '" + d + "'" + yamlu::didYouMean(d, dnames) +
                                                           " (datasets: " + yamlu::join(dnames) + ")");
      if (!v.reference.empty() && std::find(vnames.begin(), vnames.end(), v.reference) == vnames.end())
        R.fail(R.child(at, "compare_to").value_or(at), "unknown variant '" + v.reference + "'" +
                                                           yamlu::didYouMean(v.reference, vnames) +
                                                           " (variants: " + yamlu::join(vnames) + ")");
      if (v.reference == v.name) R.fail(R.child(at, "compare_to").value_or(at), "a variant cannot compare to itself");
    }
  }

  Study parse() {
    const At root{&ly.root->node(), ""};
    R.requireMap(root);
    st.file = ly.file;
    st.dir = base_dir;
    header(root);
    datasets(root);
    bases(root);
    variants(root);
    crossChecks(root);
    return std::move(st);
  }
};

/** The cell's pipeline: the variant's with its name, seed and mode (the same
 *  text for every repeat). */
std::string cellConfig(const Study& st, const Variant& v, const Dataset& d, const std::optional<uint64_t>& seed) {
  config::PipelineConfig pc = config::loadPipelineText(v.config_yaml, fs::path(v.pipeline).parent_path().string());
  pc.name = v.name;
  if (seed) pc.seed = *seed;
  if (st.mode == "parallel") pc.mode = config::Mode::Parallel;
  if (st.mode == "sequential") pc.mode = config::Mode::Sequential;
  std::ostringstream o;
  o << "# dslam ablate: study " << st.name << ", variant " << v.name;
  if (!v.is_base) o << " (overlay on base " << v.base << ")";
  o << ", dataset " << d.name << "\n# base pipeline: " << v.pipeline << "\n";
  pc.file.clear();  // not "<text>": the source is named above
  o << pc.toYaml();
  return o.str();
}

}  // namespace

Study parseStudy(const std::string& yaml_text, const std::string& pseudo_file, const std::string& base_dir) {
  const config::LoadedYaml ly = config::loadYamlText(yaml_text, pseudo_file, base_dir);
  Parser p{ly, base_dir};
  Study st = p.parse();
  st.file = "";
  return st;
}

Study loadStudy(const std::string& file) {
  const config::LoadedYaml ly = config::loadYamlFile(file);
  Parser p{ly, fs::path(file).parent_path().string()};
  Study st = p.parse();
  st.file = file;
  return st;
}

std::vector<Cell> Study::plan() const {
  std::vector<Cell> cells;
  std::vector<std::optional<uint64_t>> sd;
  for (auto s : seeds) sd.push_back(s);
  if (sd.empty()) sd.push_back(std::nullopt);
  for (const auto& v : variants)
    for (const auto& d : datasets) {
      if (!v.datasets.empty() && std::find(v.datasets.begin(), v.datasets.end(), d.name) == v.datasets.end()) continue;
      for (const auto& s : sd)
        for (int r = 0; r < repeats; r++) {
          Cell c;
          c.index = cells.size();
          c.variant = v.name;
          c.base = v.base;
          c.dataset = d.name;
          c.seed = s;
          c.repeat = r;
          c.id = v.name + "." + d.name + (s ? ".s" + std::to_string(*s) : std::string()) + ".r" + std::to_string(r);
          c.config_yaml = cellConfig(*this, v, d, s);
          std::ostringstream h;
          h << c.config_yaml << "\n--dataset " << (d.isScenario() ? d.scenario_key_text : d.path)
            << "\n--max-frames " << d.max_frames << "\n--eval " << eval::toString(evaluation.align) << " "
            << evaluation.max_dt << " " << evaluation.rpe_delta << " " << eval::toString(evaluation.rpe_unit);
          c.inputs_hash = hashHex(h.str());
          cells.push_back(std::move(c));
        }
    }
  return cells;
}

}  // namespace dslam::study
