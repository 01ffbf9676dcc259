// `dslam eval ate GT EST [...]` and `dslam eval rpe GT EST --delta N --delta-unit frames|s|m [...]`:
// trajectory evaluation against ground truth; `dslam eval objects RUN SCENE [...]`: the semantic object
// map of a run against a synthetic scene's ground truth (docs/evaluation.md).
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>

#include "command.h"
#include "dslam/core/atomic_file.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/eval/eval.h"
#include "dslam/eval/objects.h"
#include "dslam/eval/plot.h"
#include "dslam/trajectory/io.h"

void setupEvalDense(CLI::App& eval);

namespace {

using namespace dslam;

struct Common {
  std::string gt, est;
  double max_dt = 0.02;
  std::string align;
  bool json = false;
  std::string plot;
  std::string gt_format = "auto", est_format = "auto";
  std::string gt_times, est_times;
  std::string save_aligned;
};

void addCommon(CLI::App* c, Common& o, const char* default_align) {
  o.align = default_align;
  c->add_option("gt", o.gt, "ground-truth trajectory file")->required();
  c->add_option("est", o.est, "estimated trajectory file")->required();
  c->add_option("--max-dt", o.max_dt, "association threshold |t_gt - t_est| < max_dt, seconds")
      ->capture_default_str()
      ->check(app::kPositive);
  c->add_option("--align", o.align, "alignment of the estimate onto the ground truth")
      ->capture_default_str()
      ->check(CLI::IsMember({"se3", "sim3", "none"}));
  c->add_flag("--json", o.json, "print one JSON object instead of text");
  c->add_option("--plot", o.plot, "write a plot (PNG) and its data (CSV next to it)");
  const auto formats = CLI::IsMember({"auto", "tum", "kitti", "euroc"});
  c->add_option("--gt-format", o.gt_format, "ground-truth file format")->capture_default_str()->check(formats);
  c->add_option("--est-format", o.est_format, "estimate file format")->capture_default_str()->check(formats);
  c->add_option("--kitti-times", o.gt_times, "times file (one per line) for a 12-column KITTI ground truth");
  c->add_option("--est-kitti-times", o.est_times, "times file (one per line) for a 12-column KITTI estimate");
  c->add_option("--save-aligned", o.save_aligned,
                "write the aligned estimate (TUM format; EuRoC CSV if the name ends in .csv)");
}

/** Before anything is computed: outputs must not replace an input (a plot
 *  `gt.png` writes `gt.csv`), and the plot must be a format the plotter writes. */
void checkOutputs(const Common& o) {
  namespace fs = std::filesystem;
  std::vector<std::pair<std::string, std::string>> outs;  // (path, option)
  if (!o.save_aligned.empty()) outs.push_back({o.save_aligned, "--save-aligned"});
  if (!o.plot.empty()) {
    std::string ext = fs::path(o.plot).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    if (ext != ".png" && ext != ".pdf" && ext != ".svg" && ext != ".jpg" && ext != ".jpeg")
      throw ConfigError("--plot " + o.plot + ": the picture must end in .png, .pdf, .svg or .jpg");
    outs.push_back({o.plot, "--plot"});
    outs.push_back({fs::path(o.plot).replace_extension(".csv").string(), "--plot (its data file)"});
  }
  for (const auto& [out, opt] : outs)
    for (const std::string& in : {o.gt, o.est, o.gt_times, o.est_times}) {
      std::error_code ec;
      if (!in.empty() && fs::exists(out, ec) && fs::equivalent(out, in, ec))
        throw ConfigError(opt + " " + out + " is an input file (" + in + "): it would be overwritten; choose another name");
    }
}

Trajectory load(const std::string& path, const std::string& format, const std::string& times, const char* what) {
  traj::ReadOptions ro;
  ro.format = traj::formatFromString(format);
  if (ro.format == traj::Format::Auto && !std::filesystem::is_regular_file(path))
    throw DataError(std::string(what) + " trajectory file not found: " + path);
  const traj::Format actual = ro.format == traj::Format::Auto ? traj::detectFormat(path) : ro.format;
  if (!times.empty() && actual != traj::Format::Kitti)
    throw ConfigError(std::string("a KITTI times file was given for the ") + what + " trajectory " + path +
                      ", which is in " + traj::toString(actual) + " format");
  ro.kitti_times = times;
  Trajectory t = traj::read(path, ro);
  DSLAM_LOG(Debug, what << ": " << path << " (" << traj::toString(actual) << "), " << t.size() << " poses");
  return t;
}

void saveAligned(const Common& o, const Trajectory& aligned, const eval::Alignment& a) {
  traj::WriteOptions wo;
  wo.format = std::filesystem::path(o.save_aligned).extension() == ".csv" ? traj::Format::Euroc : traj::Format::Tum;
  wo.header = "estimate " + o.est + " aligned onto " + o.gt + " (" + eval::toString(a.method) +
              ", scale " + std::to_string(a.scale) + ")";
  traj::write(o.save_aligned, aligned, wo);
  DSLAM_LOG(Info, "aligned estimate written to " << o.save_aligned);
}

void header(const Common& o) {
  std::cout << "ground truth: " << o.gt << "\nestimate:     " << o.est << "\n";
}

/** Prints an ATE or RPE result (JSON or text), then writes the aligned
 *  estimate and the plot when asked; `plot` draws and returns the CSV path. */
template <class Result, class PlotFn>
void report(const Common& o, const Result& r, PlotFn plot) {
  if (o.json) {
    std::cout << eval::toJson(r) << std::endl;
  } else {
    header(o);
    std::cout << eval::toText(r) << std::flush;
  }
  if (!o.save_aligned.empty()) saveAligned(o, r.aligned, r.alignment);
  if (!o.plot.empty()) {
    const std::string csv = plot();
    DSLAM_LOG(Info, "plot written to " << o.plot << " (data: " << csv << ")");
  }
}

void runAte(const Common& o) {
  checkOutputs(o);
  const Trajectory gt = load(o.gt, o.gt_format, o.gt_times, "ground-truth");
  const Trajectory est = load(o.est, o.est_format, o.est_times, "estimate");
  eval::AteOptions opt;
  opt.max_dt = o.max_dt;
  opt.align = eval::alignFromString(o.align);
  opt.gt_name = o.gt;
  opt.est_name = o.est;
  const auto r = eval::computeAte(gt, est, opt);
  report(o, r, [&] {
    return eval::plot(o.plot, eval::plotRows(gt, r), "ATE " + std::filesystem::path(o.est).filename().string(),
                      "ATE [m]");
  });
}

void runRpe(const Common& o, double delta, const std::string& unit) {
  checkOutputs(o);
  const Trajectory gt = load(o.gt, o.gt_format, o.gt_times, "ground-truth");
  const Trajectory est = load(o.est, o.est_format, o.est_times, "estimate");
  eval::RpeOptions opt;
  opt.max_dt = o.max_dt;
  opt.align = eval::alignFromString(o.align);
  opt.delta = delta;
  opt.unit = eval::deltaUnitFromString(unit);
  opt.gt_name = o.gt;
  opt.est_name = o.est;
  const auto r = eval::computeRpe(gt, est, opt);
  report(o, r, [&] {
    return eval::plot(o.plot, eval::plotRows(gt, est, r), "RPE " + std::filesystem::path(o.est).filename().string(),
                      "RPE trans. [m] (delta " + (std::ostringstream() << delta).str() + " " + unit + ")");
  });
}

struct ObjectsOpts {
  std::string run, scene, json;
  std::string align = "se3";
  double align_until = std::numeric_limits<double>::quiet_NaN();
  eval::ObjectEvalOptions eo;
};

/** A `dslam synth` folder (groundtruth.txt, rgb.txt), or its objects.json. */
bool isSceneFolder(const std::string& p) {
  namespace fs = std::filesystem;
  const fs::path d = fs::is_directory(p) ? fs::path(p) : fs::path(p).parent_path();
  return fs::exists(d / "groundtruth.txt") && fs::exists(d / "rgb.txt") && fs::exists(d / "objects.json");
}

void runObjects(ObjectsOpts o) {
  namespace fs = std::filesystem;
  // Either order (GT_SCENE EST or EST GT_SCENE); a scene's objects.json stands for its folder.
  if (isSceneFolder(o.run) && !isSceneFolder(o.scene)) std::swap(o.run, o.scene);
  if (!fs::is_directory(o.scene) && isSceneFolder(o.scene)) o.scene = fs::path(o.scene).parent_path().string();
  std::string objects_file = o.run, traj_file;
  if (fs::is_directory(o.run)) {
    objects_file = (fs::path(o.run) / "objects.json").string();
    if (!fs::exists(objects_file))
      throw DataError("run folder " + o.run + " has no objects.json (dslam run --out writes it when the map has " +
                      "an object layer)");
    traj_file = (fs::path(o.run) / "trajectory.txt").string();
  } else {
    traj_file = (fs::path(o.run).parent_path() / "trajectory.txt").string();
  }
  const eval::Scene scene = eval::readScene(o.scene);
  const eval::EstObjects est = eval::readEstObjects(objects_file);
  eval::ObjectEvalOptions eo = o.eo;
  eo.align = eval::alignFromString(o.align);
  eo.align_until = o.align_until;
  eo.run_name = objects_file;
  eo.traj_name = traj_file;
  Trajectory traj;
  if (fs::exists(traj_file)) {
    traj = traj::readTum(traj_file);
  } else if (eo.align != eval::Align::None) {
    throw DataError("no trajectory.txt next to " + objects_file + " (" + traj_file +
                    "): it is needed to align the objects to the scene (--align none if they are in its frame)");
  }
  size_t in_map = 0;
  for (const auto& ob : est.objects) in_map += ob.map == est.map;
  if (in_map == 0)
    DSLAM_LOG(Warn, objects_file << ": no objects in map " << est.map
                                 << " (the map of trajectory.txt); evaluated as an empty object map");
  const auto r = eval::evaluateObjects(scene, est, traj, eo);
  std::cout << eval::toText(r) << std::flush;
  if (!o.json.empty()) {
    AtomicOfstream f(o.json);
    f << eval::toJson(r) << "\n";
    f.commit();
    DSLAM_LOG(Info, "numbers written to " << o.json);
  }
}

void setup(CLI::App& sub) {
  sub.require_subcommand(1);
  static Common ate_o, rpe_o;
  static double delta = 1;
  static std::string unit = "frames";

  auto* ate = sub.add_subcommand("ate", "Absolute trajectory error (translational, after alignment)");
  addCommon(ate, ate_o, "se3");
  ate->callback([] { runAte(ate_o); });

  auto* rpe = sub.add_subcommand("rpe", "Relative pose error over a fixed delta (translational m, rotational deg)");
  addCommon(rpe, rpe_o, "none");
  rpe->add_option("--delta", delta, "pair distance, in --delta-unit")->capture_default_str()->check(
      app::kPositive);
  rpe->add_option("--delta-unit", unit, "frames: associated poses; s: seconds; m: metres of ground-truth path")
      ->capture_default_str()
      ->check(CLI::IsMember({"frames", "s", "m"}));
  rpe->callback([] { runRpe(rpe_o, delta, unit); });

  static ObjectsOpts obj_o;
  auto* obj = sub.add_subcommand("objects", "Semantic object map of a run against a synthetic scene's ground truth");
  obj->add_option("run", obj_o.run,
                  "`dslam run --out` folder (objects.json, trajectory.txt) or its objects.json (the two positional "
                  "arguments may come in either order)")
      ->required();
  obj->add_option("scene", obj_o.scene, "scene folder written by `dslam synth` (objects.json, groundtruth.txt)")
      ->required();
  obj->add_option("--align", obj_o.align, "alignment of trajectory.txt (and the objects) onto the ground truth")
      ->capture_default_str()
      ->check(CLI::IsMember({"se3", "none"}));
  obj->add_option("--align-until", obj_o.align_until,
                  "align on the poses before this time, s (default: the first change event; all poses if none)");
  obj->add_option("--match-radius", obj_o.eo.match_radius, "centroid-to-box distance of a match, metres")
      ->capture_default_str()
      ->check(app::kPositive);
  obj->add_option("--on-object-margin", obj_o.eo.on_object_margin,
                  "an estimate this near (metres) to the box of an object of its class present at the end is on it "
                  "(matched or a duplicate), not stale, also inside a place an object of its class left (an object "
                  "moved by less than its size); 0 = the nearer box decides")
      ->capture_default_str()
      ->check(app::kNonNegative);
  obj->add_option("--min-visible-pixels", obj_o.eo.min_visible_pixels,
                  "a ground-truth object counts if the camera saw this many of its pixels (summed over frames)")
      ->capture_default_str()
      ->check(app::kNonNegative);
  obj->add_option("--min-points", obj_o.eo.min_points,
                  "leave out estimated objects of fewer map points (the trade-off of outputs.objects_min_points "
                  "from a run with objects_min_points: 1; 0 = every object of the file)")
      ->capture_default_str()
      ->check(app::kNonNegative);
  obj->add_option("--min-sightings", obj_o.eo.min_sightings,
                  "leave out estimated objects seen by fewer keyframes, unless of --confirm-points map points (the "
                  "trade-off of outputs.objects_min_sightings from a run with the default 1; 0 or 1 = every object)")
      ->capture_default_str()
      ->check(app::kNonNegative);
  obj->add_option("--confirm-points", obj_o.eo.confirm_points,
                  "with --min-sightings: objects of this many map points are kept however few keyframes saw them "
                  "(outputs.objects_confirm_points; 0 = no exception)")
      ->capture_default_str()
      ->check(app::kNonNegative);
  obj->add_option("--max-dt", obj_o.eo.max_dt, "trajectory association threshold, seconds")
      ->capture_default_str()
      ->check(app::kPositive);
  obj->add_option("--max-ate", obj_o.eo.max_ate,
                  "above this ATE rmse (m) of the alignment poses the run and the scene do not match")
      ->capture_default_str()
      ->check(app::kPositive);
  obj->add_option("--json", obj_o.json, "also write the numbers to this JSON file");
  obj->callback([] { runObjects(obj_o); });

  setupEvalDense(sub);  // cmd_eval_dense.cpp
}

}  // namespace

DSLAM_COMMAND(eval, "Evaluate a trajectory (ATE, RPE), a dense map or a semantic object map against ground truth", setup);
