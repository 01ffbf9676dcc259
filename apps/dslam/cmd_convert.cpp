// `dslam convert tum2rawlog IN_DIR OUT.rawlog` and
// `dslam convert rawlog2tum IN.rawlog OUT_DIR` (docs/datasets.md).
#include <iostream>

#include "command.h"
#include "dslam/plugins/datasets/convert.h"

namespace {

void setup(CLI::App& sub) {
  sub.require_subcommand(1);
  static std::string in, out;
  static dslam::TumToRawlogOptions t2r;
  static dslam::RawlogToTumOptions r2t;

  auto* a = sub.add_subcommand("tum2rawlog", "TUM RGB-D folder -> MRPT rawlog of CObservation3DRangeScan (lossless)");
  a->add_option("in", in, "TUM folder (rgb.txt + depth.txt or associations.txt)")->required();
  a->add_option("out", out, "output .rawlog file")->required();
  a->add_option("--camera", t2r.camera_file, "camera YAML file (docs/config.md); default: the TUM reader's choice");
  a->add_option("--preset", t2r.preset, "camera preset (tum_fr1, tum_fr2, tum_fr3, bonn)");
  a->add_option("--associations", t2r.associations, "association file inside the folder");
  a->add_option("--max-dt", t2r.max_dt, "rgb/depth association threshold, seconds")->capture_default_str();
  a->add_option("--label", t2r.sensor_label, "sensor label of the observations")->capture_default_str();
  a->add_option("--compression", t2r.compression, "gzip level 0-9")->capture_default_str()->check(CLI::Range(0, 9));
  a->callback([] {
    const auto r = dslam::convertTumToRawlog(in, out, t2r);
    std::cout << "wrote " << out << ": " << r.frames << " CObservation3DRangeScan, sensor '" << t2r.sensor_label
              << "', depth factor " << r.depth_factor << " (rangeUnits " << 1.0 / r.depth_factor << "), camera "
              << r.camera << "\n";
  });

  auto* b = sub.add_subcommand("rawlog2tum", "MRPT rawlog (RGB-D or monocular) -> TUM RGB-D folder");
  b->add_option("in", in, "input .rawlog file")->required();
  b->add_option("out", out, "output folder")->required();
  b->add_option("--label", r2t.sensor_label, "sensor label to convert (default: the only camera label)");
  b->add_option("--images-dir", r2t.images_dir, "folder of external images (default: <rawlog>_Images)");
  b->add_option("--depth-factor", r2t.depth_factor,
                "depth PNG units per metre (default 0: the rawlog's own 1/rangeUnits, lossless)")
      ->capture_default_str()
      ->check(dslam::app::kNonNegative);
  b->add_flag("--overwrite", r2t.overwrite, "write into a folder that already has rgb.txt");
  b->callback([] {
    const auto r = dslam::convertRawlogToTum(in, out, r2t);
    std::cout << "wrote " << out << ": " << r.frames << " frames";
    if (r.depth_factor > 0)
      std::cout << ", depth factor " << r.depth_factor << (r.depth_exact ? " (raw depth copied bit-exactly)" : " (depth requantised)");
    if (r.depth_clipped) std::cout << ", " << r.depth_clipped << " depth pixels out of range set to 0";
    std::cout << "\n";
  });
}

}  // namespace

DSLAM_COMMAND(convert, "Convert datasets (tum2rawlog, rawlog2tum)", setup);
