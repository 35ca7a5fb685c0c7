#pragma once
// A fuzz target: LLVMFuzzerTestOneInput feeds one input to one of flatscan's readers.
// An InputError is the expected answer to a bad input; anything else (another exception,
// a crash, a sanitizer report, a hang) is a finding. Built twice (fuzz/CMakeLists.txt):
// with libFuzzer by scripts/fuzz.sh (clang), and with a replay main that ctest runs over
// the target's corpus in fuzz/corpus/<target>/ (any compiler).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "flatscan/util/error.h"

namespace flatscan::fuzz {

// Writes the input to a private file named `name` (the readers take paths and choose by
// extension) and calls read(path); InputError is swallowed, everything else propagates.
inline int ReadAsFile(const uint8_t* data, size_t size, const std::string& name,
                      const std::function<void(const std::filesystem::path&)>& read) {
  static const std::filesystem::path dir = [] {
    const auto d = std::filesystem::temp_directory_path() / ("flatscan-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  const std::filesystem::path path = dir / name;
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    read(path);
  } catch (const InputError&) {
  }
  return 0;
}

}  // namespace flatscan::fuzz
