// Fuzz target: the plane file reader (io/rig_file.h).
#include "fuzz/fuzz_target.h"
#include "flatscan/io/rig_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return flatscan::fuzz::ReadAsFile(data, size, "plane.yml", [](const auto& p) { flatscan::ReadPlaneFile(p); });
}
