// embed_system [PIPELINE.yaml] [SCENARIO.yaml] [--frames N] [--size WxH]
//
// dslam as a library: builds the System a pipeline YAML describes
// (dslam::buildSystem) and feeds it frames this program produces itself,
// here rendered in memory by the synth module (no files, no dataset reader).
// Prints the estimated camera pose of every frame, then the ATE against the
// renderer's exact poses (dslam::eval).
//
// Defaults: the installed orbslam_baseline pipeline and walking_static
// scenario (dslam_CONFIG_DIR), 60 frames at 320x240.
#include <dslam/config/pipeline.h>
#include <dslam/core/error.h>
#include <dslam/core/registry.h>
#include <dslam/eval/eval.h>
#include <dslam/slam/system.h>
#include <dslam/synth/renderer.h>

#include <cstdio>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
  std::string pipeline = std::string(DSLAM_CONFIG_DIR) + "/pipelines/orbslam_baseline.yaml";
  std::string scenario = std::string(DSLAM_CONFIG_DIR) + "/scenarios/walking_static.yaml";
  int frames = 60, width = 320, height = 240;
  int positional = 0;
  for (int i = 1; i < argc; i++) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc) {
      frames = std::stoi(argv[++i]);
    } else if (a == "--size" && i + 1 < argc && std::sscanf(argv[i + 1], "%dx%d", &width, &height) == 2) {
      i++;
    } else if (a[0] != '-' && positional < 2) {
      (positional++ == 0 ? pipeline : scenario) = a;
    } else {
      std::cerr << "usage: embed_system [PIPELINE.yaml] [SCENARIO.yaml] [--frames N] [--size WxH]\n";
      return 2;
    }
  }
  try {
    dslam::register_builtin_plugins();  // before loading a pipeline: it names plug-ins

    // The frame source: a synthetic scene rendered in memory.
    dslam::synth::ScenarioOverrides ov;
    ov.frames = frames;
    ov.width = width;
    ov.height = height;
    const dslam::synth::Scenario sc = dslam::synth::loadScenario(scenario, ov);
    dslam::synth::RenderOptions ro;
    ro.right = false;
    const dslam::synth::Renderer renderer(sc, ro);
    const dslam::CameraModel camera = renderer.cameraModel();

    // The SLAM system of the pipeline file, for that camera.
    const dslam::config::PipelineConfig pc = dslam::config::loadPipeline(pipeline);
    std::unique_ptr<dslam::System> sys = dslam::buildSystem(pc, camera);
    std::cout << "pipeline " << pc.name << " (" << pipeline << ") on " << sc.name << ", " << renderer.frames()
              << " frames " << width << "x" << height << "\n";

    dslam::Trajectory truth;
    for (int i = 0; i < renderer.frames(); i++) {
      const dslam::synth::FrameRender r = renderer.render(i);
      dslam::SensorFrame sf;
      sf.index = i;
      sf.timestamp = r.timestamp;
      sf.image = r.rgb;
      r.depth.convertTo(sf.depth, CV_32F, 1.0 / camera.depth_factor);  // 16-bit sensor units -> metres
      const dslam::FrameResult fr = sys->track(sf);
      truth.stamps.push_back(r.timestamp);
      truth.poses.push_back(r.T_wc);
      if (fr.track.T_cw) {
        const Eigen::Vector3d p = fr.track.T_cw->inverse().translation();
        std::printf("frame %3d  t=%.3f  %-8s  x=%+.4f y=%+.4f z=%+.4f\n", i, r.timestamp,
                    dslam::toString(fr.track.state), p.x(), p.y(), p.z());
      } else {
        std::printf("frame %3d  t=%.3f  %-8s\n", i, r.timestamp, dslam::toString(fr.track.state));
      }
    }
    sys->shutdown();
    const dslam::Trajectory est = sys->cameraTrajectory();
    const auto ate = dslam::eval::computeAte(truth, est);
    std::printf("tracked %zu of %d frames, %zu keyframes; ATE %.4f m RMSE (%zu poses, SE(3) alignment)\n",
                est.size(), renderer.frames(), sys->keyframeTrajectory().size(), ate.stats.rmse, ate.stats.count);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
