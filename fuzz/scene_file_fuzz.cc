// Fuzz target: the scene file reader, JSON form (simulation/scene_config.h).
#include "fuzz/fuzz_target.h"
#include "flatscan/simulation/scene_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return flatscan::fuzz::ReadAsFile(data, size, "scene.json", [](const auto& p) { flatscan::LoadSceneFile(p); });
}
