// Overlays: set / add / remove / replace operations on a resolved pipeline
// (docs/ablation.md). Each operation edits the YAML tree of the pipeline,
// which is then loaded and validated again by the pipeline loader; every
// error names the operation's study file, line and key.
#include <mrpt/containers/yaml.h>

#include <algorithm>
#include <filesystem>
#include <regex>

#include "dslam/config/pipeline.h"
#include "dslam/config/yaml_loader.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/core/yaml_util.h"
#include "dslam/study/study.h"

namespace fs = std::filesystem;
using mrpt::containers::yaml;
using node_t = yaml::node_t;

namespace dslam::study {

const char* toString(OverlayOp::Kind k) {
  switch (k) {
    case OverlayOp::Kind::Set: return "set";
    case OverlayOp::Kind::Add: return "add";
    case OverlayOp::Kind::Remove: return "remove";
    case OverlayOp::Kind::Replace: return "replace";
  }
  return "?";
}

std::string OverlayOp::where() const {
  std::string s = file;
  if (line >= 0) s.append(":").append(std::to_string(line));
  if (!key_path.empty()) s.append(s.empty() ? "" : ": ").append("'").append(key_path).append("'");
  return s;
}

namespace {

constexpr const char* kResultName = "<overlay result>";

[[noreturn]] void fail(const OverlayOp& op, const std::string& msg) { throw ConfigError(op.where() + ": " + msg); }

node_t* child(node_t& m, const std::string& key) {
  if (!m.isMap()) return nullptr;
  for (auto& kv : m.asMap())
    if (yamlu::scalarText(kv.first).value_or("") == key) return &kv.second;
  return nullptr;
}

std::vector<std::string> keysOf(const node_t& m) { return m.isMap() ? yamlu::keysInOrder(m) : std::vector<std::string>{}; }

std::string moduleName(const node_t& m) {
  const node_t* n = yamlu::findValue(m, "name");
  return n ? yamlu::scalarText(*n).value_or("") : std::string();
}

/** The `modules:` list of a pipeline tree (created empty if missing). */
yaml::sequence_t& modules(node_t& root) {
  node_t* m = child(root, "modules");
  if (!m) {
    node_t seq;
    seq.d.emplace<yaml::sequence_t>();
    root.asMap()[node_t("modules")] = seq;
    m = child(root, "modules");
  }
  if (m->isNullNode()) m->d.emplace<yaml::sequence_t>();
  if (!m->isSequence()) throw ConfigError("pipeline: 'modules' is not a list");
  return m->asSequence();
}

std::vector<std::string> moduleNames(node_t& root) {
  std::vector<std::string> v;
  for (const auto& e : modules(root)) v.push_back(moduleName(e));
  return v;
}

/** Index of module `name` in the list; fails naming the operation if absent. */
size_t findModule(node_t& root, const std::string& name, const OverlayOp& op) {
  auto& seq = modules(root);
  for (size_t i = 0; i < seq.size(); i++)
    if (moduleName(seq[i]) == name) return i;
  const auto names = moduleNames(root);
  fail(op, "no module '" + name + "'" + yamlu::didYouMean(name, names) +
               " (modules: " + (names.empty() ? std::string("none") : yamlu::join(names)) + ")");
}

std::vector<std::string> splitPath(const std::string& p) {
  std::vector<std::string> parts;
  size_t b = 0;
  while (true) {
    const size_t e = p.find('.', b);
    parts.push_back(p.substr(b, e == std::string::npos ? std::string::npos : e - b));
    if (e == std::string::npos) break;
    b = e + 1;
  }
  return parts;
}

/** Parameter specs of a plug-in type ({} if the type is unknown). */
std::vector<ParamSpec> pluginSpecs(const std::string& type) {
  try {
    return createPlugin(type, CLASS_ID(Plugin))->paramSpecs();
  } catch (const Error&) {
    return {};
  }
}

std::vector<ParamSpec> sectionSpecs(const std::string& section, node_t& root) {
  if (section == "pipeline") return config::pipelineParamSpecs();
  if (section == "outputs") return config::outputParamSpecs();
  if (section == "dataset") {
    const node_t* t = yamlu::findValue(root, "dataset");
    const node_t* ty = t ? yamlu::findValue(*t, "type") : nullptr;
    return ty ? pluginSpecs(yamlu::scalarText(*ty).value_or("")) : std::vector<ParamSpec>{};
  }
  for (const auto& s : config::registeredSections())
    if (s.name == section) return s.specs();
  return {};
}

/** A relative path written in the study (parameter of type path) is made
 *  absolute against the study file's folder: the overlaid pipeline is loaded
 *  with the base pipeline's folder as base. */
void absolutizePath(node_t& v, const ParamSpec* spec, const OverlayOp& op) {
  if (!spec || spec->type != ParamType::Path) return;
  const auto t = yamlu::scalarText(v);
  if (!t || t->empty() || op.file.empty()) return;
  v = node_t(resolvePath(*t, fs::path(op.file).parent_path().string()));
}

const ParamSpec* findSpec(const std::vector<ParamSpec>& specs, const std::string& name) {
  for (const auto& s : specs)
    if (s.name == name) return &s;
  return nullptr;
}

void absolutizeModuleParams(node_t& module, const OverlayOp& op) {
  const node_t* ty = yamlu::findValue(module, "type");
  node_t* params = child(module, "params");
  if (!ty || !params || !params->isMap()) return;
  const auto specs = pluginSpecs(yamlu::scalarText(*ty).value_or(""));
  for (auto& kv : params->asMap())
    absolutizePath(kv.second, findSpec(specs, yamlu::scalarText(kv.first).value_or("")), op);
}


/** `set: {dotted.path: value, ...}`. Modules are addressed by name
 *  (`modules.<name>.params.<p>`). Every key down to the parameter must exist
 *  in the resolved pipeline (which lists every default); keys inside a
 *  parameter's own map (per-class thresholds) may be new. */
void applySet(node_t& root, const OverlayOp& op) {
  const node_t& setmap = op.node->node();
  if (!setmap.isMap() || setmap.asMap().empty())
    fail(op, "'set' expects a map {dotted.key.path: value, ...}, e.g. {features.n_features: 2000}");
  for (const auto& key : yamlu::keysInOrder(setmap)) {
    const node_t& value = *yamlu::findValue(setmap, key);
    const auto parts = splitPath(key);
    for (const auto& p : parts)
      if (p.empty()) fail(op, "'" + key + "': empty component in the key path");
    node_t* cur = &root;
    size_t i = 0;
    size_t param_index = 1;  // index of the parameter name in `parts`
    std::vector<ParamSpec> specs;
    std::string where;  // for messages
    if (parts[0] == "modules") {
      if (parts.size() < 3)
        fail(op, "'" + key + "': expected modules.<module name>.<key> (e.g. modules.box_filter.params.min_score)");
      auto& seq = modules(root);
      cur = &seq[findModule(root, parts[1], op)];
      i = 2;
      const node_t* ty = yamlu::findValue(*cur, "type");
      specs = pluginSpecs(ty ? yamlu::scalarText(*ty).value_or("") : "");
      param_index = parts[2] == "params" ? 3 : 2;
      where = "module '" + parts[1] + "'";
      const auto& mkeys = config::moduleKeys();
      if (parts[2] != "params" && std::find(mkeys.begin(), mkeys.end(), parts[2]) == mkeys.end())
        fail(op, "'" + key + "': unknown module key '" + parts[2] + "'" + yamlu::didYouMean(parts[2], mkeys) +
                     " (valid: " + yamlu::join(mkeys) + ")");
      if (parts[2] != "params" && parts.size() > 3)
        fail(op, "'" + key + "': '" + parts[2] + "' has no sub-keys");
      if (parts[2] != "params" && !child(*cur, parts[2])) {
        cur->asMap()[node_t(parts[2])] = node_t();  // inputs / every may be absent from the resolved text
      }
    } else {
      specs = sectionSpecs(parts[0], root);
      param_index = parts[0] == "dataset" && parts.size() > 1 && parts[1] == "params" ? 2 : 1;
      if (parts[0] == "dataset" && param_index == 1) specs = config::datasetCommonParamSpecs();
      where = "section '" + parts[0] + "'";
    }
    if (parts.size() <= param_index && parts[0] != "modules")
      fail(op, "'" + key + "': name a parameter, e.g. " + parts[0] + ".<parameter>");
    for (; i < parts.size(); i++) {
      node_t* next = child(*cur, parts[i]);
      const bool last = i + 1 == parts.size();
      if (!next) {
        if (i > param_index && last && cur->isMap()) {
          cur->asMap()[node_t(parts[i])] = node_t();
          next = child(*cur, parts[i]);
        } else {
          const auto valid = keysOf(*cur);
          const std::string what = i == 0 ? "no section '" + parts[0] + "' in the pipeline"
                                   : i == param_index ? "no parameter '" + parts[i] + "' in " + where
                                                      : "no key '" + parts[i] + "' in " + where;
          fail(op, "'" + key + "': " + what + yamlu::didYouMean(parts[i], valid) +
                       (valid.empty() ? std::string() : " (valid: " + yamlu::join(valid) + ")"));
        }
      }
      cur = next;
    }
    *cur = value;
    if (parts.size() == param_index + 1) absolutizePath(*cur, findSpec(specs, parts[param_index]), op);
  }
}

std::vector<std::string> namesOf(const node_t& n, const OverlayOp& op) {
  std::vector<std::string> v;
  if (auto t = yamlu::scalarText(n)) {
    v.push_back(*t);
  } else if (n.isSequence()) {
    for (const auto& e : n.asSequence()) {
      auto t2 = yamlu::scalarText(e);
      if (!t2) fail(op, "'remove' expects a module name or a list of module names");
      v.push_back(*t2);
    }
  } else {
    fail(op, "'remove' expects a module name or a list of module names, got " + yamlu::describe(n));
  }
  return v;
}

void applyRemove(node_t& root, const OverlayOp& op) {
  for (const auto& name : namesOf(op.node->node(), op)) {
    auto& seq = modules(root);
    seq.erase(seq.begin() + static_cast<std::ptrdiff_t>(findModule(root, name, op)));
  }
}

/** Checks a module entry written in an operation: keys, plug-in type and
 *  parameter names, against the plug-in's declared parameters. */
void checkModuleEntry(const node_t& m, const OverlayOp& op, const std::vector<std::string>& extra_keys,
                      const std::string& prefix) {
  if (!m.isMap()) fail(op, prefix + "expects a map {name, type, params, inputs, every, enabled}");
  std::vector<std::string> valid = config::moduleKeys();
  valid.insert(valid.end(), extra_keys.begin(), extra_keys.end());
  for (const auto& k : yamlu::keysInOrder(m))
    if (std::find(valid.begin(), valid.end(), k) == valid.end())
      fail(op, prefix + "unknown key '" + k + "'" + yamlu::didYouMean(k, valid) + " (valid: " + yamlu::join(valid) + ")");
  const node_t* ty = yamlu::findValue(m, "type");
  const auto type = ty ? yamlu::scalarText(*ty) : std::nullopt;
  if (!type || type->empty()) fail(op, prefix + "missing required key 'type' (a plug-in, see `dslam plugins`)");
  std::shared_ptr<Plugin> plugin;
  try {
    plugin = createPlugin(*type, CLASS_ID(Plugin));
  } catch (const ConfigError& e) {
    fail(op, prefix + e.what());
  }
  if (const node_t* p = yamlu::findValue(m, "params"); p && !p->isNullNode()) {
    if (!p->isMap()) fail(op, prefix + "'params' must be a map");
    std::vector<std::string> names;
    for (const auto& s : plugin->paramSpecs()) names.push_back(s.name);
    for (const auto& k : yamlu::keysInOrder(*p))
      if (std::find(names.begin(), names.end(), k) == names.end())
        fail(op, prefix + "no parameter '" + k + "' in " + *type + yamlu::didYouMean(k, names) +
                     " (valid: " + yamlu::join(names) + ")");
  }
}

/** `add: {name, type, params, inputs, every, enabled, after | before}`:
 *  inserted after / before the named module, else at the end of the list. */
void applyAdd(node_t& root, const OverlayOp& op) {
  node_t m = op.node->node();
  checkModuleEntry(m, op, {"after", "before"}, "'add': ");
  if (yamlu::findValue(m, "after") && yamlu::findValue(m, "before")) fail(op, "'add': give 'after' or 'before', not both");
  std::string name = moduleName(m);
  if (name.empty()) name = yamlu::scalarText(*yamlu::findValue(m, "type")).value_or("");
  for (const auto& n : moduleNames(root))
    if (n == name) fail(op, "'add': the pipeline already has a module '" + name + "' (use replace, or another name)");
  auto& seq = modules(root);
  size_t pos = seq.size();
  for (const char* k : {"after", "before"}) {
    if (const node_t* a = yamlu::findValue(m, k)) {
      const size_t i = findModule(root, yamlu::scalarText(*a).value_or(""), op);
      pos = std::string(k) == "after" ? i + 1 : i;
    }
  }
  auto& mm = m.asMap();
  for (auto it = mm.begin(); it != mm.end();) {
    const auto k = yamlu::scalarText(it->first).value_or("");
    it = (k == "after" || k == "before") ? mm.erase(it) : std::next(it);
  }
  absolutizeModuleParams(m, op);
  seq.insert(seq.begin() + static_cast<std::ptrdiff_t>(pos), m);
}

/** `replace: {module: NAME, with: {type, params, ...}}`: the entry is
 *  replaced in place; it keeps its name, and its inputs unless `with` gives
 *  them. */
void applyReplace(node_t& root, const OverlayOp& op) {
  const node_t& r = op.node->node();
  if (!r.isMap()) fail(op, "'replace' expects {module: <name>, with: {type, params, ...}}");
  for (const auto& k : yamlu::keysInOrder(r))
    if (k != "module" && k != "with")
      fail(op, "'replace': unknown key '" + k + "'" + yamlu::didYouMean(k, {"module", "with"}) + " (valid: module, with)");
  const node_t* mn = yamlu::findValue(r, "module");
  const node_t* with = yamlu::findValue(r, "with");
  if (!mn || !yamlu::scalarText(*mn)) fail(op, "'replace': missing 'module: <name of the module to replace>'");
  if (!with) fail(op, "'replace': missing 'with: {type, params, ...}'");
  checkModuleEntry(*with, op, {}, "'replace.with': ");
  const std::string name = *yamlu::scalarText(*mn);
  auto& seq = modules(root);
  const size_t i = findModule(root, name, op);
  node_t m = *with;
  if (const node_t* nn = yamlu::findValue(m, "name"); nn && yamlu::scalarText(*nn).value_or("") != name)
    fail(op, "'replace.with': the replacement keeps the name '" + name + "'; drop 'name' (or remove + add)");
  m.asMap()[node_t("name")] = node_t(name);
  if (!yamlu::findValue(m, "inputs"))
    if (const node_t* in = yamlu::findValue(seq[i], "inputs")) m.asMap()[node_t("inputs")] = *in;
  absolutizeModuleParams(m, op);
  seq[i] = m;
}

/** The loader's message without the "<text>:N: " position (a line of the
 *  generated text means nothing to the user). */
std::string stripPosition(const std::string& msg) {
  static const std::regex re(R"(<(text|overlay result)>(:\d+)?(:\d+)?:\s*)");
  return std::regex_replace(msg, re, "");
}

}  // namespace

std::vector<OverlayOp> parseOverlay(const std::string& yaml_text, const std::string& pseudo_file) {
  const config::LoadedYaml ly = config::loadYamlText(yaml_text, pseudo_file, ".");
  const node_t& root = ly.root->node();
  if (root.isNullNode()) return {};
  if (!root.isSequence())
    throw ConfigError(pseudo_file + ":" + std::to_string(root.marks.line + 1) +
                      ": an overlay is a list of operations (- set: ..., - add: ..., - remove: ..., - replace: ...)");
  std::vector<OverlayOp> ops;
  size_t i = 0;
  for (const auto& e : root.asSequence()) {
    OverlayOp op;
    op.file = pseudo_file;
    op.line = e.marks.line + 1;
    op.key_path.append("[").append(std::to_string(i++)).append("]");
    if (!e.isMap() || e.asMap().size() != 1)
      fail(op, "each operation is a map with one key: set, add, remove or replace");
    const std::string k = yamlu::scalarText(e.asMap().begin()->first).value_or("");
    static const std::vector<std::string> kinds = {"set", "add", "remove", "replace"};
    if (k == "set") op.kind = OverlayOp::Kind::Set;
    else if (k == "add") op.kind = OverlayOp::Kind::Add;
    else if (k == "remove") op.kind = OverlayOp::Kind::Remove;
    else if (k == "replace") op.kind = OverlayOp::Kind::Replace;
    else fail(op, "unknown operation '" + k + "'" + yamlu::didYouMean(k, kinds) + " (valid: set, add, remove, replace)");
    op.key_path += "." + k;
    auto y = std::make_shared<yaml>();
    y->node() = e.asMap().begin()->second;
    op.node = y;
    ops.push_back(std::move(op));
  }
  return ops;
}

std::string applyOverlay(const std::string& pipeline_yaml, const std::string& base_dir,
                         const std::vector<OverlayOp>& ops) {
  std::string text = pipeline_yaml;
  for (const auto& op : ops) {
    const config::LoadedYaml ly = config::loadYamlText(text, kResultName, base_dir);
    node_t& root = ly.root->node();
    if (!root.isMap()) throw ConfigError("applyOverlay: the pipeline text is not a YAML map");
    switch (op.kind) {
      case OverlayOp::Kind::Set: applySet(root, op); break;
      case OverlayOp::Kind::Add: applyAdd(root, op); break;
      case OverlayOp::Kind::Remove: applyRemove(root, op); break;
      case OverlayOp::Kind::Replace: applyReplace(root, op); break;
    }
    const std::string edited = yamlu::toYamlText(*ly.root);
    try {
      text = config::loadPipelineText(edited, base_dir).toYaml();
    } catch (const Error& e) {
      fail(op, std::string("the pipeline after this '") + toString(op.kind) + "' is invalid: " + stripPosition(e.what()));
    }
  }
  if (ops.empty()) text = config::loadPipelineText(text, base_dir).toYaml();
  return text;
}

}  // namespace dslam::study
