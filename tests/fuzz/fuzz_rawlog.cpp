// Fuzz target: the MRPT rawlog reader (RawlogDataset: the scan in
// configure() and decoding the first frames). Input = the .rawlog bytes
// (plain; MRPT's gzip detection is exercised by seeds that are gzipped).
#include "dslam/core/params.h"
#include "dslam/core/plugin.h"
#include "dslam/plugins/datasets/rawlog.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = dslam::fuzz::writeFile("seq.rawlog", data, size);
  dslam::fuzz::guarded([&] {
    dslam::RawlogDataset ds;
    const auto p = dslam::Params::resolve(ds.paramSpecs(), "path: '" + path + "'\n");
    ds.configure(p, dslam::PluginContext{});
    for (size_t i = 0; i < std::min<size_t>(ds.size(), 3); i++) (void)ds.read(i);
  });
  return 0;
}
