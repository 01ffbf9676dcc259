// The bad-input matrix: every bad input a user can hand dslam, run through
// the CLI as a user would, with the message it prints and its exit code.
// docs/errors.md is generated from this table (DSLAM_UPDATE_DOCS=1 rewrites
// it); the test fails when the page and the program disagree.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "test_support.h"

namespace fs = std::filesystem;

namespace dslam::test {
namespace {

struct Case {
  std::string input;  ///< which file or argument
  std::string wrong;  ///< what is wrong with it
  /** Writes the bad input under `dir` and returns the dslam arguments. */
  std::function<std::string(const std::string& dir)> setup;
  int exit_code;
  std::vector<std::string> must;  ///< substrings the message must contain ($DIR = the case folder)
  std::string line_prefix = "error:";  ///< the line that is the message ("[warn]" for documented skips)
};

std::string q(const std::string& s) { return "'" + s + "'"; }

/** A small rendered RGB-D scene in the TUM layout (8 frames, 320x240). */
const std::string& tinyScene() {
  static const std::string dir = [] {
    const std::string d = tempDir("bad_input_scene") + "/tum";
    const auto r = runDslam("synth " + q(source("config/scenarios/static_office.yaml")) + " --out " + q(d) +
                            " --frames 8 --resolution 320x240 --no-right --no-labels --threads 1");
    if (r.exit_code != 0) ADD_FAILURE() << r.out;
    return d;
  }();
  return dir;
}

/** A TUM trajectory with the tiny scene's ground-truth stamps, each with
 *  the same pose "tx ty tz qx qy qz qw". */
std::string sceneStampsWithPose(const std::string& pose) {
  std::istringstream in(readFile(tinyScene() + "/groundtruth.txt"));
  std::string line, out;
  while (std::getline(in, line)) {
    std::istringstream f(line);
    std::string t;
    if (line.empty() || line[0] == '#' || !(f >> t)) continue;
    out += t + " " + pose + "\n";
  }
  return out;
}

/** A copy of the tiny scene in dir/tum; returns its path. */
std::string sceneCopy(const std::string& dir) {
  const std::string d = dir + "/tum";
  fs::copy(tinyScene(), d, fs::copy_options::recursive);
  return d;
}

/** The i-th (sorted) file of a folder. */
std::string nthFile(const std::string& folder, size_t i) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(folder)) names.push_back(e.path().string());
  std::sort(names.begin(), names.end());
  return names.at(i);
}

/** A 16-bit PNG of zeros (a depth image without any valid pixel). */
void writeZeroDepth(const std::string& path, int w, int h) {
  EXPECT_TRUE(cv::imwrite(path, cv::Mat(h, w, CV_16UC1, cv::Scalar(0)))) << path;
}

std::string pipeline(const std::string& dir, const std::string& text) {
  writeFile(dir + "/pipeline.yaml", text);
  return dir + "/pipeline.yaml";
}

/** A run folder dir/run for `dslam eval objects`: objects.json with the given
 *  "objects" list and the tiny scene's ground truth as trajectory.txt (or
 *  `traj` if given). */
std::string objectsRun(const std::string& dir, const std::string& objects, const std::string& traj = "") {
  const std::string d = dir + "/run";
  fs::create_directories(d);
  writeFile(d + "/objects.json", "{\"format\": \"dslam-objects\", \"version\": 1, \"map\": 0, \"objects\": [" +
                                     objects + "]}\n");
  if (traj.empty())
    fs::copy_file(tinyScene() + "/groundtruth.txt", d + "/trajectory.txt");
  else
    writeFile(d + "/trajectory.txt", traj);
  return d;
}

/** An estimated object of class `cls` ("class_id": 62 or "class": "chair"). */
std::string estObject(const std::string& cls) {
  return "{\"id\": 1, \"map\": 0, " + cls + ", \"centroid\": [1, 0, 0.5], \"active\": true}";
}

const std::string kBaseline = "config/pipelines/orbslam_baseline.yaml";

/** `dslam run` of the baseline pipeline on `dataset`, writing to `out`. */
std::string runBaseline(const std::string& dataset, const std::string& out) {
  return "run " + q(source(kBaseline)) + " --dataset " + q(dataset) + " --out " + q(out) + " --no-progress";
}

