#include "dslam/config/pipeline.h"

#include <algorithm>

#include <cstdlib>
#include <mrpt/containers/yaml.h>

#include <filesystem>
#include <map>
#include <mutex>
#include <sstream>

#include "dslam/config/camera_yaml.h"
#include "dslam/config/yaml_loader.h"
#include "dslam/core/dataset.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/core/yaml_util.h"

namespace fs = std::filesystem;
using mrpt::containers::yaml;
using node_t = yaml::node_t;

namespace dslam::config {

namespace {
std::mutex g_sec_mtx;
std::vector<SectionInfo>& sectionTable() {
  static std::vector<SectionInfo> t;
  return t;
}
}  // namespace

void registerSection(const std::string& name, std::function<std::vector<ParamSpec>()> specs,
                     const std::string& doc) {
  std::lock_guard<std::mutex> lk(g_sec_mtx);
  for (auto& s : sectionTable())
    if (s.name == name) {
      s.specs = std::move(specs);
      s.doc = doc;
      return;
    }
  sectionTable().push_back({name, doc, std::move(specs)});
}

std::vector<SectionInfo> registeredSections() {
  std::lock_guard<std::mutex> lk(g_sec_mtx);
  return sectionTable();
}

const std::vector<std::string>& moduleKeys() {
  static const std::vector<std::string> k = {"name",  "type",  "params", "inputs",    "enabled",      "every",
                                             "detection", "carry", "hold", "keyframes", "wait_coverage"};
  return k;
}

std::vector<ParamSpec> pipelineParamSpecs() {
  return {
      P_string("name", "", "pipeline name (default: the file name without extension)"),
      P_enum("mode", "sequential", {"sequential", "parallel"},
             "sequential: deterministic, one thread; parallel: detector and mapping in threads"),
      P_int("seed", 42, "seed of every random choice (RANSAC, degradations)", 0),
  };
}

std::vector<ParamSpec> datasetCommonParamSpecs() {
  return {
      P_required("type", ParamType::String, "dataset reader plugin (dslam plugins DatasetSource)"),
      {"params", ParamType::Map, "", "parameters of the reader", {}, false, {}, {}},
      P_enum("on_bad_frame", "fail", {"fail", "skip"},
             "corrupt or missing image: fail with the frame index and path, or log and skip the frame"),
      P_int("start", 0, "first frame index to process", 0),
      P_int("max_frames", -1, "process at most this many frames (-1: all)", -1),
      P_int("stride", 1, "process every N-th frame", 1),
  };
}

std::vector<ParamSpec> outputParamSpecs() {
  return {
      P_string("dir", "", "output folder, relative to the working directory ('' = out/<pipeline name>); `dslam run --out` overrides"),
      P_string("trajectory", "trajectory.txt", "camera trajectory file name ('' = none)"),
      P_enum("trajectory_format", "tum", {"tum", "kitti", "euroc"}, "trajectory file format"),
      P_string("keyframe_trajectory", "keyframes.txt", "keyframe trajectory file name ('' = none)"),
      P_string("timing_csv", "timing.csv", "per-frame per-stage timing CSV ('' = none)"),
      P_string("frames_csv", "frames.csv", "per-frame tracking state, keypoints, usable (non-dynamic) keypoints, tracked map points, ORB feature count ('' = none)"),
      P_string("map", "map.ply", "map points as PLY ('' = none)"),
      P_string("objects", "objects.json",
               "semantic object map: MapObjects with class, centroid, 3D box, belief, active ('' = none; "
               "docs/changing.md)"),
      P_string("objects_ply", "objects.ply", "3D boxes of the current map's objects as PLY faces ('' = none)"),
      P_int("objects_min_points", 5,
            "objects.json and objects.ply leave out objects with fewer map points (local mapping culled the "
            "rest; fragments); `dslam eval objects --min-points` scores higher values from one run with 1 "
            "(docs/results.md section 7)",
            1),
      P_int("objects_min_sightings", 1,
            "objects.json and objects.ply leave out tentative objects: seen by fewer keyframes than this (and of "
            "fewer than objects_confirm_points points). 2: fewer stale and false objects, a few small moved ones "
            "lost; `dslam eval objects --min-sightings` scores it from one run (docs/results.md section 7)",
            1),
      P_int("objects_confirm_points", 0,
            "with objects_min_sightings: objects of this many map points are kept however few keyframes saw them "
            "(0 = no exception)",
            0),
      P_string("resolved_config", "config.resolved.yaml", "fully resolved configuration copy"),
      P_string("events", "events.jsonl", "loop/merge/lost events, one JSON object per line ('' = none)"),
      P_string("atlas", "", "save the atlas to this file at the end ('' = do not save)"),
      P_bool("dense_map", false,
             "dense OctoMap without dynamic objects: map.bt, dense.ply, dense_top.png, dense_side.png, dense.json "
             "(parameters: the dense_map section; docs/dense_map.md)"),
  };
}

namespace {

struct Loader {
  const LoadedYaml& ly;
  std::string base_dir;

