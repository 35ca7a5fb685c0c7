// Fuzz target: the rig file reader (OpenCV FileStorage YAML; io/rig_file.h).
#include "fuzz/fuzz_target.h"
#include "flatscan/io/rig_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return flatscan::fuzz::ReadAsFile(data, size, "rig.yml", [](const auto& p) { flatscan::ReadRigFile(p); });
}