std::vector<Case> cases() {
  std::vector<Case> c;
  // ---- pipeline YAML --------------------------------------------------------
  c.push_back({"pipeline YAML", "file does not exist",
               [](const std::string& d) { return "config check " + q(d + "/missing.yaml"); }, 1,
               {"config file not found", "missing.yaml"}});
  c.push_back({"pipeline YAML", "syntax error (unclosed flow sequence)",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\nmodules: [\n"));
               },
               1, {"pipeline.yaml:3:1", "YAML syntax error"}});
  c.push_back({"pipeline YAML", "unknown section (typo)",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\nfeatuers: {n_features: 500}\n"));
               },
               1, {"pipeline.yaml:2", "'featuers'", "did you mean 'features'"}});
  c.push_back({"pipeline YAML", "value of the wrong type",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\nfeatures: {n_features: many}\n"));
               },
               1, {"pipeline.yaml:2", "features.n_features", "expected an integer"}});
  c.push_back({"pipeline YAML", "invalid enum value",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x, mode: sequentail}\n"));
               },
               1, {"pipeline.yaml:1", "pipeline.mode", "sequentail"}});
  c.push_back({"pipeline YAML", "unknown plugin type",
               [](const std::string& d) {
                 return "config check " +
                        q(pipeline(d, "pipeline: {name: x}\nmodules:\n  - name: b\n    type: dslam::CeresBackendd\n"));
               },
               1, {"pipeline.yaml:4", "modules[0].type", "did you mean 'dslam::CeresBackend'"}});
  c.push_back({"pipeline YAML", "unknown plugin parameter",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d,
                                                     "pipeline: {name: x}\nmodules:\n  - name: b\n    type: "
                                                     "dslam::CeresBackend\n    params: {max_iteration: 3}\n"));
               },
               1, {"pipeline.yaml:5", "modules[0].params.max_iteration", "did you mean 'max_iterations'"}});
  c.push_back({"pipeline YAML", "`$include{}` of a missing file",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\ncamera: $include{nothere.yaml}\n"));
               },
               1, {"pipeline.yaml:2", "included file not found", "nothere.yaml"}});
  c.push_back({"pipeline YAML", "`$include{}` of a file that is not YAML (quoted, not dumped)",
               [](const std::string& d) {
                 std::string lines;
                 for (int i = 0; i < 50; i++) lines += "user" + std::to_string(i) + ":x:" + std::to_string(i) + ":0::/home:/bin/sh\n";
                 writeFile(d + "/passwd", lines);
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\ncamera: $include{passwd}\n"));
               },
               1, {"passwd:1", "key 'camera'", "expected a map"}});
  c.push_back({"pipeline YAML", "`$include{}` cycle below the top level (a.yaml -> b.yaml -> a.yaml)",
               [](const std::string& d) {
                 writeFile(d + "/a.yaml", "fx: $include{b.yaml}\n");
                 writeFile(d + "/b.yaml", "fx: $include{a.yaml}\n");
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\ncamera: $include{a.yaml}\n"));
               },
               1, {"include cycle", "a.yaml includes itself", "b.yaml"}});
  c.push_back({"pipeline YAML", "`${VAR}` not set and without default",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: ${DSLAM_TEST_UNSET_VARIABLE}}\n"));
               },
               1, {"DSLAM_TEST_UNSET_VARIABLE", "is not set (or empty) and has no default"}});
  // A pipeline's camera section with one key replaced (fx 500, width 320 otherwise).
  auto camera = [](const std::string& fx, const std::string& width) {
    return [fx, width](const std::string& d) {
      return "config check " + q(pipeline(d, "pipeline: {name: x}\ncamera: {fx: " + fx + ", fy: 500, cx: 160, cy: 120, "
                                             "width: " + width + ", height: 240}\n"));
    };
  };
  c.push_back({"camera section", "negative focal length", camera("-5", "320"), 1,
               {"pipeline.yaml:2", "camera.fx", "out of range"}});
  c.push_back({"camera section", "infinite focal length", camera(".inf", "320"), 1,
               {"pipeline.yaml:2", "camera.fx", "expected a finite number"}});
  c.push_back({"camera section", "image width 0", camera("500", "0"), 1,
               {"pipeline.yaml:2", "'width' must be greater than 0"}});
  c.push_back({"camera section", "principal point outside the image", camera("500", "120"), 1,
               {"pipeline.yaml:2", "'cx' (160) lies outside the image", "0..width (120)"}});
  c.push_back({"pipeline YAML", "key twice in a {...} map",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x, mode: sequential, name: y}\n"));
               },
               1, {"pipeline.yaml:1: key 'name' appears twice in the same {...} map"}});
  // ---- datasets -------------------------------------------------------------
  c.push_back({"dataset", "folder does not exist",
               [](const std::string& d) { return "run " + q(source(kBaseline)) + " --dataset " + q(d + "/nowhere") + " --out " + q(d + "/out"); },
               1, {"dataset not found", "nowhere"}});
  c.push_back({"dataset", "a symbolic link that points to itself (a loop)",
               [](const std::string& d) {
                 fs::create_symlink(d + "/loop", d + "/loop");
                 return "run " + q(source(kBaseline)) + " --dataset " + q(d + "/loop") + " --out " + q(d + "/out");
               },
               1, {"$DIR/loop: Too many levels of symbolic links"}});
  c.push_back({"output folder", "`--out` is a file",
               [](const std::string& d) {
                 writeFile(d + "/afile", "x\n");
                 return runBaseline(tinyScene(), d + "/afile");
               },
               1, {"output folder $DIR/afile is a file, not a folder"}});
  c.push_back({"output folder", "`--out` is the dataset folder",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 return runBaseline(s, s);
               },
               1, {"is the dataset folder", "would replace the dataset's"}});
  c.push_back({"command line", "`--localization-only` without `--load-atlas`",
               [](const std::string& d) { return runBaseline(tinyScene(), d + "/out") + " --localization-only"; }, 1,
               {"--localization-only tracks against a saved map", "--load-atlas"}});
  c.push_back({"TUM rgb image", "PNG header of 25000x25000 pixels (a decompression bomb)",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 std::string png = readFile(nthFile(s + "/rgb", 2));
                 for (int k = 0; k < 2; k++)
                   for (int b = 0; b < 4; b++) png[16 + 4 * k + b] = static_cast<char>((25000u >> (24 - 8 * b)) & 0xff);
                 uint32_t crc = 0xffffffffu;  // IHDR's CRC made to match
                 for (int i = 12; i < 29; i++) {
                   crc ^= uint8_t(png[static_cast<size_t>(i)]);
                   for (int k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
                 }
                 crc ^= 0xffffffffu;
                 for (int k = 0; k < 4; k++) png[29 + static_cast<size_t>(k)] = static_cast<char>(crc >> (24 - 8 * k));
                 writeFile(nthFile(s + "/rgb", 2), png);
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 2", "PNG of 25000x25000 pixels: more than the 268435456 (2^28) pixels dslam reads"}});
  c.push_back({"TUM rgb.txt", "timestamp that is not a number",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 std::string t = readFile(s + "/rgb.txt");
                 t += "abc rgb/x.png\n";
                 writeFile(s + "/rgb.txt", t);
                 fs::remove(s + "/associations.txt");
                 return "dataset info " + q(s);
               },
               1, {"rgb.txt:", "expected \"timestamp path\"", "abc rgb/x.png"}});
  c.push_back({"TUM rgb.txt", "repeated and out-of-order timestamps (accepted, as TUM's associate.py)",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 std::string t = readFile(s + "/rgb.txt");
                 const size_t first = t.find("\n1000");  // first data line
                 const std::string line = t.substr(first + 1, t.find('\n', first + 1) - first);
                 writeFile(s + "/rgb.txt", t + line);
                 fs::remove(s + "/associations.txt");
                 return "dataset info " + q(s);
               },
               0, {"rgb.txt: 1 repeated timestamp(s)", "1 out-of-order line(s)"}, "[warn]"});
  c.push_back({"TUM rgb image", "missing file",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 fs::remove(nthFile(s + "/rgb", 2));
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 2", "is missing"}});
  c.push_back({"TUM rgb image", "missing file, `dataset.on_bad_frame: skip`",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 fs::remove(nthFile(s + "/rgb", 2));
                 const std::string p = pipeline(d, readFile(source(kBaseline)) +
                                                       "dataset: {type: dslam::TumDataset, on_bad_frame: skip, "
                                                       "params: {path: " + s + "}}\n");
                 return "run " + q(p) + " --out " + q(d + "/out") + " --no-progress";
               },
               0, {"skipping frame 2", "is missing"}, "[warn]"});
  c.push_back({"TUM rgb image", "corrupt PNG",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 writeFile(nthFile(s + "/rgb", 2), "not a PNG file");
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 2", "cannot read image", "corrupt or unsupported image"}});
  // Damaged PNGs are found by dslam's own decoder: one message, no libpng line before it.
  c.push_back({"TUM rgb image", "PNG with one byte of its image data changed",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 std::string png = readFile(nthFile(s + "/rgb", 2));
                 png[png.find("IDAT") + 100] ^= 0x55;
                 writeFile(nthFile(s + "/rgb", 2), png);
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 2", "cannot read image", "(corrupt PNG: CRC error in chunk IDAT at byte"}});
  c.push_back({"TUM depth image", "PNG cut in half",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 const std::string png = readFile(nthFile(s + "/depth", 3));
                 writeFile(nthFile(s + "/depth", 3), png.substr(0, png.size() / 2));
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 3", "cannot read depth image", "(corrupt PNG: truncated: chunk IDAT"}});
  c.push_back({"TUM rgb image", "16-bit (a depth image in rgb/)",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 fs::copy_file(nthFile(s + "/depth", 1), nthFile(s + "/rgb", 1), fs::copy_options::overwrite_existing);
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 1", "is 16-bit; camera images must be 8-bit"}});
  c.push_back({"TUM depth image", "8-bit instead of 16-bit",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 fs::copy_file(nthFile(s + "/rgb", 1), nthFile(s + "/depth", 1), fs::copy_options::overwrite_existing);
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 1", "is not 16-bit single channel"}});
  c.push_back({"TUM depth image", "16-bit with three channels",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 const cv::Mat one = cv::imread(nthFile(s + "/depth", 1), cv::IMREAD_UNCHANGED);
                 cv::Mat three;
                 cv::merge(std::vector<cv::Mat>{one, one, one}, three);
                 cv::imwrite(nthFile(s + "/depth", 1), three);
                 return runBaseline(s, d + "/out");
               },
               1, {"frame 1", "is not 16-bit single channel"}});
  c.push_back({"TUM depth image", "empty (every pixel 0): tracked without depth",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 writeZeroDepth(nthFile(s + "/depth", 3), 320, 240);
                 return runBaseline(s, d + "/out");
               },
               0, {"frame 3", "has no valid depth", "tracked without depth"}, "[warn]"});
  c.push_back({"pipeline with `outputs.dense_map: true`", "RGB-D camera, but the dataset has no depth images",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 fs::remove(s + "/depth.txt");
                 fs::remove(s + "/associations.txt");
                 const std::string p = pipeline(d, readFile(source(kBaseline)) + "camera: $include{" + s +
                                                       "/camera.yaml}\noutputs: {dense_map: true}\n");
                 return "run " + q(p) + " --dataset " + q(s) + " --out " + q(d + "/out") + " --no-progress";
               },
               1, {"outputs.dense_map", "needs depth images (RGB-D) or a stereo pair", "frame 0"}});
  c.push_back({"KITTI calib.txt", "no matrix for the right camera",
               [](const std::string& d) {
                 const std::string k = d + "/kitti";
                 fs::create_directories(k + "/image_0");
                 fs::create_directories(k + "/image_1");
                 fs::copy_file(nthFile(tinyScene() + "/rgb", 0), k + "/image_0/000000.png");
                 fs::copy_file(nthFile(tinyScene() + "/rgb", 0), k + "/image_1/000000.png");
                 writeFile(k + "/calib.txt", "P0: 500 0 160 0 0 500 120 0 0 0 1 0\n");
                 return "dataset info " + q(k);
               },
               1, {"calib.txt", "no matrix P1 for the right camera"}});
  c.push_back({"EuRoC sensor.yaml", "no `T_BS`",
               [](const std::string& d) {
                 const std::string e = d + "/euroc";
                 fs::copy(shared("data/euroc-v101-micro"), e, fs::copy_options::recursive);
                 std::string y = readFile(e + "/mav0/cam0/sensor.yaml");
                 y.replace(y.find("T_BS:"), 5, "T_XX:");
                 writeFile(e + "/mav0/cam0/sensor.yaml", y);
                 return "dataset info " + q(e);
               },
               1, {"cam0/sensor.yaml", "missing key 'T_BS'"}});
  c.push_back({"MRPT rawlog", "not a rawlog (quoted in one line, no MRPT backtrace)",
               [](const std::string& d) {
                 writeFile(d + "/bad.rawlog", "this is not a rawlog\n");
                 return "dataset info " + q(d + "/bad.rawlog");
               },
               1, {"bad.rawlog", "cannot read object 0", "corrupt or truncated"}});
  c.push_back({"`dslam convert tum2rawlog` output", "a file of the input folder (groundtruth.txt)",
               [](const std::string& d) {
                 const std::string s = sceneCopy(d);
                 return "convert tum2rawlog " + q(s) + " " + q(s + "/groundtruth.txt");
               },
               1, {"output $DIR/tum/groundtruth.txt is a file of the dataset folder", "refusing to overwrite it"}});
  // ---- trajectories and evaluation -----------------------------------------
  c.push_back({"`dslam eval` ground truth", "file does not exist",
               [](const std::string& d) {
                 return "eval ate " + q(d + "/nothere.txt") + " " + q(tinyScene() + "/groundtruth.txt");
               },
               1, {"ground-truth trajectory file not found", "nothere.txt"}});
  c.push_back({"`dslam eval` estimate", "a file name longer than the file system allows",
               [](const std::string& d) {
                 return "eval ate " + q(tinyScene() + "/groundtruth.txt") + " " + q(d + "/" + std::string(300, 'e'));
               },
               1, {"/eee", ": File name too long"}});
  c.push_back({"`dslam eval` estimate", "a field that is not a number",
               [](const std::string& d) {
                 writeFile(d + "/est.txt", "1000.0 0 0 0 0 0 0 1\n1000.1 0 x 0 0 0 0 1\n");
                 return "eval ate " + q(tinyScene() + "/groundtruth.txt") + " " + q(d + "/est.txt");
               },
               1, {"est.txt:2", "field 3 is not a number"}});
  c.push_back({"`dslam eval` estimate", "unknown column count",
               [](const std::string& d) {
                 writeFile(d + "/est.txt", "1000.0 0 0 0 0\n");
                 return "eval ate " + q(tinyScene() + "/groundtruth.txt") + " " + q(d + "/est.txt");
               },
               1, {"est.txt:1", "cannot tell the trajectory format from 5 columns"}});
  c.push_back({"`dslam eval` estimate", "KITTI rows in a TUM file",
               [](const std::string& d) {
                 writeFile(d + "/est.txt", "1000.0 0 0 0 0 0 0 1\n1 0 0 0 0 1 0 0 0 0 1 0\n");
                 return "eval ate " + q(tinyScene() + "/groundtruth.txt") + " " + q(d + "/est.txt");
               },
               1, {"est.txt:2: 12 columns, a KITTI pose row, in a TUM file (line 1 has 8); one format per file"}});
  c.push_back({"`dslam eval` options", "`--plot` whose data file is the ground truth",
               [](const std::string& d) {
                 writeFile(d + "/gt.csv", "#t,x\n");
                 return "eval ate " + q(d + "/gt.csv") + " " + q(tinyScene() + "/groundtruth.txt") + " --plot " +
                        q(d + "/gt.png");
               },
               1, {"--plot (its data file) $DIR/gt.csv is an input file", "would be overwritten"}});
  c.push_back({"`dslam eval` options", "`--plot` to a format the plotter does not write",
               [](const std::string& d) {
                 return "eval ate " + q(tinyScene() + "/groundtruth.txt") + " " + q(tinyScene() + "/groundtruth.txt") +
                        " --plot " + q(d + "/p.txt");
               },
               1, {"--plot $DIR/p.txt: the picture must end in .png, .pdf, .svg or .jpg"}});
  c.push_back({"`dslam eval` estimate", "no timestamp near the ground truth",
               [](const std::string& d) {
                 writeFile(d + "/est.txt", "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n");
                 return "eval ate " + q(tinyScene() + "/groundtruth.txt") + " " + q(d + "/est.txt");
               },
               1, {"no ground-truth pose within max_dt", "spans"}});
  c.push_back({"`dslam eval` ground truth", "every position the same point, `--align sim3`",
               [](const std::string& d) {
                 writeFile(d + "/gt.txt", sceneStampsWithPose("1 2 3 0 0 0 1"));
                 return "eval ate " + q(d + "/gt.txt") + " " + q(tinyScene() + "/groundtruth.txt") + " --align sim3";
               },
               1, {"ground-truth positions are all the same point"}});
  c.push_back({"`dslam eval` estimate", "coordinates too large for double precision (1e200 m)",
               [](const std::string& d) {
                 writeFile(d + "/est.txt", sceneStampsWithPose("1e200 0 0 0 0 0 1"));
                 return "eval ate " + q(tinyScene() + "/groundtruth.txt") + " " + q(d + "/est.txt") + " --align none";
               },
               1, {"not finite numbers", "too large for double precision"}});
  c.push_back({"`dslam eval` ground truth", "repeated timestamp (accepted, as TUM's tools)",
               [](const std::string& d) {
                 std::string g = readFile(tinyScene() + "/groundtruth.txt");
                 const size_t first = g.find("\n1000");
                 g += g.substr(first + 1, g.find('\n', first + 1) - first);
                 writeFile(d + "/gt.txt", g);
                 return "eval ate " + q(d + "/gt.txt") + " " + q(tinyScene() + "/groundtruth.txt");
               },
               0, {"gt.txt: 1 repeated timestamp(s)"}, "[warn]"});
  // ---- scenarios, vocabularies, atlases, detectors --------------------------
  // ---- object maps (`dslam eval objects`) ------------------------------------
  c.push_back({"`dslam eval objects` run", "the scene's own objects.json instead of a run's",
               [](const std::string&) {
                 return "eval objects " + q(tinyScene() + "/objects.json") + " " + q(tinyScene());
               },
               1, {"objects.json", "ground-truth objects.json of the dslam synth scene", "not a run's object map"}});
  c.push_back({"`dslam eval objects` run", "folder without objects.json",
               [](const std::string& d) {
                 fs::create_directories(d + "/run");
                 return "eval objects " + q(d + "/run") + " " + q(tinyScene());
               },
               1, {"$DIR/run", "has no objects.json"}});
  c.push_back({"`dslam eval objects` run", "objects.json nested 100,000 levels deep",
               [](const std::string& d) {
                 fs::create_directories(d + "/run");
                 writeFile(d + "/run/objects.json", std::string(100000, '[') + std::string(100000, ']'));
                 return "eval objects " + q(d + "/run") + " " + q(tinyScene());
               },
               1, {"$DIR/run/objects.json:1:257", "nested more than 256 levels deep"}});
  c.push_back({"`dslam eval objects` run", "objects.json of another format",
               [](const std::string& d) {
                 writeFile(d + "/objects.json", "{\"format\": \"coco\", \"objects\": []}\n");
                 return "eval objects " + q(d + "/objects.json") + " " + q(tinyScene()) + " --align none";
               },
               1, {"$DIR/objects.json", "not a dslam object map", "expected \"dslam-objects\""}});
  c.push_back({"`dslam eval objects` run", "unknown class id",
               [](const std::string& d) {
                 return "eval objects " + q(objectsRun(d, estObject("\"class_id\": 300"))) + " " + q(tinyScene());
               },
               1, {"$DIR/run/objects.json", "objects[0] (id 1)", "unknown class id 300"}});
  c.push_back({"`dslam eval objects` run", "unknown class name",
               [](const std::string& d) {
                 return "eval objects " + q(objectsRun(d, estObject("\"class\": \"chiar\""))) + " " + q(tinyScene());
               },
               1, {"$DIR/run/objects.json", "unknown class 'chiar'"}});
  c.push_back({"`dslam eval objects` run", "no objects (accepted: scored as an empty map)",
               [](const std::string& d) { return "eval objects " + q(objectsRun(d, "")) + " " + q(tinyScene()); }, 0,
               {"$DIR/run/objects.json", "no objects in map 0"}, "[warn]"});
  c.push_back({"`dslam eval objects` scene", "folder without objects.json",
               [](const std::string& d) {
                 fs::create_directories(d + "/scene");
                 return "eval objects " + q(objectsRun(d, estObject("\"class_id\": 62"))) + " " + q(d + "/scene");
               },
               1, {"$DIR/scene", "no objects.json"}});
  c.push_back({"`dslam eval objects` scene", "folder without groundtruth.txt",
               [](const std::string& d) {
                 fs::create_directories(d + "/scene");
                 fs::copy_file(tinyScene() + "/objects.json", d + "/scene/objects.json");
                 return "eval objects " + q(objectsRun(d, estObject("\"class_id\": 62"))) + " " + q(d + "/scene");
               },
               1, {"$DIR/scene", "no groundtruth.txt"}});
  c.push_back({"`dslam eval objects` scene", "depth.txt line without a file name",
               [](const std::string& d) {
                 fs::create_directories(d + "/scene");
                 for (const char* f : {"objects.json", "groundtruth.txt"})
                   fs::copy_file(tinyScene() + "/" + f, d + "/scene/" + f);
                 writeFile(d + "/scene/depth.txt", "# timestamp filename\n1000.0\n");
                 return "eval objects " + q(objectsRun(d, estObject("\"class_id\": 62"))) + " " + q(d + "/scene");
               },
               1, {"$DIR/scene/depth.txt:2", "expected 'timestamp path'"}});
  c.push_back({"`dslam eval objects` run and scene", "trajectory of another time span",
               [](const std::string& d) {
                 const std::string t = "10.0 0 0 0 0 0 0 1\n10.1 1 0 0 0 0 0 1\n10.2 0 1 0 0 0 0 1\n";
                 return "eval objects " + q(objectsRun(d, estObject("\"class_id\": 62"), t)) + " " + q(tinyScene());
               },
               1, {"the run and the scene do not match", "no ground-truth pose within max_dt"}});
  c.push_back({"`dslam eval objects` run and scene", "trajectory of another camera path (same stamps)",
               [](const std::string& d) {
                 std::istringstream in(readFile(tinyScene() + "/groundtruth.txt"));
                 std::string line, t;
                 int i = 0;
                 while (std::getline(in, line)) {
                   if (line.empty() || line[0] == '#') continue;
                   const std::string stamp = line.substr(0, line.find(' '));
                   t += stamp + " " + std::to_string(2 * std::cos(1.3 * i)) + " " + std::to_string(2 * std::sin(2.1 * i)) +
                        " " + std::to_string(0.5 * i) + " 0 0 0 1\n";
                   i++;
                 }
                 return "eval objects " + q(objectsRun(d, estObject("\"class_id\": 62"), t)) + " " + q(tinyScene());
               },
               1, {"the run and the scene do not match: ATE rmse", "$DIR/run/trajectory.txt", "--max-ate"}});
  c.push_back({"scenario YAML", "frame rate too high for microsecond stamps",
               [](const std::string& d) {
                 writeFile(d + "/scene.yaml", "name: x\nrate: 1e9\n");
                 return "synth " + q(d + "/scene.yaml") + " --out " + q(d + "/out");
               },
               1, {"scene.yaml:2", "rate", "must be at most 100000"}});
  c.push_back({"pipeline YAML", "nested 20,000 levels deep",
               [](const std::string& d) {
                 return "config check " +
                        q(pipeline(d, "pipeline: {name: x}\nfeatures: {n_features: " + std::string(20000, '[') +
                                          std::string(20000, ']') + "}\n"));
               },
               1, {"pipeline.yaml:2: nested more than 256 levels deep"}});
  c.push_back({"pipeline YAML", "a NUL byte",
               [](const std::string& d) {
                 static const char text[] = "pipeline: {name: x}\n# \0\nfeatures: {n_features: 7}\n";
                 return "config check " + q(pipeline(d, std::string(text, sizeof text - 1)));
               },
               1, {"pipeline.yaml:2: a NUL byte"}});
  c.push_back({"pipeline YAML", "a second document (`---`)",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\n---\nfeatures: {n_features: 7}\n"));
               },
               1, {"pipeline.yaml:2: a second YAML document starts here"}});
  c.push_back({"pipeline YAML", "an anchor (`&n`)",
               [](const std::string& d) {
                 return "config check " + q(pipeline(d, "pipeline: {name: x}\nfeatures:\n  n_features: &n 900\n"));
               },
               1, {"pipeline.yaml:3: YAML anchors (&name) are not supported"}});
  c.push_back({"pipeline YAML", "`pipeline.name` that climbs out of `out/`",
               [](const std::string& d) { return "config check " + q(pipeline(d, "pipeline: {name: ../../x}\n")); }, 1,
               {"pipeline.yaml:1", "cannot name the default output folder"}});
  c.push_back({"image given to `dslam detect`", "two inputs of one name with `--out DIR`",
               [](const std::string& d) {
                 const std::string img = nthFile(tinyScene() + "/rgb", 0);
                 fs::create_directories(d + "/a");
                 fs::create_directories(d + "/b");
                 fs::copy_file(img, d + "/a/x.png");
                 fs::copy_file(img, d + "/b/x.png");
                 return "detect HogPeopleDetector " + q(d + "/a/x.png") + " " + q(d + "/b/x.png") + " --out " + q(d + "/o");
               },
               1, {"--out $DIR/o: ", "/a/x.png and ", "/b/x.png would both be written to ", "/o/x_det.png"}});
  c.push_back({"image given to `dslam detect`", "JPEG cut short (libjpeg would decode it with a grey bottom half)",
               [](const std::string& d) {
                 const cv::Mat img = cv::imread(nthFile(tinyScene() + "/rgb", 0), cv::IMREAD_COLOR);
                 cv::imwrite(d + "/x.jpg", img);
                 const std::string jpg = readFile(d + "/x.jpg");
                 writeFile(d + "/x.jpg", jpg.substr(0, jpg.size() / 2));
                 return "detect HogPeopleDetector " + q(d + "/x.jpg");
               },
               1, {"cannot read image", "(corrupt JPEG: truncated: the file (", "ends inside the image data"}});
  c.push_back({"image given to `dslam detect`", "a folder",
               [](const std::string& d) { return "detect HogPeopleDetector " + q(d); }, 1,
               {"cannot read image", "(a folder, not an image file)"}});
  c.push_back({"scenario YAML", "unknown key",
               [](const std::string& d) {
                 writeFile(d + "/scene.yaml", "name: x\nrom: {}\n");
                 return "synth " + q(d + "/scene.yaml") + " --out " + q(d + "/out");
               },
               1, {"scene.yaml:2", "unknown key 'rom'", "did you mean 'room'"}});
  c.push_back({"`dslam vocab train` output", "one of its training images",
               [](const std::string& d) {
                 const std::string img = nthFile(tinyScene() + "/rgb", 0);
                 fs::create_directories(d + "/imgs");
                 fs::copy_file(img, d + "/imgs/a.png");
                 return "vocab train --images " + q(d + "/imgs") + " -o " + q(d + "/imgs/a.png") + " --format binary";
               },
               1, {"--out $DIR/imgs/a.png is a file of the training input", "would be overwritten"}});
  c.push_back({"vocabulary", "file does not exist",
               [](const std::string& d) { return "vocab info " + q(d + "/nothere.dvoc.gz"); }, 1,
               {"vocabulary not found", "nothere.dvoc.gz"}});
  c.push_back({"vocabulary", "truncated gzip",
               [](const std::string& d) {
                 std::ifstream in(source("modules/place_recognition/data/orb_k10l5.dvoc.gz"), std::ios::binary);
                 std::string bytes(4096, '\0');
                 in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
                 writeFile(d + "/cut.dvoc.gz", bytes);
                 return "vocab info " + q(d + "/cut.dvoc.gz");
               },
               1, {"cut.dvoc.gz"}});
  c.push_back({"atlas (`--load-atlas`)", "not an atlas file",
               [](const std::string& d) {
                 writeFile(d + "/atlas.bin", "garbage");
                 return "run " + q(source(kBaseline)) + " --dataset " + q(tinyScene()) + " --out " + q(d + "/out") +
                        " --load-atlas " + q(d + "/atlas.bin") + " --no-progress";
               },
               1, {"atlas.bin is not a dslam atlas file"}});
  c.push_back({"detector model", "weights file does not exist",
               [](const std::string& d) {
                 return "detect DarknetYoloDetector -p " + q("weights=" + d + "/none.weights") + " -p " +
                        q("cfg=" + d + "/none.cfg") + " " + q(nthFile(tinyScene() + "/rgb", 0));
               },
               1, {"none."}});
  c.push_back({"detector parameter", "unknown parameter on the command line",
               [](const std::string& d) {
                 (void)d;
                 return "detect FileDetector -p path=x " + q(nthFile(tinyScene() + "/rgb", 0));
               },
               1, {"--param path", "unknown parameter of dslam::FileDetector"}});
  c.push_back({"box label file (JSON)", "syntax error",
               [](const std::string& d) {
                 fs::create_directories(d + "/labels/boxes");
                 const std::string img = nthFile(tinyScene() + "/rgb", 0);
                 writeFile(d + "/labels/boxes/" + fs::path(img).stem().string() + ".json",
                           "{\"boxes\": [{\"category_id\": 1, \"bbox\": [1, 2, 3");
                 return "detect FileDetector -p " + q("dir=" + d + "/labels") + " " + q(img);
               },
               1, {".json:1:", "invalid JSON"}});
  c.push_back({"command line", "unknown option",
               [](const std::string&) { return std::string("run --no-such-option x.yaml"); }, 109,
               {"--no-such-option"}, "The following argument"});
  c.push_back({"command line", "option value out of range",
               [](const std::string&) { return std::string("eval objects run scene --min-points -1"); }, 105,
               {"must be at least 0, got -1"}, "--min-points:"});
  c.push_back({"command line", "required argument missing",
               [](const std::string&) { return std::string("eval objects"); }, 106, {"is required"}, "run is required"});
  return c;
}

/** Paths of this machine replaced by placeholders; lists of valid names shortened. */
std::string normalize(std::string s, const std::string& dir) {
  auto repl = [&](const std::string& from, const std::string& to) {
    if (from.empty()) return;
    for (size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
  };
  repl(dir, "$DIR");
  repl(tinyScene(), "$SCENE");
  repl(fs::weakly_canonical(source("")).string(), "$SRC/");
  repl(source(""), "$SRC/");
  repl("$SRC//", "$SRC/");
  s = std::regex_replace(s, std::regex(R"(\(valid( [A-Za-z]+ plugins)?: [^)]*\))"), "(valid$1: ...)");
  return s;
}

/** The message line: the last line that starts with `prefix`. */
std::string messageLine(const std::string& out, const std::string& prefix) {
  std::istringstream in(out);
  std::string line, found;
  while (std::getline(in, line)) {
    const size_t p = line.find(prefix);
    if (p != std::string::npos && line.find_first_not_of(' ') == p) found = line;
  }
  return found;
}

std::string mdCell(std::string s) {
  for (size_t p = s.find('|'); p != std::string::npos; p = s.find('|', p + 2)) s.replace(p, 1, "\\|");
  return s;
}

TEST(BadInput, EveryCaseGivesItsMessageAndDocsErrorsIsCurrent) {
  std::ostringstream md;
  md << "# What dslam says about bad input\n\n"
        "Generated by `tests/apps/test_bad_input.cpp` (`DSLAM_UPDATE_DOCS=1 build/tests/apps/test_bad_input`\n"
        "rewrites this page; the test fails when the page and the program disagree). Every row is a\n"
        "real run of the `dslam` command shown, on a bad copy of a small rendered scene or of a file\n"
        "from the shared folder. `$DIR` is the case's folder, `$SCENE` a rendered 8-frame TUM-layout\n"
        "scene, `$SRC` the source tree; lists of valid names are shortened to `(valid: ...)`.\n\n"
        "Exit codes: 0 = success (a warning line says what was accepted or skipped), 1 = error\n"
        "(nothing is left half-written: outputs written so far are complete, see\n"
        "[slam.md](slam.md)), 105-109 = command line (CLI11: 105 a value out of range, 106 a\n"
        "required argument missing, 109 an unknown option), 128 + signal = stopped by\n"
        "SIGINT/SIGTERM after writing every output.\n\n"
        "| input | what is wrong | command | message | exit |\n|---|---|---|---|---|\n";
  const auto all = cases();
  ASSERT_GE(all.size(), 30u);
  int k = 0;
  for (const Case& c : all) {
    const std::string dir = tempDir("bad_input_" + std::to_string(k++));
    SCOPED_TRACE(c.input + ": " + c.wrong);
    const std::string args = c.setup(dir);
    const auto r = runDslam(args + " 2>&1");
    EXPECT_EQ(r.exit_code, c.exit_code) << r.out;
    const std::string msg = messageLine(r.out, c.line_prefix);
    EXPECT_FALSE(msg.empty()) << "no line starting with '" << c.line_prefix << "' in:\n" << r.out;
    // The list of valid names grows with the registry; the quoted rest is short.
    std::string quoted = msg;
    if (const size_t v = quoted.find("(valid "); v != std::string::npos)
      quoted.erase(v, quoted.find(')', v) == std::string::npos ? std::string::npos : quoted.find(')', v) - v + 1);
    EXPECT_LE(quoted.size(), 700u) << "messages quote, they do not dump";
    for (const auto& m : c.must) {
      std::string want = m;
      if (const size_t p = want.find("$DIR"); p != std::string::npos) want.replace(p, 4, dir);
      EXPECT_NE(msg.find(want), std::string::npos) << "'" << want << "' not in: " << msg;
    }
    // No crash, no stack trace, no exception dump.
    for (const char* bad : {"terminate called", "Segmentation", "MRPT exception", "Aborted", "backtrace", "libpng",
                            "Premature end of JPEG"})
      EXPECT_EQ(r.out.find(bad), std::string::npos) << bad << " in:\n" << r.out;
    md << "| " << mdCell(c.input) << " | " << mdCell(c.wrong) << " | `dslam " << mdCell(normalize(args, dir))
       << "` | `" << mdCell(normalize(msg, dir)) << "` | " << r.exit_code << " |\n";
  }
  const std::string page = source("docs/errors.md");
  const char* update = std::getenv("DSLAM_UPDATE_DOCS");
  if (update && std::string(update) == "1") {
    writeFile(page, md.str());
    return;
  }
  EXPECT_TRUE(readFile(page) == md.str())
      << "docs/errors.md is out of date: run DSLAM_UPDATE_DOCS=1 build/tests/apps/test_bad_input\n" << md.str();
}

}  // namespace
}  // namespace dslam::test