  SourceLocation loc(const std::string& key_path, const node_t* n) const {
    return SourceLocation{ly.fileFor(key_path), key_path, n ? n->marks.line + 1 : -1};
  }
  [[noreturn]] void fail(const std::string& key_path, const node_t* n, const std::string& what) const {
    throw ConfigError(loc(key_path, n).str() + ": " + what);
  }
  std::string dirFor(const std::string& key_path) const {
    const std::string f = ly.fileFor(key_path);
    return f == ly.file ? base_dir : fs::path(f).parent_path().string();
  }
  Params section(const std::vector<ParamSpec>& specs, const node_t* n, const std::string& key_path) const {
    yaml y = n ? yaml(*n) : yaml();
    return Params::resolve(specs, n ? &y : nullptr, loc(key_path, n), dirFor(key_path));
  }
};

}  // namespace

namespace {

/** Every top-level key must be a known section. */
void checkSections(const Loader& L, const node_t& root) {
  std::vector<std::string> valid = {"pipeline", "dataset", "camera", "modules", "outputs", "plugin_dirs"};
  for (const auto& s : registeredSections()) valid.push_back(s.name);
  for (const auto& kv : root.asMap()) {
    const std::string k = yamlu::scalarText(kv.first).value_or("");
    bool ok = false;
    for (const auto& v : valid) ok |= (v == k);
    if (!ok) L.fail(k, &kv.first, "unknown section" + yamlu::didYouMean(k, valid) + " (valid: " + yamlu::join(valid) + ")");
  }
}

DatasetConfig loadDataset(const Loader& L, const node_t& d) {
  Params dp = L.section(datasetCommonParamSpecs(), &d, "dataset");
  DatasetConfig dc;
  dc.type = dp.getString("type");
  dc.on_bad_frame = dp.getString("on_bad_frame") == "skip" ? OnBadFrame::Skip : OnBadFrame::Fail;
  dc.start = static_cast<int>(dp.getInt("start"));
  dc.max_frames = static_cast<int>(dp.getInt("max_frames"));
  dc.stride = static_cast<int>(dp.getInt("stride"));
  std::shared_ptr<Plugin> reader;
  try {
    reader = createPlugin(dc.type, CLASS_ID(DatasetSource));
  } catch (const ConfigError& e) {
    L.fail("dataset.type", yamlu::findValue(d, "type"), e.what());
  }
  dc.params = L.section(reader->paramSpecs(), yamlu::findValue(d, "params"), "dataset.params");
  return dc;
}

/** Fails unless modules[i] (`mc`) is a detector: `key` applies to detectors only. */
void requireDetector(const Loader& L, const node_t& v, const std::string& kp, const ModuleConfig& mc,
                     const std::string& key) {
  if (mc.interface_name != std::string("Detector"))
    L.fail(kp + "." + key, &v, "'" + key + "' applies to detectors only ('" + mc.type + "' is a " + mc.interface_name + ")");
}

/** A detector-only integer key of modules[i] (every, hold), >= `min`. */
int loadDetectorInt(const Loader& L, const node_t& ev, const std::string& kp, const ModuleConfig& mc,
                    const std::string& key, long min, const std::string& meaning) {
  const auto t = yamlu::scalarText(ev).value_or("");
  char* end = nullptr;
  const long n = std::strtol(t.c_str(), &end, 10);
  if (t.empty() || *end != '\0' || n < min || n > 1000000)
    L.fail(kp + "." + key, &ev,
           "expected an integer >= " + std::to_string(min) + " (" + meaning + "), got " + yamlu::describe(ev));
  requireDetector(L, ev, kp, mc, key);
  return static_cast<int>(n);
}

/** A detector-only fraction key of modules[i] (wait_coverage), in [0, 1]. */
double loadDetectorFraction(const Loader& L, const node_t& v, const std::string& kp, const ModuleConfig& mc,
                            const std::string& key, const std::string& meaning) {
  const auto x = yamlu::parseDouble(yamlu::scalarText(v).value_or(""));
  if (!x || !(*x >= 0.0 && *x <= 1.0))
    L.fail(kp + "." + key, &v, "expected a number in [0, 1] (" + meaning + "), got " + yamlu::describe(v));
  requireDetector(L, v, kp, mc, key);
  return *x;
}

/** A detector-only key of modules[i] with one of `values`. */
std::string loadDetectorChoice(const Loader& L, const node_t& v, const std::string& kp, const ModuleConfig& mc,
                               const std::string& key, const std::vector<std::string>& values) {
  const auto t = yamlu::scalarText(v).value_or("");
  if (std::find(values.begin(), values.end(), t) == values.end())
    L.fail(kp + "." + key, &v,
           "expected " + yamlu::join(values, " | ") + yamlu::didYouMean(t, values) + ", got " + yamlu::describe(v));
  requireDetector(L, v, kp, mc, key);
  return t;
}

/** One entry of `modules:` (key path `kp`), validated against its plug-in. */
ModuleConfig loadModule(const Loader& L, const node_t& e, const std::string& kp) {
  const std::vector<std::string>& mkeys = moduleKeys();
  if (!e.isMap()) L.fail(kp, &e, "expected a map {name, type, params, inputs}");
  for (const auto& kv : e.asMap()) {
    const std::string k = yamlu::scalarText(kv.first).value_or("");
    bool ok = false;
    for (const auto& v : mkeys) ok |= (v == k);
    if (!ok) L.fail(kp + "." + k, &kv.first, "unknown key" + yamlu::didYouMean(k, mkeys) + " (valid: " + yamlu::join(mkeys) + ")");
  }
  ModuleConfig mc;
  mc.where = L.loc(kp, &e);
  auto req = [&](const char* k) {
    const node_t* v = yamlu::findValue(e, k);
    auto t = v ? yamlu::scalarText(*v) : std::nullopt;
    if (!t || t->empty()) L.fail(kp + "." + k, v ? v : &e, std::string("missing required key '") + k + "'");
    return *t;
  };
  mc.type = req("type");
  mc.name = yamlu::findValue(e, "name") ? req("name") : mc.type;
  if (const node_t* en = yamlu::findValue(e, "enabled")) {
    auto b = yamlu::parseBool(yamlu::scalarText(*en).value_or(""));
    if (!b) L.fail(kp + ".enabled", en, "expected bool (true/false), got " + yamlu::describe(*en));
    mc.enabled = *b;
  }
  std::shared_ptr<Plugin> plugin;
  try {
    plugin = createPlugin(mc.type, CLASS_ID(Plugin));
  } catch (const ConfigError& e2) {
    L.fail(kp + ".type", yamlu::findValue(e, "type"), e2.what());
  }
  mc.interface_name = plugin->interfaceName();
  if (mc.interface_name == std::string("DatasetSource"))
    L.fail(kp + ".type", yamlu::findValue(e, "type"), "dataset readers go in the 'dataset:' section, not in modules");
  mc.params = L.section(plugin->paramSpecs(), yamlu::findValue(e, "params"), kp + ".params");
  if (const node_t* ev = yamlu::findValue(e, "every"))
    mc.every = loadDetectorInt(L, *ev, kp, mc, "every", 1, "run the detector on every N-th frame");
  if (const node_t* hv = yamlu::findValue(e, "hold"))
    mc.hold = loadDetectorInt(L, *hv, kp, mc, "hold", 0, "frames a box the detector stops reporting is kept");
  if (const node_t* dm = yamlu::findValue(e, "detection"))
    mc.detection = loadDetectorChoice(L, *dm, kp, mc, "detection", {"auto", "sync", "async"});
  if (const node_t* cm = yamlu::findValue(e, "carry")) mc.carry = loadDetectorChoice(L, *cm, kp, mc, "carry", {"flow", "none"});
  if (const node_t* km = yamlu::findValue(e, "keyframes"))
    mc.keyframes = loadDetectorChoice(L, *km, kp, mc, "keyframes", {"redetect", "carried"});
  if (const node_t* wc = yamlu::findValue(e, "wait_coverage"))
    mc.wait_coverage = loadDetectorFraction(L, *wc, kp, mc, "wait_coverage",
                                            "image fraction of carried boxes above which a frame waits; 0 = never");
  if (const node_t* in = yamlu::findValue(e, "inputs")) {
    if (!in->isSequence()) L.fail(kp + ".inputs", in, "expected a list of module names");
    for (const auto& x : in->asSequence()) mc.inputs.push_back(yamlu::scalarText(x).value_or(""));
  }
  return mc;
}

/** Every `inputs:` entry must name another module. */
void checkModuleInputs(const std::vector<ModuleConfig>& modules) {
  for (size_t a = 0; a < modules.size(); a++)
    for (const auto& in : modules[a].inputs) {
      bool found = false;
      std::vector<std::string> names;
      for (size_t b = 0; b < modules.size(); b++) {
        names.push_back(modules[b].name);
        found |= (b != a && modules[b].name == in);
      }
      if (!found && in == modules[a].name)
        throw ConfigError(modules[a].where.str() + ".inputs: module '" + in + "' lists itself as its input");
      if (!found)
        throw ConfigError(modules[a].where.str() + ".inputs: unknown module '" + in + "'" +
                          yamlu::didYouMean(in, names) + " (modules: " + yamlu::join(names) + ")");
    }
}

std::vector<ModuleConfig> loadModules(const Loader& L, const node_t& root, const node_t& m) {
  if (!m.isSequence() && !m.isNullNode())
    L.fail("modules", yamlu::findKey(root, "modules"), "expected a list of {name, type, params, inputs}");
  std::vector<ModuleConfig> modules;
  size_t i = 0;
  if (m.isSequence())
    for (const auto& e : m.asSequence()) {
      const std::string kp = "modules[" + std::to_string(i++) + "]";
      ModuleConfig mc = loadModule(L, e, kp);
      for (const auto& other : modules)
        if (other.name == mc.name) L.fail(kp + ".name", yamlu::findValue(e, "name"), "duplicate module name '" + mc.name + "'");
      modules.push_back(std::move(mc));
    }
  checkModuleInputs(modules);
  return modules;
}

}  // namespace

static PipelineConfig loadFrom(const LoadedYaml& ly, const std::string& base_dir) {
  Loader L{ly, base_dir};
  PipelineConfig pc;
  pc.file = ly.file;
  pc.dir = base_dir;
  const node_t& root = ly.root->node();
  if (!root.isMap()) L.fail("", &root, "a pipeline file must be a YAML map with sections (pipeline, dataset, camera, modules, outputs)");
  checkSections(L, root);

  // plugin_dirs first: external plugins may provide the types used below.
  if (const node_t* pd = yamlu::findValue(root, "plugin_dirs")) {
    if (!pd->isSequence()) L.fail("plugin_dirs", yamlu::findKey(root, "plugin_dirs"), "expected a list of folders");
    for (const auto& e : pd->asSequence())
      pc.plugin_dirs.push_back(resolvePath(yamlu::scalarText(e).value_or(""), L.dirFor("plugin_dirs")));
  }
  loadExternalPlugins(pc.plugin_dirs);

  Params pp = L.section(pipelineParamSpecs(), yamlu::findValue(root, "pipeline"), "pipeline");
  pc.name = pp.getString("name");
  if (pc.name == "." || pc.name == ".." ||
      std::any_of(pc.name.begin(), pc.name.end(), [](char ch) { return ch == '/' || ch == '\\' || uint8_t(ch) < 32; }))
    L.fail("pipeline.name", yamlu::findValue(*yamlu::findValue(root, "pipeline"), "name"),
           "'" + pc.name + "' cannot name the default output folder out/<name>: no '/', '\\', control characters, "
           "'.' or '..'");
  if (pc.name.empty()) pc.name = ly.file.empty() ? "pipeline" : fs::path(ly.file).stem().string();
  pc.mode = pp.getString("mode") == "parallel" ? Mode::Parallel : Mode::Sequential;
  pc.seed = static_cast<uint64_t>(pp.getInt("seed"));

  if (const node_t* d = yamlu::findValue(root, "dataset")) pc.dataset = loadDataset(L, *d);
  if (const node_t* c = yamlu::findValue(root, "camera")) {
    if (!c->isNullNode()) {
      Params cp = L.section(cameraParamSpecs(), c, "camera");
      pc.camera = cameraFromParams(cp);
    }
  }
  for (const auto& s : registeredSections())
    pc.sections[s.name] = L.section(s.specs(), yamlu::findValue(root, s.name), s.name);
  if (const node_t* m = yamlu::findValue(root, "modules")) pc.modules = loadModules(L, root, *m);
  pc.outputs = L.section(outputParamSpecs(), yamlu::findValue(root, "outputs"), "outputs");
  return pc;
}

PipelineConfig loadPipeline(const std::string& file) {
  LoadedYaml ly = loadYamlFile(file);
  return loadFrom(ly, fs::path(file).parent_path().string());
}

PipelineConfig loadPipelineText(const std::string& text, const std::string& base_dir) {
  LoadedYaml ly = loadYamlText(text, "<text>", base_dir);
  return loadFrom(ly, base_dir);
}

std::vector<const ModuleConfig*> PipelineConfig::modulesOf(const std::string& interface_name) const {
  std::vector<const ModuleConfig*> out;
  for (const auto& m : modules)
    if (m.enabled && m.interface_name == interface_name) out.push_back(&m);
  return out;
}

static std::string indent(const std::string& text, int n) {
  std::istringstream in(text);
  std::string line, out, pad(n, ' ');
  while (std::getline(in, line))
    if (!line.empty()) out += pad + line + "\n";
  return out;
}

static std::string paramsBlock(const Params& p, int n) {
  const std::string t = p.toYamlText();
  if (p.keys().empty()) return " {}\n";
  return "\n" + indent(t, n);
}

const char* toString(OnBadFrame b) { return b == OnBadFrame::Skip ? "skip" : "fail"; }

std::string PipelineConfig::toYaml() const {
  std::ostringstream o;
  o << "# dslam resolved configuration (every default filled in)\n";
  if (!file.empty()) o << "# source: " << file << "\n";
  o << "pipeline:\n  name: " << name << "\n  mode: " << (mode == Mode::Parallel ? "parallel" : "sequential")
    << "\n  seed: " << seed << "\n";
  if (dataset) {
    o << "dataset:\n  type: " << dataset->type << "\n  on_bad_frame: " << toString(dataset->on_bad_frame)
      << "\n  start: " << dataset->start << "\n  max_frames: " << dataset->max_frames
      << "\n  stride: " << dataset->stride << "\n  params:" << paramsBlock(dataset->params, 4);
  }
  if (camera) o << "camera:\n" << indent(cameraToYaml(*camera), 2);
  for (const auto& [name, p] : sections) o << name << ":" << paramsBlock(p, 2);
  o << "modules:" << (modules.empty() ? " []" : "") << "\n";
  for (const auto& m : modules) {
    o << "  - name: " << m.name << "\n    type: " << m.type << "\n    enabled: " << (m.enabled ? "true" : "false")
      << "\n";
    if (!m.inputs.empty()) o << "    inputs: [" << yamlu::join(m.inputs) << "]\n";
    if (m.interface_name == std::string("Detector"))
      o << "    every: " << m.every << "\n    detection: " << m.detection << "\n    carry: " << m.carry
        << "\n    hold: " << m.hold << "\n    keyframes: " << m.keyframes << "\n    wait_coverage: " << m.wait_coverage
        << "\n";
    o << "    params:" << paramsBlock(m.params, 6);
  }
  o << "outputs:" << paramsBlock(outputs, 2);
  if (!plugin_dirs.empty()) {
    o << "plugin_dirs:\n";
    for (const auto& d : plugin_dirs) o << "  - " << d << "\n";
  }
  return o.str();
}

std::string detectDatasetType(const std::string& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec) && fs::path(path).extension() == ".rawlog") return "dslam::RawlogDataset";
  if (!fs::is_directory(path, ec)) return "";
  const fs::path p(path);
  if (fs::exists(p / "rgb.txt") || fs::exists(p / "associations.txt")) {
    const std::string n = fs::weakly_canonical(p).filename().string();
    return n.find("bonn") != std::string::npos ? "dslam::BonnDataset" : "dslam::TumDataset";
  }
  if (fs::exists(p / "mav0")) return "dslam::EurocDataset";
  if (fs::exists(p / "calib.txt")) return "dslam::KittiDataset";
  return "";
}

}  // namespace dslam::config
