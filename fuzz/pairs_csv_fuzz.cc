// Fuzz target: the pairs CSV reader (io/pairs_csv.h).
#include "fuzz/fuzz_target.h"
#include "flatscan/io/pairs_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return flatscan::fuzz::ReadAsFile(data, size, "pairs.csv", [](const auto& p) { flatscan::ReadPairsCsv(p); });
}
